"""spherestep.explore without worker processes: keys, the grid and its rule, unbuildable designs, the results
store, resuming, the Pareto front against brute force, and the command line."""

import itertools
import json
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spherestep import packing as pk
from spherestep.cli import main
from spherestep.errors import InputError
from spherestep.explore import (COLUMNS, MEASURED, DesignPoint, Grid, Limits, ResultStore, build_design,
                                candidate_count, dask_client, default_grid, distinct_names, evaluate, finished_keys,
                                pareto_front, pareto_mask, run_sweep, symmetry_family)
from spherestep.explore import run as explore_run
from spherestep.explore.build import lookup_voxels, motor_fingerprint
from spherestep.motor import MotorDesign
from spherestep.sphere import NearestPointGrid

OBJECTIVES_ONLY = ["key", "motor", "status", "coils", "resolution_median_deg", "reaches_all"]
PROTO_POINT = DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0)
SMALL = Grid(rotors=("dodecahedron", "icosidodecahedron"), stators=("truncated-octahedron", "rhombicuboctahedron"),
             rotor_levels=(0,), stator_levels=(0,), cap_half_angles_deg=(60.0, 80.0), primary_ratio_max=None,
             samples=300, torque_states=0)


# --- keys and the grid -------------------------------------------------------------------------------------

def test_key_is_a_stable_hash_of_every_parameter():
    assert PROTO_POINT.key == "55c1027179c56059"  # the same in every process and run (key version 2)
    assert DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80).key == PROTO_POINT.key
    assert DesignPoint.from_params(PROTO_POINT.params).key == PROTO_POINT.key
    assert DesignPoint.from_params(json.dumps(PROTO_POINT.params)) == PROTO_POINT
    changed = [DesignPoint("truncated-icosahedron", 2, "truncated-cuboctahedron", 1, 80.0),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 0, 80.0),
               DesignPoint("truncated-icosahedron", 1, "cube", 1, 80.0),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 79.0),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, tol_deg=0.5),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, samples=2001),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, seed=1),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, torque_states=0),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, fill=0.8),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, stator_axis=(0, 0, 1)),
               DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 1, 80.0, core="air")]
    assert len({p.key for p in changed} | {PROTO_POINT.key}) == len(changed) + 1


def test_families_are_the_packings_own_symmetry_groups():
    assert len(distinct_names()) == 16
    assert symmetry_family("tetrahedron") == "T" and symmetry_family("truncated-tetrahedron") == "T"
    # built in the tetrahedral family, but congruent to octahedral packings: their group is O
    for name in ("tetrahedral-octahedron", "tetrahedral-cuboctahedron", "tetrahedral-truncated-octahedron"):
        assert symmetry_family(name) == "O"
    assert symmetry_family("truncated-cuboctahedron") == "O" and symmetry_family("truncated-icosahedron") == "I"


def test_default_grid_follows_the_rule_and_keeps_flagged_contrast():
    grid = default_grid()
    points = grid.points()
    pairs = grid.pairs()
    assert len(points) == len(pairs) * 3 * 2 * 2 * 1 == 648
    assert ("truncated-icosahedron", "truncated-cuboctahedron") in pairs  # the paper's choice (Sec. II-B-3)
    assert PROTO_POINT.key in {p.key for p in points}
    radius = {n: pk.by_name(n).radii[0] for n in distinct_names()}
    for rotor, stator in itertools.product(distinct_names(), repeat=2):
        ratio = max(radius[rotor], radius[stator]) / min(radius[rotor], radius[stator])
        assert ((rotor, stator) in pairs) == (ratio <= 1.25 + 1e-12)
    rules = {p.family_rule for p in points}
    assert rules == {"same", "different"}
    for p in points:
        assert p.family_rule == ("same" if symmetry_family(p.rotor) == symmetry_family(p.stator) else "different")
    strict = default_grid(same_family=False)
    assert all(p.family_rule == "different" for p in strict.points())
    assert len(strict.points()) == sum(p.family_rule == "different" for p in points)
    assert len({p.key for p in points}) == len(points)


