"""Fig. 6: polynomial force fit, its analytic potential, the profile fit, and the example data set."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.polynomial import Polynomial

from spherestep.errors import InputError
from spherestep.potential import (
    VonMisesFisher,
    example_force_curve,
    fit_force_curve,
    fit_profile,
    load_force_curve,
    pair_potential,
    potential_from_force,
    save_force_curve,
    synthetic_force_curve,
)
from spherestep.potential.force import EXAMPLE_RADIUS, EXAMPLE_ROTOR, EXAMPLE_STATOR

DATA = Path(__file__).resolve().parents[1] / "data" / "force_curve_example.csv"
TRUE = np.array([0.05, -310.0, 2.0e3, 1.5e5, -4.0e6])  # N, N/m, ..., N/m⁴: a restoring curve on 0..40 mm


def test_polynomial_fit_recovers_a_known_quartic_from_noisy_samples():
    rng = np.random.default_rng(7)
    x = np.linspace(0.0, 0.04, 81)
    sigma = 0.05
    F = Polynomial(TRUE)(x) + rng.normal(0.0, sigma, x.size)
    poly = fit_force_curve(x, F)
    assert isinstance(poly, Polynomial) and poly.degree() == 4
    # standard errors of ordinary least squares, computed here independently: σ² (XᵀX)⁻¹
    X = np.vander(x, 5, increasing=True)
    se = sigma * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))
    assert np.all(np.abs(poly.coef - TRUE) <= 4.0 * se)
    # and the fitted curve is within 3σ/√(n/5) of the true one everywhere on the data range
    assert np.max(np.abs(poly(x) - Polynomial(TRUE)(x))) <= 3 * sigma / np.sqrt(x.size / 5)
    # without noise the coefficients come back to 1e-9 relative
    exact = fit_force_curve(x, Polynomial(TRUE)(x))
    assert np.max(np.abs(exact.coef - TRUE) / np.abs(TRUE)) <= 1e-9


def test_potential_is_minus_the_integral_of_the_force():
    F = Polynomial(TRUE)
    V = potential_from_force(F)
    expected = -np.concatenate([[0.0], TRUE / np.arange(1, 6)])
    assert np.allclose(V.coef, expected, rtol=1e-14, atol=0)
    assert V(0.0) == 0.0
    x = np.linspace(0, 0.04, 9)
    assert np.allclose(-V.deriv()(x), F(x), rtol=1e-12)
    # a fit in a scaled domain integrates to the same thing
    scaled = Polynomial.fit(x, F(x), 4)
    assert np.allclose(potential_from_force(scaled)(x), V(x), rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("kappa, amplitude", [(51.02716008498338, 6.0), (120.0, 2.5)])
def test_profile_fit_recovers_known_parameters(kappa, amplitude):
    stator = VonMisesFisher(kappa, amplitude)
    x = np.linspace(0.0, 0.04, 41)
    F = synthetic_force_curve(x, EXAMPLE_ROTOR, stator, EXAMPLE_RADIUS)
    fit = fit_profile(x, F, EXAMPLE_RADIUS, EXAMPLE_ROTOR)
    assert fit.success
    # through the paper's quartic: measured 1.4e-4 (κ) and 1.3e-5 (A) for the first case
    assert fit.stator.kappa == pytest.approx(kappa, rel=2e-3)
    assert fit.stator.amplitude == pytest.approx(amplitude, rel=2e-3)
    fine = fit_profile(x, F, EXAMPLE_RADIUS, EXAMPLE_ROTOR, degree=8)  # a closer polynomial: measured 4e-7
    assert fine.stator.kappa == pytest.approx(kappa, rel=2e-5)
    assert fine.stator.amplitude == pytest.approx(amplitude, rel=2e-5)
    # the fitted model reproduces the integrated curve it was fitted to
    assert np.max(np.abs(fit.potential(x) - fit.potential_polynomial(x))) <= 1e-2 * fit.potential_polynomial(x).max()


def test_model_force_is_the_derivative_of_the_pair_potential():
    x = np.linspace(0.001, 0.04, 12)
    F = synthetic_force_curve(x, EXAMPLE_ROTOR, EXAMPLE_STATOR, EXAMPLE_RADIUS)
    h = 1e-7
    dV = (pair_potential(EXAMPLE_ROTOR, EXAMPLE_STATOR, (x + h) / EXAMPLE_RADIUS)
          - pair_potential(EXAMPLE_ROTOR, EXAMPLE_STATOR, (x - h) / EXAMPLE_RADIUS)) / (2 * h)
    assert np.allclose(F, -dV, rtol=1e-6)
    assert np.all(F < 0)  # attraction: restoring force


def test_example_data_set_is_reproducible_and_labelled_generated():
    text = DATA.read_text(encoding="utf-8")
    assert text.startswith("# GENERATED data, NOT a measurement.")
    x, F = load_force_curve(DATA)
    x0, F0 = example_force_curve()
    assert np.allclose(x, x0, rtol=1e-6, atol=1e-12) and np.allclose(F, F0, rtol=1e-6, atol=1e-12)
    readme = (DATA.parent / "README.md").read_text(encoding="utf-8")
    assert "GENERATED, not measured" in readme and "1999" in readme
    fit = fit_profile(x, F, EXAMPLE_RADIUS, EXAMPLE_ROTOR)
    assert fit.stator.kappa == pytest.approx(EXAMPLE_STATOR.kappa, rel=0.03)  # measured 0.8 % (noise 0.1 N)
    assert fit.stator.amplitude == pytest.approx(EXAMPLE_STATOR.amplitude, rel=0.02)


def test_save_and_load_round_trip(tmp_path):
    x = np.linspace(0, 0.01, 5)
    F = -x * 100
    path = save_force_curve(tmp_path / "curve.csv", x, F, "made up\nsecond line")
    assert path.read_text().splitlines()[:3] == ["# made up", "# second line", "displacement_m,force_N"]
    x2, F2 = load_force_curve(path)
    assert np.allclose(x2, x, rtol=1e-6) and np.allclose(F2, F, rtol=1e-6)


def test_force_bad_inputs(tmp_path):
    x = np.linspace(0, 0.04, 10)
    cases = [
        (lambda: fit_force_curve(x, x[:-1]), "force"),
        (lambda: fit_force_curve(np.zeros(10), x), "displacement"),
        (lambda: fit_force_curve(x, x, degree=-1), "degree"),
        (lambda: fit_force_curve(x[:, None], x), "displacement"),
        (lambda: potential_from_force([1.0, 2.0]), "poly"),
        (lambda: fit_profile(x, -x, 0.0, EXAMPLE_ROTOR), "radius"),
        (lambda: fit_profile(x, -x, 0.15, "vMF"), "rotor_profile"),
        (lambda: synthetic_force_curve(x, EXAMPLE_ROTOR, EXAMPLE_STATOR, 0.15, noise=-1.0), "noise"),
        (lambda: load_force_curve(tmp_path / "missing.csv"), "path"),
    ]
    for call, name in cases:
        with pytest.raises(InputError, match=rf"^{name} must"):
            call()
    with pytest.raises(InputError, match="^force must describe an attracting coil"):
        fit_profile(x, 100 * x, 0.15, EXAMPLE_ROTOR)  # pushes away: not an attracting coil
    bad = tmp_path / "bad.csv"
    bad.write_text("x,y\n1,2\n")
    with pytest.raises(InputError, match="^path must be a CSV whose header"):
        load_force_curve(bad)
