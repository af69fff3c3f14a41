"""The coupled iron model made fast (issue 28 §2): its compiled coupling sum against the NumPy series, its
cubed-sphere tables against the sums they interpolate, the compiled paths (packed terms, the servo's ``K`` and
bias) against the model's methods, and the design's own model being the coupled one."""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
import pytest

from spherestep import so3
from spherestep._fast.coupling import coupling_energies
from spherestep._fast.spheretable import HALO, face_coefficients, face_nodes, sphere_values
from spherestep.control import ModelCache
from spherestep.magnetics import design_model, iron_model
from spherestep.motor import prototype

# the tables' torque against the sums they interpolate, as a share of the pair table's peak |τ_d| (1.76 N m):
# measured up to 0.51 % (0.009 N m; 0.11 % of the patch FEM's largest torque) at 12 random orientations with 3 coils
# on, 0.2 % at another 20; bound 1 %
TABLE_TORQUE = 1e-2


@pytest.fixture(scope="module")
def design():
    return prototype()


@pytest.fixture(scope="module")
def coupled(design):
    return iron_model(design, coupling=True)


@pytest.fixture(scope="module")
def sample():
    rng = np.random.default_rng(7)
    R = so3.random(12, rng)
    c = np.zeros((12, 29))
    for row in c:
        row[rng.choice(29, 3, replace=False)] = rng.uniform(-1, 1, 3)
    return R, c


def test_compiled_coupling_is_the_series(coupled):
    """``_fast.coupling.coupling_energies`` (a quadratic form per harmonic) is the NumPy pair sum of
    :class:`CoreCoupling` for one coil along ``x``, to rounding (1e-12 of the largest)."""
    cc = coupled.coupling
    rng = np.random.default_rng(3)
    x = rng.normal(size=(40, 3))
    x /= np.linalg.norm(x, axis=1)[:, None]
    knots, C = cc.spline_coefficients()
    got = np.empty(len(x))
    coupling_energies(x, np.ascontiguousarray(cc.poles.T), cc.polarity, float(cc.alpha[-1]), math.radians(50.0),
                      knots, C, got)
    ref = np.array([replace(cc, coils=xi[None]).energy(np.eye(3)[None])[0] for xi in x])
    assert np.abs(ref).max() > 1e-3
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max())


def test_numpy_coupling_torque_is_its_energy_gradient(coupled):
    """With the reach's taper, the NumPy coupling torque is ``−∂E_c/∂θ`` (central differences, 1e-5 rad)."""
    cc = coupled.coupling
    R = so3.random(3, np.random.default_rng(11))
    h = 1e-5
    for Rk in R:
        tau = cc.torque(Rk[None])[0]
        fd = np.array([-(cc.energy(so3.exp(h * e)[None] @ Rk)[0] - cc.energy(so3.exp(-h * e)[None] @ Rk)[0])
                       / (2 * h) for e in np.eye(3)])
        np.testing.assert_allclose(tau, fd, rtol=0, atol=1e-6 + 1e-5 * np.abs(tau).max())


def test_tables_against_sums(coupled, sample):
    """The tables' energy, torque and ``K(R)`` against the pair splines and the coupling's series (NumPy)."""
    R, c = sample
    peak = float(np.max(np.abs(coupled.detent.tau)))
    tau, tau_exact = coupled.torque(R, c), coupled.exact_torque(R, c)
    assert np.abs(tau - tau_exact).max() <= TABLE_TORQUE * peak
    assert np.abs(tau_exact).max() > 0.5 * peak  # the check is not of small numbers
    E, E_exact = coupled.energy(R, c), coupled.exact_energy(R, c)
    assert np.abs(E - E_exact).max() <= 1e-6 * np.abs(E_exact).max()
    K = coupled.torque_matrix(R)
    assert np.abs(K - coupled.linear.torque_matrix(R)).max() <= TABLE_TORQUE * np.max(np.abs(coupled.linear.tau))
    # one orientation gives the batch's row
    np.testing.assert_allclose(coupled.torque(R[0], c[0]), tau[0], rtol=0, atol=1e-12)


