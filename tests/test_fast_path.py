"""The fast path (issue 17): the rotor as one function on the sphere, evaluated at the coils' body-frame directions.

References: the exact forms of :class:`MotorPotential` (harmonic and pairwise), finite differences, and the two
evaluators of :class:`RotorField` (ducc0's synthesis and the direct sum) against each other.
"""

import numpy as np
import pytest

from spherestep import so3
from spherestep.errors import InputError
from spherestep.potential import MotorPotential
from spherestep.rotor_field import COMPILED_DIRECT_BELOW, CUTOFF_TAILS, RotorField
from spherestep.statics import finite_difference_hessian

BIG = COMPILED_DIRECT_BELOW // 29 + 20  # orientations × 29 coils: enough points for the ducc0 evaluator


def _unit(rng, n):
    x = rng.normal(size=(n, 3))
    x[:4] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, 1e-9, -1]]  # the poles of (θ, φ) and the seam
    return x / np.linalg.norm(x, axis=1, keepdims=True)


@pytest.fixture(scope="module")
def exact_field(model):
    """The prototype's rotor function with the exact Legendre series as the direct kernel."""
    k = model.kernel
    return RotorField(model.poles, model.polarity, lambda t, orders: tuple(k.series(t, n) for n in orders),
                      model.bandlimit, exact=k.value)


def test_synthesis_matches_direct_sum(exact_field):
    """ducc0's synthesis of F, its gradient and Hessian (spins 0, 1, 2) equals the sum over the poles."""
    x = _unit(np.random.default_rng(1), 500)
    F0, g0, (lap0, H0) = exact_field.fields(x, 2, method="direct")
    F1, g1, (lap1, H1) = exact_field.fields(x, 2, method="ducc0")
    assert np.max(np.abs(F1 - F0)) <= 1e-12 * np.max(np.abs(F0))
    assert np.max(np.abs(g1 - g0)) <= 1e-12 * np.max(np.abs(g0))
    assert np.max(np.abs(H1 - H0)) <= 1e-11 * np.max(np.abs(H0))
    assert np.max(np.abs(lap1 - lap0)) <= 1e-11 * np.max(np.abs(lap0))
    # the gradient is tangent and the Hessian acts on the tangent plane
    assert np.max(np.abs(np.sum(g1 * x, axis=1))) <= 1e-12 * np.max(np.abs(g1))
    assert np.max(np.abs(H1 @ x[:, :, None])) <= 1e-11 * np.max(np.abs(H1))


@pytest.mark.parametrize("count", [3, BIG])
def test_fast_path_matches_exact_forms(model, count):
    """Energy within 1e-9 relative of the harmonic and pairwise forms, torque and K(R) within 1e-9 of the
    torque reference, the Hessian within 1e-8 of its peak (the pairwise G'' table is good to ~1e-9)."""
    rng = np.random.default_rng(count)
    R = so3.random(count, rng)
    # the first coil on the body frame's +z and −z axes, where the synthesis's frame (θ̂, φ̂) is a convention
    v = model.coils[0]
    R[0] = so3.rot(np.cross([0.0, 0.0, 1.0], v), np.arccos(v[2]))
    R[1] = so3.rot(np.cross([0.0, 0.0, -1.0], v), np.arccos(-v[2]))
    c = rng.uniform(-1.0, 1.0, (count, model.coil_count))
    E, tau, H = model.evaluate(R, c, 2)
    E_pair, tau_pair, H_pair = model.evaluate_pairwise(R, c, 2)
    assert np.max(np.abs(E - E_pair) / np.abs(E_pair)) <= 1e-9
    E1, tau1 = model.energy_and_torque(R, c)  # the batch of E and τ alone (large: ducc0 and compiled sums)
    assert np.max(np.abs(E1 - E_pair) / np.abs(E_pair)) <= 1e-9
    assert np.max(np.linalg.norm(tau1 - tau_pair, axis=-1) / model.torque_reference(c)) <= 1e-9
    assert np.max(np.abs(E - model.energy_harmonic(R, c)) / np.abs(E_pair)) <= 1e-9
    ref = model.torque_reference(c)
    assert np.max(np.linalg.norm(tau - tau_pair, axis=-1) / ref) <= 1e-9
    assert np.max(np.abs(model.torque(R, c) - tau_pair)) <= 1e-9 * np.min(ref)
    assert np.max(np.abs(H - H_pair)) <= 1e-8 * np.max(np.abs(H_pair))
    K, K_pair = model.torque_matrix(R), model.torque_matrix_pairwise(R)
    assert np.max(np.abs(K - K_pair)) <= 1e-9 * np.max(np.abs(K_pair))
    assert np.allclose(np.einsum("kan,kn->ka", K, c), tau, rtol=0, atol=1e-12 * np.max(ref))


