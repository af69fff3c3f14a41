"""Trajectories, the geometric planner (Sec. III-A) and the plan's file formats."""

import json
import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.commutation import Plan, about_axis, plan_geometric, steps_for, through
from spherestep.errors import InputError
from spherestep.sphere import arc_distance


def test_about_axis_turns_at_equal_steps():
    T = about_axis([1, 2, 3], 2 * math.pi, 40, start=so3.rot([0, 1, 0], 0.3))
    d = so3.distance(T[:-1], T[1:])
    assert np.allclose(d, 2 * math.pi / 40, atol=1e-12)
    assert so3.distance(T[0], T[-1]) < 1e-12
    # the axis of every step is the fixed-frame axis (left multiplication)
    axis, _ = so3.axis_angle(T[1:] @ np.swapaxes(T[:-1], 1, 2))
    assert np.allclose(axis, np.array([1, 2, 3]) / math.sqrt(14), atol=1e-10)


def test_through_keys_equal_steps():
    keys = np.array([so3.rot([0, 0, 1], 0.0), so3.rot([0, 0, 1], 0.6), so3.rot([0.3, 0, 1], 0.9) @ so3.rot([0, 0, 1], 0.6),
                     so3.rot([0, 1, 1], 0.5) @ so3.rot([0.3, 0, 1], 0.9) @ so3.rot([0, 0, 1], 0.6)])
    T = through(keys, 30)
    d = so3.distance(T[:-1], T[1:])
    assert np.ptp(d) < 1e-10 and so3.distance(T[-1], keys[-1]) < 1e-12


def test_steps_for():
    assert steps_for(math.pi, math.pi / 4) == 4 and steps_for(1.0, 2.0) == 1
    with pytest.raises(InputError):
        steps_for(1.0, 0.0)


def _check_plan(design, plan, metrics):
    achieved = plan.achieved
    moves = so3.distance(achieved[:-1], achieved[1:])
    assert moves.max() <= design.max_step + 1e-12
    cap_cos = math.cos(design.cap_half_angle)
    for step in plan.steps:
        assert len(step.coils) >= 2
        assert {k for _, k in step.held} == set(step.coils)
        for j, k in step.held:
            assert design.stator.centers[k] @ design.stator_axis >= cap_cos - 1e-12
            assert arc_distance(step.achieved @ design.rotor.centers[j], design.stator.centers[k]) <= design.state_tol + 1e-12
            assert step.coils[k] == design.polarity[j]
        assert math.isclose(step.error, so3.distance(step.achieved, step.target), abs_tol=1e-12)
    assert plan.errors[-1] <= metrics.resolution_p95_rad


@pytest.mark.slow
def test_full_turns_about_random_axes(proto, proto_metrics):
    rng = np.random.default_rng(2024)
    states = proto.states()
    for _ in range(50):
        axis = rng.normal(size=3)
        start = states.rotations[rng.integers(len(states))]
        T = about_axis(axis, 2 * math.pi, steps_for(2 * math.pi, 0.5 * proto.max_step), start=start)
        plan = plan_geometric(proto, T)
        _check_plan(proto, plan, proto_metrics)
        # the plan follows the path: typical error within the design's resolution
        assert np.median(plan.errors) <= proto_metrics.resolution_p95_rad


def test_plan_from_arbitrary_start_ends_near_target(proto, proto_metrics):
    T = about_axis([0.2, -1, 0.4], math.radians(200), 30, start=so3.random(1, 3)[0])
    plan = plan_geometric(proto, T)
    assert plan.errors[-1] <= proto_metrics.resolution_max_rad


def test_axis_cost_prefers_the_desired_direction(proto):
    """Each move's axis (relative to the previous state) points closer to the desired axis than a random one."""
    states = proto.states()
    axis = np.array([0.0, 0.6, 0.8])
    T = about_axis(axis, math.radians(120), 20, start=states.rotations[0])
    plan = plan_geometric(proto, T)
    cosines = []
    for a, b in zip(plan.steps[:-1], plan.steps[1:]):
        if b.status == "ok" and so3.distance(a.achieved, b.achieved) > 0:
            n, _ = so3.axis_angle(b.achieved @ a.achieved.T)  # fixed-frame axis of the move
            cosines.append(n @ axis)
    assert len(cosines) >= 10 and np.median(cosines) > 0.5


