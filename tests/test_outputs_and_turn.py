"""The library under the thin CLI: commutation.turn, Plan.summary, output locations, stale temporary files,
and the diagnosis of designs that cannot step (issues 12 §5 and 13)."""

from __future__ import annotations

import dataclasses
import errno
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from spherestep import so3
from spherestep.atomic import remove_stale, write_text
from spherestep.commutation import Plan, Step, default_channel_map, turn, turn_targets
from spherestep.errors import ComputationError, InputError
from spherestep.motor.diagnosis import unusable_reasons
from spherestep.outputs import Outputs, output_file, output_folder


def test_turn_targets_start_at_the_nearest_state_and_turn_the_angle_in_equal_steps(proto):
    axis = np.array([1.0, 0.5, 2.0])
    targets = turn_targets(proto, axis, math.radians(90.0), steps=6)
    states = proto.states()
    start = states.rotations[int(states.nearest(np.eye(3))[1].ravel()[0])]
    assert targets.shape == (7, 3, 3) and np.allclose(targets[0], start, atol=1e-12)
    expected_end = so3.rot(axis / np.linalg.norm(axis), math.radians(90)) @ start  # independent: one rotation
    assert so3.distance(targets[-1], expected_end) < 1e-9
    gaps = so3.distance(targets[:-1], targets[1:])
    assert np.allclose(gaps, math.radians(15), atol=1e-9)  # equal steps of 90°/6
    default = turn_targets(proto, axis, math.radians(90.0))  # default: steps of at most 0.35 of a max step
    n = len(default) - 1
    assert math.radians(90) / n <= 0.35 * proto.max_step + 1e-12 < math.radians(90) / (n - 1)


def test_turn_plans_with_either_planner_and_names_its_own_arguments(proto):
    plan = turn(proto, (0, 0, 1), math.radians(30), steps=4)  # radians, like every library function
    assert len(plan.steps) == 5 and plan.planner == "geometric"
    assert so3.distance(plan.targets[-1], so3.rot([0, 0, 1], math.radians(30)) @ plan.targets[0]) < 1e-9
    for kwargs, name in (({"axis": (0, 0, 0)}, "axis"), ({"axis": (1, 2)}, "axis"), ({"angle": 0}, "angle"),
                         ({"axis": (1e-320, 0, 0)}, "axis"),
                         ({"angle": float("nan")}, "angle"), ({"angle": 700.0}, "angle"),
                         ({"steps": 0}, "steps"), ({"steps": 2.5}, "steps"), ({"planner": "magic"}, "planner")):
        args = {"axis": (0, 0, 1), "angle": math.radians(30), "steps": 4} | kwargs
        with pytest.raises(InputError, match=f"^{name} must be") as info:
            turn(proto, **args)
        assert info.value.field == name


def _plan(statuses, errors_deg, moves):
    I3 = np.eye(3)
    steps, R = [], I3
    for i, (status, err, move) in enumerate(zip(statuses, errors_deg, moves)):
        R = so3.rot(np.array([0.0, 0, 1]), math.radians(10)) @ R if move else R
        target = so3.rot(np.array([0.0, 0, 1]), math.radians(30 * i))
        steps.append(Step(index=i, target=target, achieved=R, error=math.radians(err), coils={0: 1, 1: -1},
                          status=status))
    return Plan(steps=steps, coil_count=2, channel_map=default_channel_map(2))


def test_plan_summary_counts_errors_and_warnings():
    plan = _plan(["ok", "ok", "hold", "detour: x", "blocked: y", "settle: z"], [0, 1, 2, 3, 4, 0.5],
                 [False, True, False, True, False, True])
    s = plan.summary()
    assert (s.steps, s.moves, s.holds, s.detours, s.blocked, s.settle_steps) == (5, 3, 1, 1, 1, 1)
    assert s.error_max == pytest.approx(math.radians(4)) and s.error_final == pytest.approx(math.radians(0.5))
    assert s.target_step_max == pytest.approx(math.radians(30))
    assert s.warnings == ("1 steps blocked", "1 detours (the target's nearest states were out of reach)")
    d = s.to_dict()
    assert d["error_max_deg"] == pytest.approx(4) and d["target_step_max_deg"] == pytest.approx(30)
    assert s.to_dict(degrees=False)["error_max_rad"] == pytest.approx(math.radians(4))
    warned = plan.summary(max_step=math.radians(20)).warnings[0]
    assert warned.startswith("a desired step of 30.00° exceeds the design's max step 20.00°")
    assert "WARNING: a desired step" in plan.summary(max_step=math.radians(20)).line()