def test_single_orientation_shapes(model, proto):
    rng = np.random.default_rng(3)
    R, c = so3.random(1, rng)[0], rng.uniform(-1.0, 1.0, model.coil_count)
    assert model.energy(R, c).shape == () and model.torque(R, c).shape == (3,)
    assert model.hessian(R, c).shape == (3, 3) and model.torque_matrix(R).shape == (3, model.coil_count)
    E, tau = model.energy_and_torque(R, c)
    E0, tau0 = model.evaluate_pairwise(R, c, 1)
    assert E == pytest.approx(E0, rel=1e-12) and np.max(np.abs(tau - tau0)) <= 1e-12 * model.torque_reference(c)
    np.testing.assert_array_equal(model.torque(R, c), tau)
    # nothing energised: the constant energy, no torque
    E, tau, H = model.evaluate(R, np.zeros(model.coil_count), 2)
    assert E == pytest.approx(model.evaluate_pairwise(R, np.zeros(model.coil_count), 0)[0], rel=1e-12)
    assert not tau.any() and not H.any()


@pytest.mark.parametrize("count", [1, BIG])
def test_torque_is_minus_gradient_of_fast_energy(model, count):
    """τ = −∂E/∂θ for R → exp(θ̂) R, by central differences of the fast energy (step 1e-5 rad)."""
    rng = np.random.default_rng(10 + count)
    R = so3.random(count, rng)
    c = rng.uniform(-1.0, 1.0, (count, model.coil_count))
    h = 1e-5
    turns = so3.exp(np.concatenate([h * np.eye(3), -h * np.eye(3)]))
    Rs = np.einsum("sab,kbc->ksac", turns, R)
    E = model.energy(Rs, c[:, None, :])  # (count, 6)
    gradient = (E[:, :3] - E[:, 3:]) / (2 * h)
    assert np.max(np.abs(-gradient - model.torque(R, c))) <= 1e-6 * np.min(model.torque_reference(c))


@pytest.mark.parametrize("count", [2, BIG])
def test_hessian_matches_finite_differences(model, count):
    """The analytic Hessian against central differences of the fast torque (step 1e-6 rad)."""
    rng = np.random.default_rng(20 + count)
    R = so3.random(count, rng)
    c = rng.uniform(-1.0, 1.0, (count, model.coil_count))
    H = model.hessian(R, c)
    fd = finite_difference_hessian(model, R, c)
    assert np.max(np.abs(H - fd)) <= 1e-6 * np.max(np.abs(H))
    assert np.allclose(H, np.swapaxes(H, -1, -2), rtol=0, atol=1e-14 * np.max(np.abs(H)))


def test_threads_give_identical_results(proto, model):
    """ducc0 with 1 and 2 threads, and BLAS with 1 and 2 threads: the same numbers (each point is synthesised
    independently; BLAS only reorders sums)."""
    two = MotorPotential(proto, nthreads=2)
    rng = np.random.default_rng(5)
    R = so3.random(BIG, rng)
    c = rng.uniform(-1.0, 1.0, (BIG, model.coil_count))
    for order in (1, 2):
        for a, b in zip(model.evaluate(R, c, order), two.evaluate(R, c, order)):
            np.testing.assert_allclose(a, b, rtol=1e-15, atol=1e-15 * np.max(np.abs(b)))
    np.testing.assert_allclose(model.torque_matrix(R), two.torque_matrix(R), rtol=1e-15,
                               atol=1e-15 * np.max(np.abs(two.torque_matrix(R))))
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=2, user_api="blas"):
        blas_two = model.evaluate(R, c, 2)
    for a, b in zip(model.evaluate(R, c, 2), blas_two):
        np.testing.assert_allclose(a, b, rtol=1e-14, atol=1e-14 * np.max(np.abs(b)))


