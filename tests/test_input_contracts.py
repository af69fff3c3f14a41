"""One input contract per concept: every public function that takes rotations refuses a non-rotation, and every
one that takes points on the sphere refuses a non-unit vector, with the project's one-line InputError naming
its own argument (``exc.field``); and the rooms accept the same batches."""

import math

import numpy as np

from spherestep import commutation, harmonics, so3, sphere, statics
from spherestep.errors import InputError

NOT_ROTATIONS = {"scaled": 2 * np.eye(3), "reflection": np.diag([1.0, 1.0, -1.0]), "shape": np.eye(2)}
EYE = np.eye(3)


def pair(R):
    """``[I, R]`` for a 3 × 3 ``R``; a wrongly shaped ``R`` is passed on as a batch of one."""
    R = np.asarray(R)
    return np.stack([EYE, R]) if R.shape == (3, 3) else R[None]


def rotation_takers(proto, model):
    """``(label, call(R), argument name)`` for the public functions that take rotations."""
    states = proto.states()
    c = proto.coil_currents(states.coils(0))
    fhat = harmonics.so3_forward(np.ones((5, 3, 5)))
    flm = harmonics.s2_forward(np.ones((3, 5)))
    return [
        ("so3.angle", lambda R: so3.angle(R), "R"),
        ("so3.distance R1", lambda R: so3.distance(R, EYE), "R1"),
        ("so3.distance R2", lambda R: so3.distance(EYE, R), "R2"),
        ("so3.log", lambda R: so3.log(R), "R"),
        ("so3.to_euler_zyz", lambda R: so3.to_euler_zyz(R), "R"),
        ("so3.geodesic", lambda R: so3.geodesic(EYE, R, 0.5), "R2"),
        ("so3.turned_angle", lambda R: so3.turned_angle(pair(R), [0, 0, 1]), "rotations"),
        ("so3.resample", lambda R: so3.resample(pair(R), 3), "path"),
        ("StepperStates.nearest", lambda R: states.nearest(R), "R"),
        ("StepperStates.within", lambda R: states.within(R, 0.1), "R"),
        ("commutation.about_axis", lambda R: commutation.about_axis([0, 0, 1], 0.5, 4, start=R), "start"),
        ("commutation.through", lambda R: commutation.through(pair(R), 4), "keys"),
        ("commutation.plan_geometric", lambda R: commutation.plan_geometric(proto, pair(R)), "targets"),
        ("statics.equilibrium", lambda R: statics.equilibrium(model, R, c), "R0"),
        ("statics.holding_torque", lambda R: statics.holding_torque(model, R, c), "R_eq"),
        ("statics.step_torque", lambda R: statics.step_torque(model, EYE, R, c), "R_to"),
        ("MotorPotential.energy", lambda R: model.energy(R, c), "R"),
        ("MotorPotential.torque", lambda R: model.torque(R, c), "R"),
        ("harmonics.so3_evaluate", lambda R: harmonics.so3_evaluate(fhat, R), "R"),
        ("harmonics.s2_rotate", lambda R: harmonics.s2_rotate(flm, R), "R"),
    ]


def test_every_rotation_taker_refuses_a_non_rotation_naming_its_argument(proto, model):
    failures = []
    for label, call, name in rotation_takers(proto, model):
        for kind, bad in NOT_ROTATIONS.items():
            try:
                call(bad)
            except InputError as exc:
                if exc.field != name or "\n" in str(exc):
                    failures.append(f"{label} ({kind}): field {exc.field!r}, expected {name!r}: {exc}")
            except Exception as exc:  # noqa: BLE001 (collected: a bare TypeError is what this test is against)
                failures.append(f"{label} ({kind}): {type(exc).__name__}: {exc}")
            else:
                failures.append(f"{label} ({kind}): accepted")
    assert not failures, "\n".join(failures)


def test_every_point_taker_refuses_a_non_unit_vector_naming_its_argument(proto):
    from spherestep import packing as pk

    flm = harmonics.s2_forward(np.ones((3, 5)))
    takers = [
        ("sphere.angles", lambda u: sphere.angles(u), "u"),
        ("sphere.arc_distance", lambda u: sphere.arc_distance([0, 0, 1], u), "u2"),
        ("harmonics.sph_harm_u", lambda u: harmonics.sph_harm_u(1, 0, u), "u"),
        ("harmonics.s2_evaluate", lambda u: harmonics.s2_evaluate(flm, u), "u"),
        ("Packing.within_cap", lambda u: pk.named("cube").within_cap(u, 1.0), "axis"),
    ]
    failures = []
    for label, call, name in takers:
        for bad in ([0, 0, 2.0], [0.0, 0.0, 0.0], [1.0, 0.0]):
            try:
                call(bad)
            except InputError as exc:
                if exc.field != name:
                    failures.append(f"{label}: field {exc.field!r}, expected {name!r}")
            except Exception as exc:  # noqa: BLE001
                failures.append(f"{label}: {type(exc).__name__}: {exc}")
            else:
                failures.append(f"{label}: accepted {bad}")
    assert not failures, "\n".join(failures)


def test_rooms_accept_the_same_batches(proto, model):
    """A (2, 3) batch of rotations gives the same numbers as the flat (6,) batch, in every room."""
    R = so3.random(6, 5)
    c = proto.coil_currents(proto.states().coils(0))
    batch = R.reshape(2, 3, 3, 3)
    assert np.array_equal(so3.angle(batch).ravel(), so3.angle(R))
    assert np.allclose(model.energy(batch, c).ravel(), model.energy(R, c), rtol=1e-12, atol=0)
    d, i = proto.states().nearest(batch)
    assert d.shape == (2, 3, 1) and np.array_equal(i.reshape(-1), proto.states().nearest(R)[1].reshape(-1))
    assert math.isfinite(float(harmonics.so3_evaluate(harmonics.so3_forward(np.ones((5, 3, 5))), batch).real.sum()))