def test_output_locations_are_checked_without_creating_anything(tmp_path):
    afile = tmp_path / "afile"
    afile.write_text("x")
    for bad, message in ((afile, "is a file"), (afile / "sub", "lies under"), ("/dev/null", "not a folder")):
        with pytest.raises(InputError, match=message):
            output_folder(bad)
    assert output_folder(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()  # created by the first write, not by the check
    for bad, message in ((tmp_path, "is a folder"), ("/dev/null", "not a regular file"), (afile / "x.csv", "lies under"),
                         (tmp_path / "x.txt", "must end in .csv")):
        with pytest.raises(InputError, match=message):
            output_file(bad, suffixes=(".csv",))
    with pytest.raises(InputError, match="exists; give --force"):
        output_file(afile, force=False)
    assert output_file(afile, force=True) == afile


def test_a_read_only_folder_is_a_user_mistake(tmp_path):
    ro = tmp_path / "ro"
    ro.mkdir()
    mounted = os.geteuid() == 0 and subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64k,ro", "tmpfs", str(ro)], capture_output=True).returncode == 0
    if not mounted:
        if os.geteuid() == 0:
            pytest.skip("root ignores permission bits and tmpfs could not be mounted")
        ro.chmod(0o555)
    try:
        with pytest.raises(InputError, match="is not writable"):
            output_folder(ro / "out")
    finally:
        if mounted:
            subprocess.run(["umount", str(ro)], check=True)
        else:
            ro.chmod(0o755)


def test_outputs_turn_a_full_disk_into_n_of_m_files_written(tmp_path):
    (tmp_path / "a.txt").write_text("old")  # written before the block (an hour ago): not counted
    os.utime(tmp_path / "a.txt", (os.path.getmtime(tmp_path / "a.txt") - 3600,) * 2)
    with pytest.raises(ComputationError, match=r"the disk is full \(.*c.txt\): 1 of 3 files written"):
        with Outputs(tmp_path, ["a.txt", "b.txt", "c.txt"]):
            write_text(tmp_path / "b.txt", "new")
            raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "c.txt"))
    with pytest.raises(InputError, match=r"--out: could not write .*Permission denied.*0 of 1 files"):
        with Outputs(tmp_path / "x", ["x.txt"]):
            raise PermissionError(errno.EACCES, "Permission denied", str(tmp_path / "x" / "x.txt"))


def test_stale_temporary_files_are_removed_only_when_their_writer_is_gone(tmp_path):
    dead = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True,
                              text=True).stdout)
    stale, mine, other = (tmp_path / f".f.{dead}.ab.tmp", tmp_path / f".f.{os.getpid()}.cd.tmp",
                          tmp_path / ".not-ours.tmp")
    for p in (stale, mine, other):
        p.write_text("x")
    assert remove_stale(tmp_path) == [stale]
    assert mine.exists() and other.exists()
    with pytest.raises(InputError, match="not a regular file"):
        write_text("/dev/null", "never")  # never renamed over a device


def test_the_diagnosis_of_designs_that_cannot_step(proto):
    assert unusable_reasons(proto) == []
    one = proto.without_coils(range(1, len(proto.stator)))
    assert unusable_reasons(one)[0].startswith("the stator has 1 working coil (29 in the cap of half-angle 80.0°, "
                                               "28 failed) and a state needs two")
    u = proto.rotor.centers
    cos = np.clip(u @ u.T, -1, 1)
    spacing = np.degrees(np.min(np.arccos(cos[~np.eye(len(u), dtype=bool)])))  # brute force, every pair
    wide = dataclasses.replace(proto, tol=math.radians(12))
    reason = unusable_reasons(wide, lambda name: {"tol": "tolerance"}.get(name, name))[0]
    assert reason.startswith(f"tolerance 12° is over half the rotor's pole spacing ({spacing:.3g}°)")
    assert f"make tolerance smaller than {spacing / 2:.3g}°" in reason


@pytest.mark.parametrize("call, name", [
    (lambda c: c.about_axis((0, 0, 1), 1.0, 0), "steps"),
    (lambda c: c.about_axis((0, 0, 1), 1.0, 2.5), "steps"),
    (lambda c: c.about_axis((0, 0, 1), 1.0, 3, start=2 * np.eye(3)), "start"),
    (lambda c: c.through(np.stack([np.eye(3)] * 2), 0), "steps"),
    (lambda c: c.through(np.stack([2 * np.eye(3)] * 2), 3), "keys"),
    (lambda c: c.steps_for(float("nan"), 0.1), "length"),
    (lambda c: c.plan_geometric(None, "abc"), "targets"),
    (lambda c: c.turn(None, (0, 0, 1), 30), "design"),
    (lambda c: c.turn_targets("prototype", (0, 0, 1), 30), "design"),
])
def test_the_trajectory_api_names_its_own_arguments(call, name):
    import spherestep.commutation as c

    with pytest.raises(InputError, match=f"^{name} must be"):
        call(c)


def test_turn_with_the_potential_planner_follows_the_same_targets(proto):
    plan = turn(proto, (0, 0, 1), math.radians(20), steps=2, planner="potential")
    assert plan.planner == "potential" and len(plan.steps) == 3
    assert np.allclose(plan.targets, turn_targets(proto, (0, 0, 1), math.radians(20), steps=2), atol=1e-12)
    assert plan.summary().error_max < proto.max_step  # every step lands within reach of its target