def test_fast_false_is_the_exact_form(proto, model):
    exact = MotorPotential(proto, fast=False)
    rng = np.random.default_rng(6)
    R, c = so3.random(4, rng), rng.uniform(-1.0, 1.0, (4, model.coil_count))
    np.testing.assert_array_equal(exact.energy(R, c), model.energy_harmonic(R, c))
    np.testing.assert_array_equal(exact.torque(R, c), model.evaluate_pairwise(R, c, 1)[1])
    np.testing.assert_array_equal(exact.torque_matrix(R), model.torque_matrix_pairwise(R))


def test_bad_input(proto, model):
    with pytest.raises(InputError, match="nthreads"):
        MotorPotential(proto, nthreads=0)
    with pytest.raises(InputError, match="method"):
        model.rotor_field.fields(np.array([[0.0, 0.0, 1.0]]), 1, method="fft")
    with pytest.raises(InputError, match="currents"):
        model.torque(np.eye(3), np.ones(3))


@pytest.fixture(scope="module")
def torque_map(proto):
    from spherestep.magnetics import TorqueMap

    return TorqueMap.build(proto)


def test_torque_map_through_the_rotor_function(torque_map):
    """The map's energy, torque and K(R) through the rotor function equal its pair sums (to rounding); its
    analytic Hessian matches central differences of the torque; the torque is minus the energy's gradient."""
    rng = np.random.default_rng(7)
    R = so3.random(40, rng)
    c = rng.uniform(-1.0, 1.0, (40, torque_map.coil_count))
    E, tau, H = torque_map.evaluate(R, c, 2)
    ref = torque_map.torque_reference(c)
    assert np.max(np.abs(E - torque_map.energy_pairwise(R, c))) <= 1e-12 * np.max(np.abs(E))
    assert np.max(np.linalg.norm(tau - torque_map.torque_pairwise(R, c), axis=-1) / ref) <= 1e-12
    K, K_pair = torque_map.torque_matrix(R), torque_map.torque_matrix_pairwise(R)
    assert np.max(np.abs(K - K_pair)) <= 1e-12 * np.max(np.abs(K_pair))
    fd = finite_difference_hessian(torque_map, R, c)
    assert np.max(np.abs(H - fd)) <= 1e-6 * np.max(np.abs(H))
    h = 1e-6
    turns = so3.exp(np.concatenate([h * np.eye(3), -h * np.eye(3)]))
    Es = torque_map.energy(np.einsum("sab,kbc->ksac", turns, R).reshape(-1, 3, 3), np.repeat(c, 6, axis=0))
    Es = Es.reshape(-1, 6)
    assert np.max(np.abs(-(Es[:, :3] - Es[:, 3:]) / (2 * h) - tau)) <= 1e-6 * np.min(ref)
    single = torque_map.evaluate(R[0], c[0], 2)
    assert np.max(np.abs(torque_map.torque(R[0], c[0]) - torque_map.torque_pairwise(R[0], c[0]))) <= 1e-12 * ref[0]
    assert torque_map.energy(R[0], c[0]) == pytest.approx(float(torque_map.energy_pairwise(R[0], c[0])), rel=1e-12)
    assert [a.shape for a in single] == [(), (3,), (3, 3)] and torque_map.torque_matrix(R[0]).shape == (3, 29)


def _numpy_direct(field, x, order):
    """``field``'s direct sum in NumPy (its compiled kernel switched off)."""
    plain = RotorField(field.poles, field.polarity, field.kernel)
    return plain.fields(x, order, method="direct")