@pytest.mark.parametrize("changes, field", [
    (dict(rotors=("no-such-packing",)), "rotors"), (dict(stators=()), "stators"),
    (dict(rotor_levels=(0, 9)), "rotor_levels"), (dict(stator_levels=(1, 1)), "stator_levels"),
    (dict(cap_half_angles_deg=(90.0,)), "cap_half_angles_deg"), (dict(tolerances_deg=(0.0,)), "tolerances_deg"),
    (dict(primary_ratio_max=0.5), "primary_ratio_max"), (dict(samples=0), "samples"),
    (dict(torque_states=-1), "torque_states"),
    (dict(rotor_levels=(True,)), "rotor_levels"),
])
def test_bad_grids_name_the_field(changes, field):
    with pytest.raises(InputError, match=rf"^{field} must be"):
        Grid(**changes)


# --- building and measuring one design ---------------------------------------------------------------------

def test_prototype_point_builds_the_prototype(proto):
    design = build_design(PROTO_POINT)
    assert motor_fingerprint(design) == motor_fingerprint(proto)
    assert len(design.stator) == len(proto.stator) == 29 and len(design.rotor) == 92
    assert design.magnet_diameter == pytest.approx(proto.magnet_diameter, rel=1e-12)
    assert design.coil_diameter == pytest.approx(proto.coil_diameter, rel=1e-12)
    assert candidate_count(design) == 114_240  # the alignments find_states starts from (docstring of build)


def test_candidate_count_against_brute_force():
    design = build_design(DesignPoint("icosidodecahedron", 0, "rhombicuboctahedron", 0, 80.0))
    u, v, tol = design.rotor.centers, design.stator.centers, design.state_tol
    count = 0
    for k1, k2 in itertools.combinations(range(len(v)), 2):
        s = math.acos(np.clip(v[k1] @ v[k2], -1, 1))
        for j1, j2 in itertools.permutations(range(len(u)), 2):
            count += abs(math.acos(np.clip(u[j1] @ u[j2], -1, 1)) - s) <= 2 * tol
    assert candidate_count(design) == count > 0


def test_lookup_voxels_is_the_grid_state_enumeration_builds():
    for point in (DesignPoint("truncated-icosahedron", 1, "truncated-cuboctahedron", 0, 60.0),
                  DesignPoint("truncated-cuboctahedron", 2, "truncated-icosahedron", 0, 60.0, tol_deg=0.5)):
        design = build_design(point)
        assert lookup_voxels(design) == len(NearestPointGrid(design.rotor.centers, design.state_tol).ids)


def test_measured_row_agrees_with_the_motor_metrics():
    point = DesignPoint("truncated-icosahedron", 0, "truncated-cuboctahedron", 0, 60.0, samples=500, seed=3)
    row = evaluate(point)
    metrics = build_design(point).metrics(samples=500, seed=3)
    assert row["status"] == "ok" and row["reason"] == ""
    assert row["coils"] == 16 and row["rotor_poles"] == 60
    assert row["states"] == metrics.states
    assert row["resolution_median_deg"] == math.degrees(metrics.resolution_median_rad)
    assert row["resolution_max_deg"] == math.degrees(metrics.resolution_max_rad)
    assert row["escape_violations"] == len(metrics.escape_violations)
    assert row["reaches_all"] is metrics.reaches_all
    assert row["inertia_isotropy"] == pk.by_name("truncated-icosahedron").inertia_isotropy()
    assert row["family_rule"] == "different" and json.loads(row["params"]) == point.params