def test_tables_hessian_is_their_torque_gradient(coupled, sample):
    """The analytic Hessian of the tables against central differences of their own torque (1e-4 of its
    largest entry)."""
    R, c = sample
    from spherestep.statics import finite_difference_hessian

    H = coupled.hessian(R[:4], c[:4])
    Hf = finite_difference_hessian(coupled, R[:4], c[:4])
    np.testing.assert_allclose(H, Hf, rtol=0, atol=1e-4 * np.abs(Hf).max())


def test_sphere_table_interpolates_and_differentiates():
    """A cubed-sphere table of a smooth function (a tilted zonal polynomial) returns its values, tangent gradient
    and ambient second derivative (of the 0-homogeneous extension) to the interpolation's order."""
    a = np.array([0.3, -0.5, 0.81])
    a /= np.linalg.norm(a)

    def f(x):
        t = x @ a
        return t ** 3 + 0.5 * t

    n = 64
    nodes = face_nodes(n)
    coef = face_coefficients(f(nodes.reshape(-1, 3)).reshape(nodes.shape[:-1]))
    x = np.random.default_rng(5).normal(size=(200, 3))
    x /= np.linalg.norm(x, axis=1)[:, None]
    F, g, H = np.empty(len(x)), np.empty((len(x), 3)), np.empty((len(x), 3, 3))
    sphere_values(coef.reshape(-1), coef.shape[1], 2 * n / math.pi, HALO, x, 2, F, g, H)
    t = x @ a
    d = 3 * t ** 2 + 0.5
    g_exact = d[:, None] * (a - t[:, None] * x)
    np.testing.assert_allclose(F, f(x), rtol=0, atol=5e-7)
    np.testing.assert_allclose(g, g_exact, rtol=0, atol=2e-5)
    np.testing.assert_allclose(np.einsum("pab,pb->pa", H, x), -g, rtol=0, atol=2e-3)  # M x = −S: homogeneous