@pytest.mark.parametrize("which", ["model", "torque_map"])
def test_compiled_sum_matches_numpy_sum(request, proto, which):
    """The compiled direct sum (spherestep._fast.kernels, numba) equals the NumPy one (every pole), orders 0–2,
    including points on a pole and opposite it (t = ±1): within 1e-12 of each quantity's peak plus the cut-off's
    stated tail for that derivative (CUTOFF_TAILS: 1e-13, 1e-12, 1e-10; the potential's kernel is cut at 78°, the
    magnets' map is not cut)."""
    field = request.getfixturevalue(which).rotor_field
    assert field.compiled is not None
    assert (field.cut is not None) == (which == "model")
    x = _unit(np.random.default_rng(5), 300)
    x[4], x[5] = proto.rotor.centers[0], -proto.rotor.centers[0]
    F0, g0, (lap0, H0) = _numpy_direct(field, x, 2)
    F1, g1, (lap1, H1) = field.fields(x, 2, method="direct")
    tails = CUTOFF_TAILS if field.cut is not None else (0.0, 0.0, 0.0)
    for got, want, tail in ((F1, F0, tails[0]), (g1, g0, tails[1]), (lap1, lap0, tails[2]), (H1, H0, tails[2])):
        assert np.max(np.abs(got - want)) <= (1e-12 + tail) * np.max(np.abs(want))


@pytest.mark.parametrize("which", ["model", "torque_map"])
def test_one_orientation_call_matches_the_batch(request, proto, which):
    """One orientation in one compiled call equals the same orientation in a batch (the vectorised path)."""
    m = request.getfixturevalue(which)
    rng = np.random.default_rng(6)
    R = so3.random(8, rng)
    c = rng.uniform(-1, 1, (8, len(proto.stator)))
    c[:, ::3] = 0.0
    E, tau = m.evaluate(R, c, 1)
    for i in range(len(R)):
        e, t = m.evaluate(R[i], c[i], 1)
        assert abs(e - E[i]) <= 1e-12 * max(1.0, abs(E[i]))
        assert np.max(np.abs(t - tau[i])) <= 1e-12 * m.torque_reference(c[i])


@pytest.mark.parametrize("which", ["model", "torque_map", "iron"])
def test_compiled_integrator_matches_the_reference_steps(request, proto, which):
    """The compiled integrator (a model with ``packed_terms``) follows Rotor.step's trajectory (compiled=False) to rounding,
    with damping and castor friction, for the potential, the magnets' map and the iron model (two terms)."""
    from spherestep.dynamics import Integrator, Rotor
    from spherestep.magnetics import iron_model

    m = iron_model(proto) if which == "iron" else request.getfixturevalue(which)
    states = proto.states()
    c = proto.coil_currents(states.coils(0))
    R0 = so3.exp(np.radians([3.0, 1.0, 0.0])) @ states.rotations[0]
    rotor = Rotor(inertia=0.05, damping=0.02, friction=0.01)
    w0 = np.array([0.1, 0.0, 0.2])
    fast = Integrator(m, rotor, 0.01).run(R0, w0, c, 0.57, record_every=7)
    slow = Integrator(m, rotor, 0.01, compiled=False).run(R0, w0, c, 0.57, record_every=7)
    assert np.array_equal(fast[2], slow[2])
    for got, want in zip(fast, slow):
        assert np.max(np.abs(got - want)) <= 1e-10 * max(1.0, np.max(np.abs(want)))