@pytest.mark.parametrize("core, label", [("iron", "iron (coupled, FEM table)"), ("air", "air (magnets' torque map)")])
def test_holding_torque_of_sampled_states_on_the_designs_own_model(core, label):
    from spherestep import magnetics, statics

    point = DesignPoint("truncated-icosahedron", 0, "truncated-cuboctahedron", 0, 60.0, samples=200, seed=5,
                        torque_states=4, core=core)
    row = evaluate(point)
    design = build_design(point)
    assert design.coil.core == core and row["core"] == core and row["model"] == label
    states = design.states()
    idx = np.sort(np.random.default_rng(5).choice(len(states), size=4, replace=False))
    model = magnetics.design_model(design).model  # the coil as built: its nominal current, with iron the detent
    currents = np.array([magnetics.state_currents(design, i) for i in idx])
    eq = statics.equilibrium(model, states.rotations[idx], currents)
    torque = statics.holding_torque(model, eq.rotation, currents).torque[eq.converged]
    assert row["status"] == "ok" and row["holding_torque_states"] == len(torque) >= 3
    assert row["holding_torque_median_Nm"] == pytest.approx(np.median(torque), rel=1e-12)
    assert row["holding_torque_min_Nm"] == pytest.approx(torque.min(), rel=1e-12)
    assert 0.01 < row["holding_torque_min_Nm"] <= row["holding_torque_median_Nm"] < 10  # N·m, 2-in coils
    assert "holding_torque_median_Nm" not in evaluate(DesignPoint(**(point.params | {"torque_states": 0,
                                                                                     "stator_axis": (0, 0, -1)})))


@pytest.mark.parametrize("point, limits, status, words", [
    (PROTO_POINT, Limits(budget_coils=28), "over_budget", "29 coils in the stator cap, over the budget of 28"),
    (PROTO_POINT, Limits(max_rotor_poles=91), "too_large", "92 poles, over the sweep's limit of 91"),
    (PROTO_POINT, Limits(max_candidates=100_000), "too_large", "114240 candidate alignments"),
    (DesignPoint("truncated-dodecahedron", 2, "cube", 0, 80.0), Limits(), "does_not_fit", "magnet"),
    (DesignPoint("truncated-icosahedron", 0, "truncated-icosidodecahedron", 0, 80.0,
                 coil_diameter_min=0.04), Limits(), "does_not_fit", "coil"),
    (DesignPoint("icosidodecahedron", 2, "truncated-cube", 0, 60.0), Limits(max_lookup_voxels=200_000),
     "too_large", "poles 4.08° apart needs a state lookup grid of 2.69e+05 voxels"),
    (DesignPoint("truncated-cube", 2, "truncated-icosahedron", 0, 60.0, tol_deg=2.0), Limits(), "does_not_fit",
     "not under half the 3.67° pole spacing"),
    (DesignPoint("truncated-icosahedron", 0, "octahedron", 0, 60.0), Limits(), "no_states", "1 coil in"),
    (DesignPoint("dodecahedron", 0, "truncated-octahedron", 0, 60.0), Limits(), "no_states",
     "no orientation holds"),
])
def test_designs_that_cannot_be_built_are_recorded_with_the_reason(point, limits, status, words):
    row = evaluate(point, limits)
    assert row["status"] == status
    assert words in row["reason"]
    if status == "over_budget":
        assert row["coils"] == 29  # so a sweep with a larger budget knows to build it
    assert row["key"] == point.key and row["rotor_poles"] == len(pk.refine(pk.by_name(point.rotor),
                                                                               levels=point.rotor_level))
    assert row.get("resolution_median_deg") is None


# --- the store, resuming -----------------------------------------------------------------------------------

def _rows(n, status="ok", **extra):
    return [{"key": f"k{i:03d}", "rotor": "dodecahedron", "rotor_level": 0, "status": status, "coils": 10 + i,
             "rotor_poles": 20, "resolution_median_deg": float(i), "reaches_all": bool(i % 2)} | extra
            for i in range(n)]


def test_store_writes_whole_parts_and_the_latest_row_wins(tmp_path):
    store = ResultStore(tmp_path / "results")
    empty = store.read()
    assert empty.empty and list(empty.columns) == COLUMNS
    store.append(_rows(3))
    store.append([_rows(3)[1] | {"status": "failed", "reason": "again"}])
    (tmp_path / "results" / ".part-000009-deadbeef.parquet.x.tmp").write_bytes(b"half a file")
    table = store.read()
    assert [p.name[:11] for p in store.parts()] == ["part-000001", "part-000002"]
    assert sorted(table["key"]) == ["k000", "k001", "k002"]
    assert table.set_index("key").loc["k001", "status"] == "failed"
    assert str(table["coils"].dtype) == "Int64" and str(table["reaches_all"].dtype) == "boolean"
    assert table["states"].isna().all()
    (tmp_path / "results" / "part-000003-0badf00d.parquet").write_bytes(b"not parquet")
    with pytest.raises(InputError, match="part-000003-0badf00d.parquet"):
        store.read()