def test_compiled_paths_take_the_coupled_model(coupled, sample):
    """The packed terms (the integrator's, the descent's) and the servo's compiled ``K``/bias give the model's
    own numbers: the coupled model no longer steps aside for NumPy."""
    from spherestep._fast.terms import terms_evaluate, workspace

    R, c = sample
    packed = coupled.packed_terms(c[0])
    assert packed is not None
    tau, H = np.empty(3), np.empty((3, 3))
    work, near = workspace(packed.poles)
    E = terms_evaluate(packed.params, packed.offsets, np.ascontiguousarray(R[0]), packed.coils,
                       np.ascontiguousarray(packed.C), packed.poles, packed.P, packed.signs, 1, tau, H, work, near)
    E_model, tau_model = coupled.evaluate(R[0], c[0], 1)
    assert E == pytest.approx(float(E_model), rel=1e-12, abs=1e-12)
    np.testing.assert_allclose(tau, tau_model, rtol=0, atol=1e-12)
    cache = ModelCache(coupled, reuse=0.0)
    assert cache.compiled
    K, b = cache.at(np.ascontiguousarray(R[1]))
    np.testing.assert_allclose(K, coupled.torque_matrix(R[1]), rtol=0, atol=1e-12)
    np.testing.assert_allclose(b, coupled.torque(R[1], np.zeros(29)), rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(b, coupled.detent_torque(R[1]), rtol=1e-11, atol=1e-12)


def test_energy_and_torque_within_a_millisecond(coupled, sample):
    """Issue 28 §2: E + τ of the coupled model ≤ 1 ms per orientation (the model's own call, median of 200;
    ~20-100 µs measured on a loaded machine; the compiled packed call ~5-20 µs)."""
    R, c = sample
    coupled.evaluate(R[0], c[0], 1)
    times = []
    for i in range(200):
        t0 = time.perf_counter()
        coupled.evaluate(R[i % len(R)], c[i % len(R)], 1)
        times.append(time.perf_counter() - t0)
    assert float(np.median(times)) <= 1e-3


def test_design_model_is_coupled_by_default(design):
    """The design's own model is the coupled one (label says so); ``coupling=False`` is the pairwise model."""
    own = design_model(design)
    assert own.label == "iron (coupled, FEM table)" and own.model.coupling is not None
    pair = design_model(design, coupling=False)
    assert pair.label == "iron (pairwise, FEM table)" and pair.model.coupling is None
    assert design_model(design, "air").model is not None  # air: no coupling, no error


def test_tables_on_one_grid_summed_per_coil_equal_each_table_evaluated(coupled, sample):
    """The fused evaluation (the coupled model's two tables located once per coil and summed before the chain
    rule, :func:`spherestep._fast.terms.terms_evaluate`) equals the sum of each table evaluated on its own
    (:func:`sphere_values`, one table at a time: energy, torque ``R Σ c x × S`` and the Hessian's defining
    property: the symmetric part of the torque's central difference, ``−∂τ/∂θ`` off equilibrium not being
    symmetric) to rounding."""
    from spherestep._fast.terms import terms_evaluate, workspace

    R, c = sample[0][:6], np.zeros(29)
    c[[2, 5, 11]] = [1.0, -1.0, 0.6]
    p = coupled.packed_terms(c)
    C = np.ascontiguousarray(p.C)
    tau, H = np.empty(3), np.empty((3, 3))
    work, near = workspace(p.poles)
    for Rk in R:
        E = terms_evaluate(p.params, p.offsets, np.ascontiguousarray(Rk), p.coils, C, p.poles, p.P, p.signs, 2,
                           tau, H, work, near)
        x = p.coils @ Rk  # (N, 3): x_k = Rᵀ v_k
        E_ref, body = 0.0, np.zeros(3)
        for i in range(len(p.signs)):
            head = p.params[p.offsets[i]:p.offsets[i + 1]]
            F, g, h = np.empty(len(x)), np.empty((len(x), 3)), np.empty((len(x), 3, 3))
            sphere_values(np.ascontiguousarray(head[5:]), int(head[1]), head[3], int(head[4]), x, 1, F, g, h)
            E_ref += p.signs[i] * C[i] @ F
            body += p.signs[i] * (C[i][:, None] * np.cross(x, g)).sum(axis=0)
        assert abs(E - E_ref) <= 1e-12 * max(1.0, abs(E_ref))
        np.testing.assert_allclose(tau, Rk @ body, rtol=0, atol=1e-11 * max(1.0, np.abs(body).max()))  # 29 coils cancel
        step = 1e-6  # H = sym(−∂τ/∂θ) (fixed frame), central differences: to the difference's error
        fd = np.empty((3, 3))
        for a in range(3):
            ends = []
            for sign in (1.0, -1.0):
                t2 = np.empty(3)
                Rs = np.ascontiguousarray(so3.exp(sign * step * np.eye(3)[a]) @ Rk)
                terms_evaluate(p.params, p.offsets, Rs, p.coils, C, p.poles, p.P, p.signs, 1, t2, np.empty((3, 3)),
                               work, near)
                ends.append(t2)
            fd[:, a] = -(ends[0] - ends[1]) / (2 * step)
        np.testing.assert_allclose(H, 0.5 * (fd + fd.T), rtol=0, atol=1e-5 * max(1.0, np.abs(H).max()))


def test_the_compiled_newton_step_is_the_eigen_sum():
    """:func:`spherestep._fast.descent.newton_direction` (``adj(H) τ / det H`` where no eigenvalue floor can act,
    ``eigh`` elsewhere) against the NumPy reference's eigen-sum (:func:`spherestep.statics._newton_direction`) on
    positive definite, ill-conditioned, indefinite and singular matrices: to 1e-14 × the condition number of the
    step's largest component."""
    from spherestep._fast.descent import newton_direction
    from spherestep.statics import _newton_direction

    rng = np.random.default_rng(11)
    cases = []
    for scales in ([3.0, 2.0, 1.0], [1e3, 1.0, 1e-4], [5.0, -1.0, 2.0], [1.0, 1e-12, 2.0], [-1.0, -2.0, -3.0],
                   [1.0, 0.0, 1.0], [1e2, 1e2, 1e-7]):
        for _ in range(20):
            Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
            cases.append(Q @ np.diag(scales) @ Q.T)
    for H in cases:
        tau = rng.normal(size=3)
        for max_step in (10.0, 0.05):
            got = newton_direction(np.ascontiguousarray(H), tau, max_step)
            want = _newton_direction(H[None], tau[None], max_step)[0]
            h = np.abs(np.linalg.eigvalsh(H))
            cond = h.max() / max(h.min(), 1e-8 * h.max())  # both solve in floating point: error ~ cond × eps
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-14 * cond * max(1.0, np.abs(want).max()))