@pytest.mark.parametrize("which", ["model", "torque_map", "iron"])
def test_compiled_equilibrium_matches_the_reference_descent(request, proto, which):
    """statics.equilibrium's compiled descent (a model with ``packed_terms``) takes the NumPy reference's steps:
    the same iterations and verdicts, end points within 1e-9 rad, energies within 1e-12 relative, from perturbed
    stepper states with their own and with random 4-coil activations (batched, one R0 broadcast)."""
    from spherestep.magnetics import iron_model
    from spherestep.statics import equilibrium

    m = iron_model(proto) if which == "iron" else request.getfixturevalue(which)
    states = proto.states()
    rng = np.random.default_rng(11)
    ids = rng.integers(len(states), size=12)
    c = np.array([proto.coil_currents(states.coils(int(i))) for i in ids])
    c[6:] = 0.0
    for row in c[6:]:
        row[rng.choice(len(proto.stator), 4, replace=False)] = rng.choice([-1.0, 1.0], 4)
    R0 = so3.exp(rng.normal(scale=0.04, size=(12, 3))) @ states.rotations[ids]
    for start in (R0, R0[0]):
        fast = equilibrium(m, start, c)
        slow = equilibrium(m, start, c, compiled=False)
        assert np.array_equal(fast.iterations, slow.iterations)
        assert np.array_equal(fast.converged, slow.converged)
        assert np.max(so3.distance(fast.rotation, slow.rotation)) <= 1e-9
        assert np.max(np.abs(fast.energy - slow.energy)) <= 1e-12 * np.max(np.abs(slow.energy))
        assert np.max(np.abs(fast.stiffness - slow.stiffness)) <= 1e-8 * np.max(np.abs(slow.stiffness))


def test_models_declare_their_fast_path_and_bias(proto, model, torque_map):
    """Each model states what it offers: ``packed_terms`` (compiled zonal terms, or ``None``) and ``has_bias``
    (torque at zero current), and the declarations match what the model does."""
    from spherestep._fast import Packed
    from spherestep.magnetics import iron_model
    from spherestep.statics import TorqueModelBase, is_torque_model

    iron = iron_model(proto)
    slow = MotorPotential(proto, fast=False)
    R = so3.random(6, 3)
    zero = np.zeros((6, len(proto.stator)))
    c = proto.coil_currents(proto.states().coils(0))
    for m, bias, packed in ((model, False, True), (torque_map, False, True), (iron, True, True),
                            (slow, False, False)):
        assert is_torque_model(m) and m.has_bias is bias
        assert bool(np.any(m.torque(R, zero) != 0)) is bias
        terms = m.packed_terms(c)
        assert isinstance(terms, Packed) if packed else terms is None
        if packed:  # the packed energy at one orientation is the model's
            from spherestep._fast.terms import terms_evaluate, workspace

            tau, H = np.empty(3), np.empty((3, 3))
            C = np.ascontiguousarray(np.broadcast_to(terms.C, terms.C.shape[-2:]))
            e = terms.constant + terms_evaluate(terms.params, terms.offsets, R[0], terms.coils, C, terms.poles,
                                                terms.P, terms.signs, 1, tau, H, *workspace(terms.poles))
            assert abs(e - m.energy(R[0], c)) <= 1e-12 * max(1.0, abs(m.energy(R[0], c)))
            assert np.max(np.abs(tau - m.torque(R[0], c))) <= 1e-12 * m.torque_reference(c)
    assert TorqueModelBase.has_bias is True and TorqueModelBase.packed_terms(model, c) is None
    assert TorqueModelBase.affine_in_currents is False


def _sampled_affine(m) -> bool:
    """The probe the declaration replaced: packed terms at 0, 1 and 2 per unit in every live coil lie on a line."""
    live = np.ones(m.coil_count)
    live[list(m.failed)] = 0.0
    packs = [m.packed_terms(x * live) for x in (0.0, 1.0, 2.0)]
    if any(p is None for p in packs):
        return False
    p0, p1, p2 = packs
    return bool(np.allclose(p2.C, 2.0 * p1.C - p0.C, rtol=0.0, atol=1e-14) and np.array_equal(p0.params, p1.params)
                and np.array_equal(p0.signs, p1.signs))


def test_models_declare_whether_their_terms_are_affine(proto, model, torque_map):
    """``affine_in_currents`` (what the servo law's cache reads instead of sampling) agrees with a sample at 0, 1 and
    2 per unit for every model kind: the potential (fast and not), the torque map, the iron model pairwise and
    coupled."""
    from spherestep.magnetics import iron_model

    pairwise = iron_model(proto)
    for m in (model, MotorPotential(proto, fast=False), torque_map, pairwise, iron_model(proto, coupling=True)):
        assert m.affine_in_currents is _sampled_affine(m), type(m).__name__