def test_finished_keys_rerun_only_what_the_new_limits_admit(tmp_path):
    store = ResultStore(tmp_path)
    store.append([
        {"key": "ok", "status": "ok", "coils": 29, "rotor_poles": 92},
        {"key": "budget", "status": "over_budget", "coils": 40, "rotor_poles": 92},
        {"key": "poles", "status": "too_large", "rotor_poles": 362},
        {"key": "cands", "status": "too_large", "coils": 29, "rotor_poles": 272, "candidates": 502_680},
        {"key": "fit", "status": "does_not_fit", "rotor_poles": 272},
        {"key": "voxels", "status": "too_large", "coils": 12, "rotor_poles": 182, "lookup_voxels": 13_651_919},
    ])
    table = store.read()
    everything = {"ok", "budget", "poles", "cands", "fit", "voxels"}
    assert finished_keys(table, Limits()) == everything
    assert finished_keys(table, Limits(budget_coils=39)) == everything
    assert finished_keys(table, Limits(budget_coils=40)) == everything - {"budget"}
    assert finished_keys(table, Limits(max_rotor_poles=400)) == everything - {"poles"}
    assert finished_keys(table, Limits(max_candidates=600_000)) == everything - {"cands"}
    assert finished_keys(table, Limits(max_lookup_voxels=14_000_000)) == everything - {"voxels"}


def test_an_interrupted_sweep_resumes_without_recomputing(tmp_path):
    points = SMALL.points()
    store = ResultStore(tmp_path / "results")
    seen = []

    def interrupt_after_three(row):
        seen.append(row["key"])
        if len(seen) == 3:
            raise KeyboardInterrupt

    with dask_client(threads=True, workers=1) as client:
        with pytest.raises(KeyboardInterrupt):
            run_sweep(points, store, client, batch_size=100, on_result=interrupt_after_three)
        first = store.read()
        assert sorted(first["key"]) == sorted(seen)  # the partial batch was written before the interrupt
        summary = run_sweep(points, store, client, batch_size=2)
        assert (summary.total, summary.stored_before, summary.evaluated) == (len(points), 3, len(points) - 3)
        new_keys = set(pd.concat([pd.read_parquet(p) for p in summary.parts])["key"])
        assert new_keys == {p.key for p in points} - set(seen)  # finished designs were not evaluated again
        again = run_sweep(points, store, client)
        assert (again.stored_before, again.evaluated, again.parts) == (len(points), 0, [])
        # designs over a budget are built when the budget grows, and only those
        tight = Limits(budget_coils=8)
        over = {p.key for p in points if evaluate(p, tight)["status"] == "over_budget"}
        budget_store = ResultStore(tmp_path / "budget")
        run_sweep(points, budget_store, client, tight)
        assert over and set(budget_store.read().query("status == 'over_budget'")["key"]) == over
        grown = run_sweep(points, budget_store, client, Limits(budget_coils=12))
        assert grown.evaluated == len(over) and grown.stored_before == len(points) - len(over)
        assert not (budget_store.read()["status"] == "over_budget").any()
    table = store.read().set_index("key").loc[[p.key for p in points]]
    reference = ResultStore(tmp_path / "reference")
    reference.append([evaluate(p) for p in points])  # the same designs, one by one in this process
    expected = reference.read().set_index("key").loc[[p.key for p in points]]
    assert set(table["status"]) == {"ok", "no_states"}
    pd.testing.assert_frame_equal(table[MEASURED[1:]], expected[MEASURED[1:]])


# --- the Pareto front --------------------------------------------------------------------------------------