def test_next_pole_is_held_in_the_next_step(proto):
    T = about_axis([1, 0, 0], math.radians(90), 15, start=proto.states().rotations[10])
    plan = plan_geometric(proto, T)
    for a, b in zip(plan.steps[:-1], plan.steps[1:]):
        if a.next_pole is not None:
            assert a.next_pole in {j for j, _ in b.held} and a.next_pole not in {j for j, _ in a.held}


def test_plan_round_trips_through_json_and_masks(proto, tmp_path):
    T = about_axis([0, 0, 1], math.radians(45), 6, start=proto.states().rotations[3])
    plan = plan_geometric(proto, T)
    path = tmp_path / "plan.json"
    plan.to_json(path)
    back = Plan.from_json(path)
    assert [s.coils for s in back.steps] == [s.coils for s in plan.steps]
    assert np.allclose(back.achieved, plan.achieved, atol=1e-14)
    data = json.loads(path.read_text())
    for s, row in zip(plan.steps, data["steps"]):
        enable = int(row["enable_mask"], 16)
        polarity = int(row["polarity_mask"], 16)
        for k in range(plan.coil_count):
            on = bool(enable >> int(proto.channel_map[k, 0]) & 1)
            reversed_ = bool(polarity >> int(proto.channel_map[k, 1]) & 1)
            assert on == (k in s.coils)
            assert reversed_ == (s.coils.get(k) == -1)
    csv = plan.to_csv(tmp_path / "plan.csv").splitlines()
    assert len(csv) == len(plan.steps) + 1 and csv[0].startswith("step,status")


@pytest.mark.parametrize("text, field", [
    ("{", "plan"),
    ('{"format": "other"}', "plan.format"),
    ('{"format": "spherestep-plan", "version": 9}', "plan.version"),
    ('{"format": "spherestep-plan", "version": 1, "coil_count": 2, "channel_map": [], "steps": []}',
     "plan.version must be 2 .*plan the turn again"),
    ('{"format": "spherestep-plan", "version": 2, "coil_count": 2, "channel_map": [], "steps": []}',
     "plan.design_fingerprint"),
    ('{"format": "spherestep-plan", "version": 2, "design_fingerprint": null, "coil_count": 2, "channel_map": [], '
     '"steps": []}', "channel_map"),
    ('{"format": "spherestep-plan", "version": 2, "design_fingerprint": "md5:1", "coil_count": 2, "channel_map": [], '
     '"steps": []}', "plan.design_fingerprint"),
    ('{"format": "spherestep-plan", "version": 2, "design_fingerprint": null, "coil_count": 1, "channel_map": '
     '[{"enable": 0, "polarity": 1}], "steps": [{"index": 0, "coils": {"5": 1}, "target": [], "achieved": [], '
     '"error_deg": 0}]}', "coils"),
])
def test_bad_plan_files_raise_input_errors(tmp_path, text, field):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(InputError, match=field):
        Plan.from_json(path)


def test_planner_rejects_bad_targets(proto):
    with pytest.raises(InputError, match="targets"):
        plan_geometric(proto, np.eye(3))
    with pytest.raises(InputError, match="candidates"):
        plan_geometric(proto, np.stack([np.eye(3)] * 2), candidates=0)


@pytest.mark.slow
def test_planner_works_around_failed_coils(proto):
    broken = proto.without_coils([3, 7])
    T = about_axis([1, 1, 0], math.radians(90), 12, start=broken.states().rotations[0])
    plan = plan_geometric(broken, T)
    assert all(3 not in s.coils and 7 not in s.coils for s in plan.steps)


