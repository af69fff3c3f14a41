"""Force–displacement data and the fit of the zonal ansatz (Fig. 6, Sec. III-B).

The paper measured the force between a rotor magnet and a stator coil while translating the magnet in the
plane normal to the coil's axis, fitted a fourth-order polynomial to it (Fig. 6(a)), integrated that
analytically to a potential (Fig. 6(b)) and chose the parameters of the ansatz of eq. (4) to match it, taking
small rotations of the rotor as translations of the pole ([27]): a displacement ``x`` at radius ``r`` is the
rotation angle ``ψ = x / r``.

Sign convention: ``F(x)`` is the force on the magnet along ``+x``; an attracting coil pulls the magnet back,
``F(x) < 0`` for ``x > 0``, and ``V(x) = −∫_0^x F dx'`` rises away from the coil.

Single-pole potential of the model. One pole (polarity ``+1``) at angle ``ψ`` from one coil (current ``+1``):
eq. (4) gives ``V(ψ) = ‖f_r‖² + ‖f_s‖² − 2 G(cos ψ)``, so relative to the aligned position
``ΔV(ψ) = 2 [G(1) − G(cos ψ)]`` (:func:`pair_potential`) and the force ``−dΔV/dx = −(2/r) sin ψ G'(cos ψ)``.
Only the product of the two amplitudes enters; :func:`fit_profile` keeps the rotor's profile as given and fits
the coil's von Mises–Fisher concentration ``κ_s`` and amplitude ``A_s`` (per unit current), so that the
fitted profiles make :class:`~spherestep.potential.MotorPotential` return joules and newton metres when the data
are in metres and newtons.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.polynomial import Polynomial
from numpy.polynomial.legendre import legval
from scipy.optimize import least_squares

from .. import checks
from ..atomic import write_text
from ..errors import InputError, bad_value
from . import _checks
from .profiles import VonMisesFisher, ZonalProfile

# The example data set data/force_curve_example.csv (see data/README.md): the closed-form vMF model below.
EXAMPLE_RADIUS = 0.1524  # m: the prototype's 12-in sphere
EXAMPLE_ROTOR = VonMisesFisher(200.6655091620246)  # half width 4.764°: the prototype's 1-in magnet face
EXAMPLE_STATOR = VonMisesFisher(51.02716008498338, 6.0)  # half width 9.455°: the 2-in coil face; peak 7.6 N
EXAMPLE_DISPLACEMENT = np.linspace(0.0, 0.040, 41)  # m, 1-mm steps
EXAMPLE_NOISE = 0.1  # N, standard deviation of the added Gaussian noise
EXAMPLE_SEED = 1999


def fit_force_curve(displacement, force, degree: int = 4) -> Polynomial:
    """Least-squares polynomial ``F(x) = Σ_i a_i x^i`` of ``degree`` (default 4, as in Fig. 6(a)) through samples.

    Fitted in a scaled variable for conditioning (``Polynomial.fit``) and returned in the power basis of ``x``
    itself (``coef[i] = a_i``, identity domain). Needs at least ``degree + 1`` distinct displacements.
    """
    x = _checks.samples(displacement, "displacement")
    F = _checks.samples(force, "force")
    degree = checks.count(degree, "degree", minimum=0)
    if len(F) != len(x):
        raise bad_value("force", f"one value per displacement ({len(x)})", f"{len(F)} values")
    if len(np.unique(x)) <= degree:
        raise bad_value("displacement", f"at least {degree + 1} distinct values for a degree-{degree} fit",
                        f"{len(np.unique(x))} distinct values")
    return Polynomial.fit(x, F, degree).convert()


def potential_from_force(poly) -> Polynomial:
    """``V(x) = −∫_0^x F(x') dx'`` of a force polynomial, analytically (``V(0) = 0``), as Fig. 6(b)."""
    if not isinstance(poly, Polynomial):
        raise bad_value("poly", "a numpy.polynomial.Polynomial (e.g. from fit_force_curve)", type(poly).__name__)
    return -(poly.convert().integ(lbnd=0.0))


def pair_potential(rotor: ZonalProfile, stator: ZonalProfile, angle, tail: float = 1e-12) -> np.ndarray:
    """``ΔV(ψ) = 2 [G(1) − G(cos ψ)]``: one pole of polarity +1 at angle ``ψ`` (radians) from a coil at current +1,
    relative to alignment, with ``G`` the degree-``L`` Funk–Hecke series (``L`` from both profiles'
    :meth:`~ZonalProfile.bandwidth` at ``tail``), evaluated exactly by Clenshaw's recurrence."""
    psi = checks.real_array(angle, "angle")
    L = max(rotor.bandwidth(tail), stator.bandwidth(tail))
    g = rotor.legendre_coefficients(L) * stator.legendre_coefficients(L) * (2 * np.arange(L + 1) + 1) / (4 * np.pi)
    return 2.0 * (legval(1.0, g) - legval(np.cos(psi), g))


@dataclass(frozen=True)
class ProfileFit:
    """Result of :func:`fit_profile`.

    ``rotor`` (as given), ``stator`` (fitted :class:`VonMisesFisher`, amplitude per unit current);
    ``force_polynomial`` and ``potential_polynomial`` (Fig. 6(a), (b)); ``radius`` (m); ``rms``: root mean square
    of ``ΔV(x/r) − V_poly(x)`` over the samples (J); ``success`` from the optimiser.
    """

    rotor: ZonalProfile
    stator: VonMisesFisher
    force_polynomial: Polynomial
    potential_polynomial: Polynomial
    radius: float
    rms: float
    success: bool

    def potential(self, displacement) -> np.ndarray:
        """The fitted model's ``ΔV`` at displacements ``x`` (m): ``pair_potential(rotor, stator, x / r)``."""
        return pair_potential(self.rotor, self.stator, checks.real_array(displacement, "displacement") / self.radius)


def fit_profile(displacement, force, radius, rotor_profile: ZonalProfile, *, degree: int = 4,
                kappa_range: tuple[float, float] = (1.0, 3000.0)) -> ProfileFit:
    """Fit the coil's profile ``A_s exp(κ_s (t − 1))`` so the model's single-pole potential matches a force curve.

    Steps (Sec. III-B, Fig. 6): ``poly = fit_force_curve(x, F, degree)``; ``V_poly = potential_from_force(poly)``;
    then minimise ``Σ_i [ΔV(x_i / r; κ_s, A_s) − V_poly(x_i)]²`` over ``(log κ_s, log A_s)`` with
    ``scipy.optimize.least_squares``, started from the best of 41 values of ``κ_s`` log-spaced over
    ``kappa_range`` (``A_s`` solved linearly for each, since ``ΔV`` is proportional to it). ``radius``: the radius
    (m) of the circle the pole's centre moves on, so ``ψ = x / r``; ``rotor_profile`` is held fixed (only the
    product of amplitudes is identifiable). The force must be attracting (``V_poly`` rising away from 0).
    """
    x = _checks.samples(displacement, "displacement")
    radius = checks.positive(radius, "radius")
    if not isinstance(rotor_profile, ZonalProfile):
        raise bad_value("rotor_profile", "a ZonalProfile (e.g. VonMisesFisher)", rotor_profile)
    lo, hi = (checks.positive(k, "kappa_range") for k in kappa_range)
    if not lo < hi:
        raise bad_value("kappa_range", "an increasing pair (low, high)", kappa_range)
    poly = fit_force_curve(x, force, degree)
    potential = potential_from_force(poly)
    target = potential(x)
    psi = x / radius

    def shape(log_kappa: float) -> np.ndarray:
        return pair_potential(rotor_profile, VonMisesFisher(math.exp(log_kappa)), psi)

    best = None
    for log_kappa in np.linspace(math.log(lo), math.log(hi), 41):
        s = shape(log_kappa)
        amplitude = float(s @ target) / float(s @ s) if np.any(s) else 0.0
        cost = float(np.sum((amplitude * s - target) ** 2))
        if amplitude > 0 and (best is None or cost < best[0]):
            best = (cost, log_kappa, amplitude)
    if best is None:
        raise InputError("force must describe an attracting coil (the integrated potential rising away from "
                         "x = 0, F(x) < 0 for x > 0); instead the fitted potential falls")
    _, log_kappa, amplitude = best
    scale = max(float(np.max(np.abs(target))), np.finfo(float).tiny)

    def residual(theta: np.ndarray) -> np.ndarray:
        return (math.exp(theta[1]) * shape(theta[0]) - target) / scale

    bounds = ([math.log(lo), -np.inf], [math.log(hi), np.inf])
    result = least_squares(residual, [log_kappa, math.log(amplitude)], bounds=bounds, x_scale=[0.1, 0.1],
                           xtol=1e-12, ftol=1e-12, gtol=1e-12)
    stator = VonMisesFisher(math.exp(result.x[0]), math.exp(result.x[1]))
    rms = float(np.sqrt(np.mean((residual(result.x) * scale) ** 2)))
    return ProfileFit(rotor_profile, stator, poly, potential, radius, rms, bool(result.success))


def synthetic_force_curve(displacement, rotor: VonMisesFisher, stator: VonMisesFisher, radius, *, noise=0.0,
                          seed=None) -> np.ndarray:
    """Forces ``F(x) = −(2/r) sin ψ G'(cos ψ)``, ``ψ = x/r``, from the closed-form vMF overlap
    (:meth:`VonMisesFisher.overlap`), plus Gaussian noise of standard deviation ``noise`` from
    ``numpy.random.default_rng(seed)``. GENERATED data for tests and examples, not a measurement."""
    x = _checks.samples(displacement, "displacement")
    radius = checks.positive(radius, "radius")
    for label, profile in (("rotor", rotor), ("stator", stator)):
        if not isinstance(profile, VonMisesFisher):
            raise bad_value(label, "a VonMisesFisher profile", profile)
    noise = checks.non_negative(noise, "noise", "a non-negative standard deviation (N)")
    psi = x / radius
    force = -(2.0 / radius) * np.sin(psi) * rotor.overlap(stator, np.cos(psi), derivative=1)
    if noise:
        force = force + np.random.default_rng(seed).normal(0.0, noise, size=x.shape)
    return force


def example_force_curve() -> tuple[np.ndarray, np.ndarray]:
    """The example data set ``data/force_curve_example.csv``: :func:`synthetic_force_curve` at
    ``EXAMPLE_DISPLACEMENT`` (0–40 mm, 1-mm steps) with ``EXAMPLE_ROTOR``, ``EXAMPLE_STATOR``, ``EXAMPLE_RADIUS``,
    noise ``EXAMPLE_NOISE`` = 0.1 N and seed ``EXAMPLE_SEED`` = 1999. GENERATED, not measured."""
    x = EXAMPLE_DISPLACEMENT.copy()
    return x, synthetic_force_curve(x, EXAMPLE_ROTOR, EXAMPLE_STATOR, EXAMPLE_RADIUS, noise=EXAMPLE_NOISE,
                                    seed=EXAMPLE_SEED)


def save_force_curve(path, displacement, force, note: str) -> Path:
    """Write ``displacement_m,force_N`` rows (``%.6e``) to a CSV file, atomically, after ``# note`` lines."""
    x = _checks.samples(displacement, "displacement")
    F = _checks.samples(force, "force")
    if len(F) != len(x):
        raise bad_value("force", f"one value per displacement ({len(x)})", f"{len(F)} values")
    lines = [f"# {line}" for line in note.strip().splitlines()]
    lines.append("displacement_m,force_N")
    lines += [f"{a:.6e},{b:.6e}" for a, b in zip(x, F)]
    return write_text(path, "\n".join(lines) + "\n")


def load_force_curve(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a ``displacement_m,force_N`` CSV (``#`` comment lines allowed): ``(displacement (m), force (N))``."""
    path = Path(path)
    if not path.is_file():
        raise bad_value("path", "an existing CSV file with columns displacement_m,force_N", str(path))
    rows = [line for line in path.read_text(encoding="utf-8").splitlines() if line and not line.startswith("#")]
    if not rows or rows[0].replace(" ", "") != "displacement_m,force_N":
        raise bad_value("path", "a CSV whose header is displacement_m,force_N", rows[0] if rows else "no rows")
    try:
        data = np.array([[float(v) for v in row.split(",")] for row in rows[1:]])
    except ValueError as exc:
        raise bad_value("path", "numeric rows of two columns", str(exc)) from None
    if data.ndim != 2 or data.shape[1] != 2:
        raise bad_value("path", "numeric rows of two columns", f"shape {data.shape}")
    return data[:, 0], data[:, 1]