def brute_force_front(values, maximize=()):
    v = [[-x if j in maximize else x for j, x in enumerate(row)] for row in values]
    keep = []
    for i, p in enumerate(v):
        if any(math.isnan(x) for x in p):
            keep.append(False)
            continue
        dominated = any(all(q[j] <= p[j] for j in range(len(p))) and any(q[j] < p[j] for j in range(len(p)))
                        for k, q in enumerate(v) if k != i and not any(math.isnan(x) for x in q))
        keep.append(not dominated)
    return np.array(keep)


@settings(max_examples=150, deadline=None)
@given(st.lists(st.tuples(st.integers(2, 12), st.sampled_from([0.5, 1.0, 1.5, 2.0, 3.0, float("nan")]),
                          st.integers(0, 3)), min_size=0, max_size=40),
       st.sampled_from([(), (2,), (0, 2)]))
def test_pareto_mask_matches_brute_force(rows, maximize):
    values = np.array(rows, dtype=float).reshape(-1, 3)
    assert np.array_equal(pareto_mask(values, maximize), brute_force_front(values.tolist(), maximize))
    two = values[:, :2]
    assert np.array_equal(pareto_mask(two), brute_force_front(two.tolist()))


def test_pareto_front_of_a_synthetic_table():
    rng = np.random.default_rng(4)
    n = 300
    table = pd.DataFrame({
        "key": [f"k{i}" for i in range(n)], "motor": [f"m{i}" for i in range(n)],
        "status": rng.choice(["ok", "ok", "ok", "over_budget", "no_states"], n),
        "coils": pd.array(rng.integers(2, 40, n), dtype="Int64"),
        "resolution_median_deg": np.round(rng.uniform(1, 20, n), 1),
        "reaches_all": pd.array(rng.random(n) < 0.7, dtype="boolean"),
    })
    table.loc[table["status"] != "ok", "resolution_median_deg"] = np.nan
    table.loc[5, ["status", "coils", "resolution_median_deg", "reaches_all"]] = ["ok", 3, 0.5, True]
    table.loc[6] = table.loc[5].copy()  # the same motor from another grid point: proposed once
    table.loc[6, "key"] = "k6-copy"
    table.loc[7, ["status", "coils", "resolution_median_deg", "reaches_all"]] = ["ok", 2, 0.1, False]
    front = pareto_front(table, budget_coils=30)
    pool = table[(table["status"] == "ok") & (table["coils"] <= 30) & table["reaches_all"].fillna(False)]
    pool = pool.drop_duplicates("motor")
    expected = pool[brute_force_front(pool[["resolution_median_deg", "coils"]].astype(float).values.tolist())]
    assert set(front["key"]) == set(expected["key"]) and len(front) == len(expected)
    assert "k5" in set(front["key"]) and "k6-copy" not in set(front["key"]) and "k7" not in set(front["key"])
    assert list(front["coils"]) == sorted(front["coils"])
    assert front["resolution_median_deg"].is_monotonic_decreasing
    assert (front["coils"] <= 30).all()
    loose = pareto_front(table, budget_coils=30, require_reach_all=False)
    assert "k7" in set(loose["key"])
    # with a measured holding torque it is a third objective, maximised; unmeasured designs leave the front
    table["holding_torque_median_Nm"] = np.round(rng.uniform(0.1, 1.0, n), 2)
    table.loc[rng.choice(n, 20, replace=False), "holding_torque_median_Nm"] = np.nan
    front = pareto_front(table, budget_coils=30)
    pool = table[(table["status"] == "ok") & (table["coils"] <= 30) & table["reaches_all"].fillna(False)]
    pool = pool.drop_duplicates("motor")
    columns = ["resolution_median_deg", "coils", "holding_torque_median_Nm"]
    expected = pool[brute_force_front(pool[columns].astype(float).values.tolist(), maximize=(2,))]
    assert set(front["key"]) == set(expected["key"]) and len(front) > len(pareto_front(table[OBJECTIVES_ONLY], 30))
    assert front["holding_torque_median_Nm"].notna().all()


# --- the command line --------------------------------------------------------------------------------------