def test_potential_planner_lands_on_equilibria(proto, model):
    from spherestep.commutation import plan_potential
    from spherestep.potential import coil_currents
    from spherestep.statics import equilibrium

    T = about_axis([1, 0.5, 2], math.radians(60), 8, start=proto.states().rotations[0])
    plan = plan_potential(proto, T, model, max_coils=3)
    assert plan.planner == "potential" and len(plan.steps) == len(T)
    for prev, step in zip(plan.steps[:-1], plan.steps[1:]):
        assert 2 <= len(step.coils) <= 3
        # the achieved orientation is a strict minimum of the energy under the step's coils ...
        eq = equilibrium(model, step.achieved, coil_currents(proto, step.coils))
        assert so3.distance(eq.rotation, step.achieved) < 1e-6 and eq.is_minimum
        # ... within one step of the previous one
        assert so3.distance(prev.achieved, step.achieved) <= proto.max_step + 1e-9
    assert np.median(plan.errors) < math.radians(6)


def test_planner_activations_are_the_trimmed_state_activations(proto):
    """The planner's one-pass candidate currents (_activations) are, row by row, the coil → polarity maps of
    _trim (each state's held pairs, the max_coils closest at the target) — including states holding more pairs
    than max_coils."""
    from spherestep.commutation.potential_planner import _activations, _trim
    from spherestep.potential import coil_currents

    states = proto.states()
    rng = np.random.default_rng(3)
    ids = np.concatenate([rng.integers(len(states), size=40), np.flatnonzero(states.counts > 3)[:10]])
    target = so3.random(1, rng)[0]
    for max_coils in (2, 3, 4):
        got = _activations(states, proto, target, ids, max_coils)
        want = [coil_currents(proto, _trim(states.held(int(i)), proto, target, max_coils)) for i in ids]
        assert np.array_equal(got, np.array(want))
    # no state holds more than max_coils pairs: the ranking is skipped, the currents the same
    assert np.array_equal(_activations(states, proto, target, ids, 4, ranked=False), got)


def test_planner_distinct_keeps_each_activation_at_its_last_offer():
    from spherestep._fast.relays import distinct

    options = np.array([[1.0, 0], [0, 1], [1, 0], [0, -1], [0, 1], [1, 0]])
    assert distinct(options).tolist() == [5, 4, 3]


def test_planner_best_is_the_nearest_strict_minimum_within_reach():
    from spherestep._fast.relays import best

    here, target = np.eye(3), so3.rot([0, 0, 1], 0.1)
    R = np.array([so3.rot([0, 0, 1], a) for a in (0.09, 0.05, 0.5, 0.1, 0.05)])
    H = np.array([np.diag([-1.0, 2, 3]), np.eye(3), np.eye(3), np.eye(3), np.eye(3)])  # 0 a saddle, 2 far, 3 unconverged
    converged = np.array([True, True, True, False, True])
    back = np.swapaxes(R, 1, 2)
    assert best(back @ here, back @ target, H, converged, 0.3) == 1  # of 1 and 4 (equal), the first
    assert best(back @ here, back @ target, np.eye(3)[None].repeat(5, 0), converged, 0.3) == 0  # no saddle: the nearest
    assert best(back @ here, back @ target, H, converged, 0.01) == -1


def _reference_plan(design, targets, model, max_coils=4, candidates=8, max_step=None):
    """The potential planner's loop written plainly with the public statics (one equilibrium call per step, NumPy
    Park distances): what plan_potential must reproduce step for step."""
    from spherestep.commutation.geometric import BLOCKED, start_state
    from spherestep.commutation.potential_planner import _activations, _trim
    from spherestep.potential import coil_currents
    from spherestep.statics import equilibrium

    states, reach = design.states(), design.max_step if max_step is None else max_step
    first = start_state(states, targets[0])
    coils = _trim(states.held(first), design, states.rotations[first], max_coils)
    current = coil_currents(design, coils)
    here = equilibrium(model, states.rotations[first], current).rotation
    _, near = states.nearest(targets, k=candidates)
    out = [(coils, here, "ok")]
    for i in range(1, len(targets)):
        around = states.within(here, reach)
        around = around[np.argsort(so3.distance(states.rotations[around], targets[i]))[:candidates]]
        ids = np.concatenate([near[i], around])
        options = np.vstack([current[None], _activations(states, design, targets[i], ids, max_coils)])
        unique = list({row.tobytes(): n for n, row in enumerate(options)}.values())
        eq = equilibrium(model, here, options[unique])
        valid = eq.is_minimum & (so3.distance(eq.rotation, here) <= reach)
        if not valid.any():
            out.append((coils, here, BLOCKED))
            continue
        best = int(np.argmin(np.where(valid, so3.distance(eq.rotation, targets[i]), np.inf)))
        if unique[best] != 0:
            coils = _trim(states.held(int(ids[unique[best] - 1])), design, targets[i], max_coils)
            current = options[unique[best]]
        here = eq.rotation[best]
        out.append((coils, here, "hold" if unique[best] == 0 else "ok"))
    return out


