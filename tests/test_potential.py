"""spherestep.potential: the energy of eq. (4) in its three forms, the torque and Hessian, the SO(3) grid.

Independent references: the Bessel closed form of the von Mises–Fisher Legendre coefficients, the closed-form
overlap of two vMF bumps, adaptive quadrature (SciPy), brute-force quadrature over the sphere, explicit Wigner
matrices (``wigner_D``), and central finite differences. Tolerances are stated at each assertion; the measured
errors are in docs/potential.md.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import eval_legendre

from spherestep import so3
from spherestep.errors import InputError
from spherestep.packing import Packing
from spherestep.potential import (
    MotorPotential,
    RaisedCosine,
    VonMisesFisher,
    ZonalKernel,
    coil_currents,
    pair_potential,
)


@pytest.fixture(scope="module")
def small(proto):
    """A strongly truncated model (L = 10): the band-limited identities must still hold exactly."""
    return MotorPotential(proto, bandlimit=10)


def random_inputs(design, count, seed):
    rng = np.random.default_rng(seed)
    return so3.random(count, rng), rng.uniform(-1.0, 1.0, size=(count, len(design.stator)))


# ------------------------------------------------------------------------------------------------ profiles


@pytest.mark.parametrize("kappa", [0.5, 3.0, 51.02716008498338, 200.6655091620246, 1000.0])
def test_legendre_coefficients_match_the_bessel_closed_form(kappa):
    f = VonMisesFisher(kappa, 1.7)
    got = f.legendre_coefficients(150)
    exact = f.exact_coefficients(150)
    # rounding of exp(κ(t−1)) near t = 1 is ~κ·1e-16 relative
    assert np.max(np.abs(got - exact)) <= max(1e-13, 2e-15 * kappa) * exact[0]


def test_raised_cosine_coefficients_against_adaptive_quadrature():
    f = RaisedCosine(np.radians(8.0), 2.0)
    lam = f.legendre_coefficients(80)
    for l in (0, 1, 7, 33, 80):
        ref = 2 * np.pi * quad(lambda t: f(t) * eval_legendre(l, t), np.cos(np.radians(8.0)), 1.0,
                               epsabs=1e-16, epsrel=1e-13, limit=400)[0]
        assert abs(lam[l] - ref) <= 1e-12 * lam[0]


def test_half_width_and_bandwidth(proto, model):
    f = VonMisesFisher.from_half_width(proto.magnet_angle)
    assert float(f(np.cos(proto.magnet_angle))) == pytest.approx(0.5, abs=1e-12)
    assert f.half_width == pytest.approx(proto.magnet_angle, rel=1e-12)
    # the default band limit keeps all but 1e-10 of each profile's squared norm
    for profile in (model.rotor_profile, model.stator_profile):
        L = model.bandlimit
        lam = profile.legendre_coefficients(3 * L)
        energy = lam**2 * (2 * np.arange(3 * L + 1) + 1)
        assert energy[L + 1:].sum() <= 1e-10 * energy.sum()
    assert model.bandlimit == 68


def test_kernel_series_matches_closed_form_overlap_and_table(model):
    t = np.cos(np.linspace(0, np.pi, 20001))
    exact = model.rotor_profile.overlap(model.stator_profile, t)
    scale = exact.max()
    # the degree-68 Funk–Hecke series against ∫ f_r f_s in closed form: truncation ≤ 1e-12 of the peak
    assert np.max(np.abs(model.kernel.series(t) - exact)) <= 1e-12 * scale
    rng = np.random.default_rng(3)
    s = np.concatenate([rng.uniform(-1, 1, 50_000), 1 - rng.exponential(0.01, 50_000).clip(0, 2)])
    G, dG, d2G = model.kernel.evaluate(s, 2)
    gmax, dmax, d2max = model.kernel.maxima
    assert np.max(np.abs(G - model.kernel.series(s))) <= 1e-12 * gmax
    assert np.max(np.abs(dG - model.kernel.series(s, 1))) <= 1e-11 * dmax
    assert np.max(np.abs(d2G - model.kernel.series(s, 2))) <= 1e-8 * d2max
    assert np.max(np.abs(dG - model.rotor_profile.overlap(model.stator_profile, s, 1))) <= 1e-10 * dmax
    assert model.kernel.table_error[0] <= 1e-12 and model.kernel.table_error[1] <= 1e-11


def test_kernel_is_exact_on_low_degree_series():
    k = ZonalKernel([0.3, 0.2, -0.1, 0.5, 0.7, -0.2])  # degree 5: the quintic pieces reproduce it
    t = np.linspace(-1, 1, 1001)
    assert np.max(np.abs(k.value(t) - k.series(t))) <= 1e-14
    assert np.max(np.abs(k.derivative(t) - k.series(t, 1))) <= 1e-11


def test_pair_potential_against_closed_form(model):
    psi = np.radians(np.linspace(0, 60, 61))
    f, g = model.rotor_profile, model.stator_profile
    exact = 2 * (f.overlap(g, 1.0) - f.overlap(g, np.cos(psi)))
    assert np.max(np.abs(pair_potential(f, g, psi) - exact)) <= 1e-12 * exact.max()
    assert pair_potential(f, g, 0.0) == 0.0
    assert np.all(np.diff(pair_potential(f, g, psi)) > 0)  # attraction: rises monotonically away from the coil


# --------------------------------------------------------------------------------------- the three forms


def test_harmonic_energy_matches_quadrature_of_the_profiles(proto, model):
    R, c = random_inputs(proto, 5, seed=11)
    c[:, list(proto.failed_coils)] = 0
    harmonic = model.energy(R, c)
    brute = model.energy_quadrature(R, c)
    # eq. (4) integrated over the sphere with the un-truncated profiles: 1e-8 relative (measured 4e-11)
    assert np.max(np.abs(harmonic - brute) / brute) <= 1e-8
    # the orientation-dependent part alone (differences between orientations at fixed currents)
    same_c = np.broadcast_to(c[0], c.shape)
    h, b = model.energy(R, same_c), model.energy_quadrature(R, same_c)
    spread = np.max(np.abs(h - h[0]))
    assert spread > 1e-3
    assert np.max(np.abs((h - h[0]) - (b - b[0]))) <= 1e-8 * spread


def test_band_limited_identity_is_exact(proto, small):
    R, c = random_inputs(proto, 3, seed=12)
    harmonic = small.energy(R, c)
    exact = small.energy_quadrature(R, c, band_limited=True)  # degree-2L integrand, exact Gauss rule
    assert np.max(np.abs(harmonic - exact) / exact) <= 1e-12
    # the truncation at L = 10 is far from the profiles themselves: the check above is not vacuous
    assert np.max(np.abs(harmonic - small.energy_quadrature(R, c)) / exact) > 1e-3


def test_harmonic_pairwise_and_explicit_wigner_forms_agree(proto, model, small):
    for m in (model, small):
        R, c = random_inputs(proto, 40, seed=13)
        harmonic = m.energy(R, c)
        assert np.max(np.abs(m.energy_pairwise(R, c) - harmonic) / harmonic) <= 1e-12
        # Plancherel with the rotated coefficients D^l(R) Â^l formed explicitly (wigner_D, corrected eq. (16))
        a, b = m.rotor_coefficients(R[:4]), m.stator_coefficients(c[:4])
        plancherel = np.sum(np.abs(a - b) ** 2, axis=(-2, -1))
        assert np.max(np.abs(plancherel - harmonic[:4]) / harmonic[:4]) <= 1e-12
    assert model.rotor_norm2 == pytest.approx(model._rotor_norm2_pairwise, rel=1e-13)
    assert np.max(np.abs(model.stator_gram - model._stator_gram_pairwise)) <= 1e-13 * model.stator_gram.max()


def test_rotor_coefficients_describe_the_rotated_field(proto, small):
    """â_R evaluated at points u equals Σ_j p_j f_r,L(u · R u_j): the corrected eq. (16) at work."""
    from numpy.polynomial.legendre import legval

    from spherestep.harmonics import s2_evaluate

    R = so3.random(2, 5)
    u = so3.random(1, 6)[0]  # three orthonormal points
    field = s2_evaluate(small.rotor_coefficients(R), u)
    weight = (2 * np.arange(11) + 1) / (4 * np.pi)
    direct = np.einsum("kpj,j->kp", legval(u @ (R @ proto.rotor.centers.T), small.lambda_rotor * weight),
                       proto.polarity.astype(float))
    assert np.max(np.abs(field - direct)) <= 1e-12 * np.max(np.abs(direct))


def test_energy_is_invariant_under_rotating_rotor_and_stator_together(proto, model):
    Q = so3.random(1, 21)[0]
    stator = Packing(proto.stator.centers @ Q.T, proto.stator.radii)
    turned = dataclasses.replace(proto, stator=stator, stator_axis=Q @ proto.stator_axis)
    other = MotorPotential(turned)
    R, c = random_inputs(proto, 6, seed=14)
    base = model.energy(R, c)
    assert np.max(np.abs(other.energy(Q @ R, c) - base) / base) <= 1e-12
    assert np.max(np.abs(other.energy_pairwise(Q @ R, c) - base) / base) <= 1e-12
    # torque is a fixed-frame vector: it turns with Q
    assert np.max(np.abs(other.torque(Q @ R, c) - model.torque(R, c) @ Q.T)) <= 1e-11


# ------------------------------------------------------------------------------------ torque and Hessian


def test_torque_is_minus_the_gradient_in_the_fixed_frame(proto, model):
    R, c = random_inputs(proto, 6, seed=15)
    tau = model.torque(R, c)
    h = 1e-5
    fd = np.zeros_like(tau)
    fd_harmonic = np.zeros_like(tau)
    for a in range(3):
        e = np.zeros(3)
        e[a] = h
        plus, minus = so3.exp(e) @ R, so3.exp(-e) @ R  # R → exp(ω̂) R
        fd[:, a] = -(model.energy_pairwise(plus, c) - model.energy_pairwise(minus, c)) / (2 * h)
        e[a] = 1e-4
        plus, minus = so3.exp(e) @ R, so3.exp(-e) @ R
        fd_harmonic[:, a] = -(model.energy(plus, c) - model.energy(minus, c)) / 2e-4
    scale = np.max(np.abs(tau))
    assert np.max(np.abs(fd - tau)) <= 1e-6 * scale  # measured 9e-10
    assert np.max(np.abs(fd_harmonic - tau)) <= 1e-6 * scale  # measured 9e-8 (step 1e-4)
    # the energy falls along the torque
    E = model.energy_pairwise(R, c)
    assert np.all(model.energy_pairwise(so3.exp(1e-4 * tau / np.linalg.norm(tau, axis=1)[:, None]) @ R, c) < E)
    E2, tau2 = model.energy_and_torque(R, c)
    assert np.array_equal(tau2, tau) and np.allclose(E2, E, rtol=1e-12, atol=0)  # fast path vs pairwise form


def test_torque_pulls_a_pole_towards_its_coil(proto, model):
    states = proto.states()
    R_state = states.rotations[5]
    (j, k), *_ = states.held(5)
    c = np.zeros(len(proto.stator))
    c[k] = proto.polarity[j]
    w, v = R_state @ proto.rotor.centers[j], proto.stator.centers[k]
    axis = np.cross(w, v) / np.linalg.norm(np.cross(w, v)) if np.linalg.norm(np.cross(w, v)) > 1e-9 else \
        np.cross(v, [1.0, 0, 0]) / np.linalg.norm(np.cross(v, [1.0, 0, 0]))
    R = so3.rot(axis, -np.radians(6.0)) @ R_state  # turn the pole 6° (more) away from the coil
    tau = model.torque(R, c)
    pole = R @ proto.rotor.centers[j]
    # the torque's rotation moves the pole towards the coil: d/ds (exp(s τ̂) w) · v = (τ × w) · v > 0
    assert np.dot(np.cross(tau, pole), v) > 0


def test_hessian_is_the_second_derivative_along_exp(proto, model):
    R, c = random_inputs(proto, 3, seed=16)
    H = model.hessian(R, c)
    assert np.max(np.abs(H - np.swapaxes(H, -1, -2))) <= 1e-12 * np.max(np.abs(H))
    h = 1e-4
    fd = np.zeros_like(H)
    basis = np.eye(3) * h
    for a in range(3):
        for b in range(3):
            def f(sa, sb):
                return model.energy_pairwise(so3.exp(sa * basis[a] + sb * basis[b]) @ R, c)
            fd[:, a, b] = (f(1, 1) - f(1, -1) - f(-1, 1) + f(-1, -1)) / (4 * h * h)
    assert np.max(np.abs(fd - H)) <= 1e-5 * np.max(np.abs(H))  # measured ~1e-8 (rounding / h²)


def test_zero_currents_give_the_constant_energy(proto, model):
    R = so3.random(4, 17)
    c = np.zeros(len(proto.stator))
    assert np.allclose(model.energy(R, c), model.rotor_norm2, rtol=1e-13)
    assert np.allclose(model.energy_pairwise(R, c), model.rotor_norm2, rtol=1e-13)
    assert np.array_equal(model.torque(R, c), np.zeros((4, 3)))


def test_shapes_and_broadcasting(proto, model):
    R, c = random_inputs(proto, 5, seed=18)
    N = len(proto.stator)
    assert model.energy(R[0], c[0]).shape == ()
    assert model.energy_pairwise(R, c[0]).shape == (5,)
    assert model.energy(R[0], c[:4]).shape == (4,)
    grid = model.energy_pairwise(R[:, None], c[None, :4])
    assert grid.shape == (5, 4)
    assert np.allclose(grid[2, 3], model.energy_pairwise(R[2], c[3]), rtol=1e-14)
    assert np.allclose(model.energy(R[:, None], c[None, :4]), grid, rtol=1e-12)
    assert model.torque(R[:, None], c[None, :4]).shape == (5, 4, 3)
    assert model.hessian(R[0], c[:2]).shape == (2, 3, 3)
    assert np.allclose(model.torque(R[:, None], c[None, :4])[1, 2], model.torque(R[1], c[2]), rtol=1e-13)
    E, tau = model.energy_and_torque(R[0], np.zeros((2, N)))
    assert E.shape == (2,) and tau.shape == (2, 3)


def test_coil_currents_from_a_state(proto):
    states = proto.states()
    c = coil_currents(proto, states.coils(0))
    assert c.shape == (len(proto.stator),)
    assert {k: int(c[k]) for k in np.flatnonzero(c)} == states.coils(0)


# ------------------------------------------------------------------------------------------ SO(3) grid


@pytest.mark.slow
def test_energy_grid_matches_direct_evaluation(proto, small, model):
    rng = np.random.default_rng(19)
    c = rng.uniform(-1, 1, size=(2, len(proto.stator)))
    for lmax, cl in ((10, c), (12, c[:1])):  # the grid of the model's own band limit, and a finer one
        grid, V = small.energy_grid(cl, lmax)
        assert V.shape == (len(cl), 2 * lmax + 1, lmax + 1, 2 * lmax + 1)
        direct = small.energy_pairwise(grid.rotations()[None], cl[:, None, None, None])
        assert np.max(np.abs(V - direct)) <= 1e-12 * np.max(np.abs(direct))
        some = grid.rotations().reshape(-1, 3, 3)[::17]  # and the harmonic form itself at a subset
        harmonic = small.energy(some, cl[:, None])
        assert np.max(np.abs(V.reshape(len(cl), -1)[:, ::17] - harmonic)) <= 1e-12 * np.max(np.abs(direct))
    # full band limit with a state's coils: spot checks against the pairwise form
    states = proto.states()
    cs = coil_currents(proto, states.coils(0))
    grid, V = model.energy_grid(cs)
    assert V.shape == (137, 69, 137)
    pick = rng.choice(V.size, 300, replace=False)
    rotations = so3.from_euler_zxz(grid.angles().reshape(-1, 3)[pick])
    assert np.max(np.abs(V.reshape(-1)[pick] - model.energy_pairwise(rotations, cs))) <= 1e-12 * V.max()


# ------------------------------------------------------------------------------------------- bad input


def test_bad_inputs_raise_input_error_naming_the_argument(proto, model):
    N = len(proto.stator)
    R = np.eye(3)
    cases = [
        (lambda: model.energy(np.ones((3, 3)), np.zeros(N)), "R"),
        (lambda: model.energy(np.eye(4), np.zeros(N)), "R"),
        (lambda: model.torque(-np.eye(3), np.zeros(N)), "R"),
        (lambda: model.energy_pairwise(np.full((3, 3), np.nan), np.zeros(N)), "R"),
        (lambda: model.energy(R, np.zeros(N + 1)), "currents"),
        (lambda: model.energy(R, np.full(N, np.nan)), "currents"),
        (lambda: model.torque(so3.random(3, 0), np.zeros((2, N))), "currents"),
        (lambda: model.energy_quadrature(R, np.zeros(N), n=0), "n"),
        (lambda: model.energy_coefficients(np.zeros(N), lmax=3), "lmax"),
        (lambda: MotorPotential(proto, bandlimit=-1), "bandlimit"),
        (lambda: MotorPotential(proto, rotor_profile=lambda t: t), "rotor_profile"),
        (lambda: MotorPotential("not a design"), "design"),
        (lambda: VonMisesFisher(-1.0), "kappa"),
        (lambda: VonMisesFisher(2.0, amplitude=0.0), "amplitude"),
        (lambda: VonMisesFisher.from_half_width(0.0), "angle"),
        (lambda: RaisedCosine(4.0), "radius"),
        (lambda: ZonalKernel([]), "coefficients"),
        (lambda: ZonalKernel([1.0, 2.0]).series(0.0, order=3), "order"),
        (lambda: coil_currents(proto, {N: 1}), "coils"),
    ]
    for call, name in cases:
        with pytest.raises(InputError, match=rf"^{name} must be"):
            call()
    failed = proto.without_coils([2])
    with pytest.raises(InputError, match="^currents must be zero on the failed coils"):
        MotorPotential(failed, bandlimit=4).energy(R, np.eye(N)[2])