@pytest.mark.slow
def test_cli_quick_sweep_writes_table_plot_and_design_files(tmp_path, capsys):
    out = tmp_path / "out"
    args = ["explore", "--quick", "--out", str(out), "--threads", "--workers", "2", "--samples", "500", "--json"]
    assert main(args) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["designs"] == 12 and info["evaluated"] == 12 and info["lost"] == 0
    results = pd.read_csv(out / "results.csv")
    assert len(results) == 12 and set(results["status"]) <= {"ok", "no_states"}
    pareto = pd.read_csv(out / "pareto.csv")
    assert len(pareto) == len(info["pareto"]) >= 2
    assert (out / "pareto.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    files = sorted((out / "designs").iterdir())
    assert [f.name for f in files] == sorted(pareto["design_file"].str.removeprefix("designs/"))
    # the proposals are the non-dominated eligible designs in resolution, coils and holding torque
    columns = ["resolution_median_deg", "coils", "holding_torque_median_Nm"]
    pool = results[(results["status"] == "ok") & (results["reaches_all"] == True)]  # noqa: E712
    pool = pool.drop_duplicates("motor")
    expected = pool[brute_force_front(pool[columns].astype(float).values.tolist(), maximize=(2,))]
    assert set(pareto["key"]) == set(expected["key"]) and pareto["holding_torque_median_Nm"].notna().all()
    for _, row in pareto.iterrows():
        design = MotorDesign.load(out / row["design_file"])
        assert len(design.stator) == row["coils"]
        assert len(design.rotor) == row["rotor_poles"]
        assert math.degrees(design.state_tol) == pytest.approx(row["tol_deg"], abs=1e-12)
        assert motor_fingerprint(design) == row["motor"]
    assert main(args) == 0
    again = json.loads(capsys.readouterr().out)
    assert (again["stored_before"], again["evaluated"]) == (12, 0)
    assert again["pareto"] == info["pareto"]
    assert main(args + ["--budget-coils", "15"]) == 0
    tight = json.loads(capsys.readouterr().out)
    assert tight["evaluated"] == 0 and all(r["coils"] <= 15 for r in tight["pareto"])
    assert len(list((out / "designs").iterdir())) == len(tight["pareto"])  # the folder holds this run's proposals


@pytest.mark.parametrize("args, option", [
    (["--budget-coils", "1"], "--budget-coils"), (["--rotors", "truncated-icosahedron,nope"], "--rotors"),
    (["--stators", ","], "--stators"), (["--caps", "95"], "--caps"), (["--tols", "x"], "--tols"),
    (["--rotor-levels", "0,-1"], "--rotor-levels"), (["--stator-levels", "1.5"], "--stator-levels"),
    (["--primary-ratio", "0.5"], "--primary-ratio"), (["--primary-ratio", "big"], "--primary-ratio"),
    (["--samples", "0"], "--samples"), (["--max-candidates", "0"], "--max-candidates"),
    (["--max-lookup-voxels", "-5"], "--max-lookup-voxels"),
    (["--workers", "0"], "--workers"), (["--scheduler", "localhost:8786"], "--scheduler"),
    (["--scheduler", "tcp://127.0.0.1:8786", "--threads"], "--scheduler"), (["--caps", "nan"], "--caps"),
    (["--workers", "two"], "--workers"),
])
def test_cli_bad_input_is_one_line_and_exit_2(tmp_path, capsys, args, option):
    out = tmp_path / "out"
    assert main(["explore", "--quick", "--out", str(out)] + args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("spherestep: error:") and option in err
    assert not (out / "results").exists()


def test_cli_unreachable_scheduler_and_out_file(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(explore_run, "CONNECT_TIMEOUT", 2.0)  # nothing listens on port 9: no need to wait 10 s
    assert main(["explore", "--quick", "--out", str(tmp_path / "o"), "--scheduler", "tcp://127.0.0.1:9"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--scheduler: could not connect to tcp://127.0.0.1:9 within 2 s" in err
    (tmp_path / "file").write_text("x")
    assert main(["explore", "--quick", "--out", str(tmp_path / "file")]) == 2
    assert "is a file" in capsys.readouterr().err


def test_cli_help_has_an_example(capsys):
    assert main(["explore", "--help"]) == 0
    text = capsys.readouterr().out
    assert "spherestep explore --budget-coils 32 --out" in text and "--scheduler" in text and "--quick" in text


@pytest.mark.parametrize("core", ["iron", "air"])
def test_torque_capability_is_measured_on_the_designs_own_model_and_maximised_on_the_front(core):
    from spherestep.control import torque_capability
    from spherestep.explore import CAPABILITY, objectives, pareto_mask
    from spherestep.magnetics import design_model

    point = DesignPoint("truncated-icosahedron", 0, "truncated-cuboctahedron", 0, 60.0, samples=200, seed=5,
                        torque_states=2, core=core)
    row = evaluate(point)
    design = build_design(point)
    own = design_model(design)
    assert row["model"] == own.label and own.core == core
    direct = torque_capability(design, own.model, own.limits, samples=100, seed=5).radius
    assert row["capability_median_Nm"] == pytest.approx(np.median(direct), rel=1e-12)
    assert row["capability_p5_Nm"] == pytest.approx(np.percentile(direct, 5), rel=1e-12)
    assert row["capability_p5_Nm"] <= row["capability_median_Nm"]
    if core == "air":
        assert 0 < row["capability_p5_Nm"]
    else:  # the cores' detent exceeds what the coils can cancel at the weakest orientations
        assert row["capability_p5_Nm"] < 0 < row["capability_median_Nm"]
    table = pd.DataFrame({"resolution_median_deg": [3.0, 3.0], "coils": [20, 20], CAPABILITY: [1.0, 2.0]})
    assert objectives(table)[-1] == CAPABILITY
    # equal resolution and coils: the larger capability dominates when maximised
    assert list(pareto_mask(table[objectives(table)].to_numpy(), maximize=[2])) == [False, True]


@pytest.mark.parametrize("point, words", [
    (DesignPoint("truncated-icosahedron", 0, "truncated-dodecahedron", 0, 60.0, samples=100, torque_states=2),
     "coil 46.9 mm"),  # the stator's primary caps shrink the coil
    (DesignPoint("truncated-tetrahedron", 2, "truncated-octahedron", 0, 60.0, samples=100, torque_states=2),
     "magnet 14.3 mm"),  # the refined rotor's poles shrink the magnet
])
def test_iron_parts_without_stored_tables_are_flagged_not_measured_on_air(point, words):
    """Iron with other parts than the prototype's would need a moment-method solve (minutes): the row keeps its
    kinematic metrics, leaves the torques and the model empty and says why; on air cores it is measured."""
    from spherestep.explore import iron_is_stored, unmeasured_iron

    design = build_design(point)
    assert design.coil.core == "iron" and not iron_is_stored(design)
    assert iron_is_stored(build_design(PROTO_POINT)) and unmeasured_iron(build_design(PROTO_POINT)) is None
    row = evaluate(point)
    assert row["status"] == "ok" and row["states"] > 0
    assert row["reason"].startswith("torques not measured: the iron model of these parts") and words in row["reason"]
    assert "--core air" in row["reason"]
    for column in ("model", "holding_torque_median_Nm", "capability_p5_Nm"):
        assert row.get(column) is None
    air = evaluate(DesignPoint(**(point.params | {"core": "air", "stator_axis": point.stator_axis})))
    assert air["model"] == "air (magnets' torque map)" and air["capability_median_Nm"] > 0 and air["reason"] == ""
    assert air["key"] != row["key"]


def test_core_is_checked_and_set_from_the_command_line(tmp_path):
    with pytest.raises(InputError, match="core"):
        DesignPoint("dodecahedron", 0, "cube", 0, 60.0, core="copper")
    with pytest.raises(InputError, match="core"):
        Grid(core="copper")
    grid = Grid(rotors=("dodecahedron",), stators=("cube",), primary_ratio_max=None, core="air")
    assert {p.core for p in grid.points()} == {"air"}
    from spherestep.cli.explore import build_grid

    assert build_grid(True, *[None] * 7, True, None, None, "air").core == "air"
    assert build_grid(True, *[None] * 7, True, None, None).core == "iron"  # the prototype's pot-core coils
    assert main(["explore", "--quick", "--core", "copper", "--out", str(tmp_path / "x")]) == 2