@pytest.mark.slow
@pytest.mark.parametrize("case", ["turn", "two coils", "standing", "short reach", "failed coil"])
def test_potential_planner_matches_its_plain_loop(proto, model, case):
    """plan_potential (inputs checked once, the descent called directly, compiled bookkeeping) chooses, step by
    step, the coils of the plain loop above, in the same order, with the same status, at the same equilibria."""
    from spherestep.commutation import plan_potential
    from spherestep.potential import MotorPotential

    design, states, kwargs = proto, proto.states(), {}
    T = about_axis([0.3, -1, 0.6], math.radians(120), 16, start=states.rotations[11])
    if case == "two coils":
        kwargs = {"max_coils": 2}  # states holding 3 or 4 pairs: ranked by closeness
    elif case == "standing":  # targets repeated, the last on a state: ties between symmetric states
        T = np.concatenate([T[:4], np.repeat(T[4:5], 4, axis=0), np.repeat(states.rotations[11][None], 4, axis=0)])
    elif case == "short reach":  # hardly any equilibrium within reach: "hold" steps
        kwargs = {"max_step": 0.03 * proto.max_step}
    elif case == "failed coil":
        design = proto.without_coils([4])
        T = about_axis([1, 0, 0], math.radians(60), 8, start=design.states().rotations[0])
    energy = model if design is proto else MotorPotential(design)
    plan = plan_potential(design, T, energy, **kwargs)
    want = _reference_plan(design, T, energy, **kwargs)
    assert [list(s.coils.items()) for s in plan.steps] == [list(c.items()) for c, _, _ in want]
    assert [s.status for s in plan.steps] == [status for _, _, status in want]
    assert ("hold" in [s.status for s in plan.steps]) == (case == "short reach")
    assert np.max(np.abs(np.array([s.achieved for s in plan.steps]) - np.array([h for _, h, _ in want]))) < 1e-12
    u, v = design.rotor.centers, design.stator.centers  # held: the poles within tolerance of an energised coil
    for s in plan.steps:
        ks = list(s.coils)
        near = (s.achieved @ u.T).T @ v[ks].T >= np.cos(design.state_tol)
        assert s.held == [(int(j), ks[c]) for j, c in zip(*np.nonzero(near))]


def test_potential_planner_beats_or_matches_geometric_on_a_turn(proto, model):
    from spherestep.commutation import plan_potential

    T = about_axis([0.2, -1, 0.5], 2 * math.pi, steps_for(2 * math.pi, 0.5 * proto.max_step),
                   start=proto.states().rotations[17])
    geometric = plan_geometric(proto, T)
    potential = plan_potential(proto, T, model)
    assert np.median(potential.errors) <= np.median(geometric.errors) + math.radians(0.5)
    assert potential.errors[-1] < math.radians(2)


@pytest.mark.slow
def test_potential_planner_avoids_failed_coils(proto):
    from spherestep.commutation import plan_potential
    from spherestep.potential import MotorPotential

    broken = proto.without_coils([4])
    T = about_axis([1, 0, 0], math.radians(40), 5, start=broken.states().rotations[0])
    plan = plan_potential(broken, T, MotorPotential(broken))
    assert all(4 not in s.coils for s in plan.steps)
