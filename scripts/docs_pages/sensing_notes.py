"""docs/sensing.md's hand-measured notes (``data/docs_sensing_notes.json``: :func:`measure_sensing_notes`)."""

from __future__ import annotations

import math
import statistics
import sys
import time
from collections.abc import Callable
from .common import ROOT, _cpu, _deg, _notes_when, _run_footer, _run_header, _signed, _step, _thin, table


SENSING_GLOBAL_TRIALS = 10  # per row of the global start (the 2026-11-23 one-off ran 50)


def measure_sensing_notes() -> dict:
    """docs/sensing.md's numbers of today's code outside ``bench_sensing.py --docs``: the field table against
    magpylib, the placement, accuracy against sensor count, the global start (shortened), the model errors, the
    self-calibration, the 2-s tracking run with the IMU and the fusion, the servo's 20° turn with each sensor, and on
    the iron prototype the cores' cost, the estimator's error with and without them and ``accuracy``; the same
    seeds and cases as ``benchmarks/bench_sensing.py`` and ``bench_sensing_iron.py``. ~3–5 min of one core."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    from bench_sensing import global_start_rows, loop_rows, one_step_case  # the benchmark's own trials, stored here
    from dataclasses import replace

    import numpy as np
    from scipy.spatial.transform import Rotation

    from spherestep import sensing, so3
    from spherestep.sensing import iron as sensing_iron
    from spherestep.control import Trajectory, plan_turn
    from spherestep.drive import choose_model
    from spherestep.drive.turn import Turn
    from spherestep.dynamics import Rotor, simulate_servo
    from spherestep.magnetics import rotor_collection, torque_map
    from spherestep.motor import prototype

    run = _run_header("sensing-notes")
    design = prototype()
    t = time.perf_counter()
    placement = sensing.greedy_placement(design, 24)
    run["placement"] = {"seconds": time.perf_counter() - t, "candidates": len(placement.candidates)}
    array = placement.array(24)
    R = so3.random(200, 1)
    exact = np.asarray(rotor_collection(design, R).getB(array.positions))
    shell = sensing.fibonacci_directions(20_000)  # the rotor at rest: every orientation's field is on this shell
    run["field_max_mT"] = {f"{1e3 * s:g}": float(1e3 * np.linalg.norm(
        rotor_collection(design).getB(shell * (design.radius + s)), axis=-1).max()) for s in (0.010, 0.008, 0.005, 0.003)}
    run["field_max_mT"]["array"] = float(1e3 * np.linalg.norm(exact, axis=-1).max())
    run["table"] = []
    for n in (4097, 16385, 65537):
        t = time.perf_counter()
        table = sensing.FieldTable.build(design, array.positions, nodes=n)
        build = time.perf_counter() - t
        d = table.field(R) - exact
        run["table"].append({"nodes": n, "max_T": float(np.abs(d).max()), "rms_T": float(np.sqrt(np.mean(d ** 2))),
                             "build_s": build})
    table = sensing.FieldTable.build(design, array.positions)
    # symmetry (bench_sensing.symmetry): magpylib over the 60 copies; the marked rotor's nearest wrong copy
    G = sensing.symmetry_group(design)
    spread = max(float(np.abs(B - B[0]).max()) for B in
                 (sensing.rotor_field(design, array.positions, Rk @ G) for Rk in so3.random(5, 4)))
    marked_table = sensing.FieldTable.build(sensing.marked_design(design), array.positions)
    Gp = sensing.symmetry_group(sensing.marked_design(design), polarity=False)
    d = np.array([np.sqrt(np.sum((marked_table.field(Rk @ Gp[1:]) - marked_table.field(Rk)) ** 2, axis=(1, 2))).min()
                  for Rk in so3.random(300, 5)]) / array.part.effective_noise_T
    run["symmetry"] = {"order": len(G), "smallest_turn_deg": float(np.degrees(so3.angle(G[1:])).min()),
                       "copies_spread_T": spread, "marked_order": len(sensing.symmetry_group(sensing.marked_design(design))),
                       "margin_min": float(d.min()), "margin_p5": float(np.percentile(d, 5)),
                       "margin_median": float(np.median(d))}
    run["marker"] = sensing.marker_effect(design, sensing.marked_design(design), states=2, samples=300).to_dict()
    _, _, est, Ri, c, m, prev = one_step_case(design, array)
    run["one_step_deg"] = math.degrees(so3.distance(est.track(m, prev, c).R, Ri))
    run["solved_deg"] = math.degrees(so3.distance(est.solve(m, prev, c).R, Ri))
    _step(run, "placement, table, one step")
    # accuracy against sensor count (bench_sensing.accuracy_vs_count: seed k, 300 orientations) on the air-core
    # prototype (same winding): on iron every array but the stored one needs its cores' and coils' tables (minutes)
    air = replace(design, coil=replace(design.coil, core="air"))
    cand = placement.candidates
    run["accuracy"] = []
    bounds = placement.bound_deg()
    for k in (3, 4, 6, 8, 12, 16, 24):
        spread = sensing.SensorArray.at(cand[np.linspace(0, len(cand) - 1, k).astype(int)])
        for name, arr in (("greedy", placement.array(k)), ("spread", spread)):
            a = sensing.accuracy(air, arr, samples=300, seed=k)
            run["accuracy"].append({"sensors": k, "layout": name, "rms_deg": math.degrees(a.rms),
                                    "worst_deg": math.degrees(a.worst), "predicted_deg": math.degrees(a.predicted_rms),
                                    "bound_deg": float(bounds[k - 1]) if name == "greedy" else None,
                                    "coil_residual_uT": a.coil_residual_T * 1e6})
    _step(run, "accuracy against sensor count")
    # global start (bench_sensing's, shortened)
    run["global"] = {"trials": SENSING_GLOBAL_TRIALS, "rows": global_start_rows(design, array, SENSING_GLOBAL_TRIALS)}
    _step(run, "global start")
    # model errors (bench_sensing.model_error, 100 orientations)
    rng = np.random.default_rng(7)
    Rm = so3.random(100, rng)
    e1 = sensing.Estimator(table, array.axes, array.part)

    def errors(B, axes=array.axes):
        mm = np.einsum("sji,ksj->ksi", axes, B)
        return np.degrees([so3.distance(e1.solve(mm[k], Rm[k]).R, Rm[k]) for k in range(len(Rm))])

    cases = []
    moved = array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape)
    cases.append(("sensor positions off by 0.2 mm RMS per axis", errors(sensing.rotor_field(design, moved, Rm))))
    rotor = rotor_collection(design)
    for child in rotor.children:
        child.polarization = np.asarray(child.polarization) * (1.0 + rng.normal(0.0, 0.01))
    rotor.orientation = Rotation.from_matrix(Rm)
    cases.append(("magnet remanence spread 1 % RMS", errors(np.asarray(rotor.getB(array.positions)))))
    gain = 1.0 + rng.normal(0.0, 0.01, (len(array), 3))
    mm = np.einsum("sji,ksj->ksi", array.axes, sensing.rotor_field(design, array.positions, Rm)) * gain
    cases.append(("sensor gains off by 1 % RMS per axis",
                  np.degrees([so3.distance(e1.solve(mm[k], Rm[k]).R, Rm[k]) for k in range(len(Rm))])))
    run["model_error"] = [{"source": n, "rms_deg": float(np.sqrt(np.mean(e ** 2))), "worst_deg": float(e.max())}
                          for n, e in cases]
    _step(run, "model errors")
    # self-calibration (bench_sensing.calibration: 200 poses, 5 rounds, 100 tests)
    rng = np.random.default_rng(1)
    true_pos = array.positions + rng.normal(0.0, 0.2e-3, array.positions.shape)
    gain, offset = 1.0 + rng.normal(0.0, 0.01, (len(array), 3)), rng.normal(0.0, 50e-6, (len(array), 3))
    Rc = so3.random(200, rng)
    mc = sensing.sense(array, sensing.rotor_field(design, true_pos, Rc), rng) * gain + offset
    start = np.stack([e1.solve(mc[k], Rc[k]).R for k in range(len(Rc))])
    t = time.perf_counter()
    cal = sensing.calibrate(design, array, mc, start, rounds=5, cores=False)
    took = time.perf_counter() - t
    e2 = sensing.Estimator(sensing.FieldTable.build(design, cal.array.positions), array.axes, array.part)
    Rt = so3.random(100, rng)
    mt = sensing.sense(array, sensing.rotor_field(design, true_pos, Rt), rng) * gain + offset
    E0 = np.stack([so3.log(e1.solve(mt[k], Rt[k]).R @ Rt[k].T) for k in range(len(Rt))])
    E1 = np.stack([so3.log(e2.solve(cal.correct(mt[k]), Rt[k]).R @ Rt[k].T) for k in range(len(Rt))])
    rms = lambda E: math.degrees(float(np.sqrt(np.mean(np.sum(E ** 2, axis=1)))))  # noqa: E731
    run["calibration"] = {"seconds": took, "residual_before_uT": float(cal.residual_T[0] * 1e6),
                          "residual_after_uT": float(cal.residual_T[-1] * 1e6),
                          "position_before_mm": float(1e3 * np.sqrt(np.mean((array.positions - true_pos) ** 2))),
                          "position_after_mm": float(1e3 * np.sqrt(np.mean((cal.array.positions - true_pos) ** 2))),
                          "orientation_before_deg": rms(E0), "orientation_after_deg": rms(E1),
                          "common_deg": math.degrees(float(np.linalg.norm(E1.mean(0)))),
                          "scatter_deg": rms(E1 - E1.mean(0))}
    _step(run, "self-calibration")
    # the 2-s run at 1 kHz (bench_sensing's)
    run["loop"] = loop_rows(design, array)
    _step(run, "2-s tracking run")
    # the servo's 20° turn with each sensor (bench_sensing.servo)
    tmap = torque_map(design)
    R0 = so3.random(1, 4)[0]
    traj = Trajectory.turn(R0, [1.0, 0.5, 2.0], math.radians(20), acceleration=10.0)
    sensors = {"ideal": sensing.IdealSensor(),
               "hall": sensing.HallSensor(design, array=array, current_error=0.01, seed=1, start=R0),
               "fused": sensing.FusedSensor(design, sensing.HallSensor(design, array=array, current_error=0.01,
                                                                       seed=2), 1e-3, seed=3, start=R0),
               "imu": sensing.ImuSensor(design, 1e-3, seed=4)}
    run["servo"] = {}
    for name, s in sensors.items():
        r = simulate_servo(design, traj, tmap, sensor=s, settle=0.15)
        est_e = so3.distance(r.estimates, r.orientations)
        run["servo"][name] = {"max_tracking_deg": math.degrees(float(r.tracking_error.max())),
                              "final_deg": math.degrees(r.final_error),
                              "estimate_rms_deg": math.degrees(float(np.sqrt(np.mean(est_e ** 2))))}
    _step(run, "servo turns")
    # iron: the stored cores' table read, its cost, the estimator's error (bench_sensing_iron.timing, static_error,
    # in_the_loop) and accuracy() with and without the cores
    iron_array = sensing.default_array(design)
    on = sensing.HallSensor(design, iron_array, seed=2)
    off = sensing.HallSensor(design, iron_array, seed=2, cores=False)
    rng = np.random.default_rng(2)
    Ri = so3.random(1, rng)[0]
    mi = on.readings(Ri, c)
    prev = so3.exp(np.radians(0.06) * np.array([0.6, 0.0, 0.8])) @ Ri
    core = on.core_field
    run["iron_cost_us"] = {k: 1e6 * _cpu(f) for k, f in (
        ("rotor", lambda: on.rotor_table.field_and_jacobian(Ri)), ("cores field", lambda: core.field(Ri)),
        ("cores jacobian", lambda: core.field_and_jacobian(Ri)), ("update without", lambda: off.estimator.track(mi, prev, c)),
        ("update with", lambda: on.estimator.track(mi, prev, c)))}
    run["iron_static"] = {}
    for label, cores in (("with", True), ("without", False)):
        s = sensing.HallSensor(design, iron_array, current_error=0.01, seed=4, cores=cores)
        errs = [so3.distance(s.estimator.solve(s.readings(Rk, c), so3.exp(np.radians(0.06) * np.array([0.6, 0.0, 0.8]))
                                               @ Rk, c).R, Rk) for Rk in so3.random(200, 7)]
        e = np.degrees(errs)
        run["iron_static"][label] = {"rms_deg": float(np.sqrt(np.mean(e ** 2))), "worst_deg": float(e.max())}
    chosen = choose_model(design)
    ax, angle = np.array([1.0, 0.0, 0.0]), math.radians(90.0)
    job = Turn(design, ax, angle, chosen)
    rotor = Rotor.from_design(design)
    plan = plan_turn(chosen.model, job.start, ax, angle, rotor.inertia, chosen.limits, damping=rotor.damping)
    run["iron_loop"] = {"model": chosen.label}
    for name, traj in (("turn", plan), ("hold", Trajectory.hold(job.start))):
        for label, cores in (("with", True), ("without", False)):
            s = sensing.HallSensor(design, current_error=0.01, seed=0, rate=1000.0, start=traj.start, cores=cores)
            t = time.perf_counter()
            r = simulate_servo(design, traj, chosen.model, limits=chosen.limits, rotor=rotor, sensor=s, settle=0.5)
            wall = time.perf_counter() - t
            e = np.degrees(so3.distance(r.estimates, r.orientations))
            run["iron_loop"][f"{name} {label}"] = {
                "rms_deg": float(np.sqrt(np.mean(e ** 2))), "worst_deg": float(e.max()),
                "tracking_deg": math.degrees(float(r.tracking_error.max())),
                "final_deg": float(np.degrees(so3.distance(r.orientations[-1], traj.end))),
                "final_sensor_deg": float(e[-1]), "wall_per_simulated": wall / float(r.times[-1])}
    _step(run, "iron cost, static error, loop")
    # self-calibration on iron (tests/test_sensing_model.py's case with 80 poses): with and without the cores
    arr8 = sensing.default_array(design, 8)
    rng = np.random.default_rng(21)
    true_pos = arr8.positions + rng.normal(0.0, 0.2e-3, arr8.positions.shape)
    gain, offset = 1.0 + rng.normal(0.0, 0.01, (len(arr8), 3)), rng.normal(0.0, 50e-6, (len(arr8), 3))
    Rc = so3.random(80, rng)
    cores8 = sensing_iron.iron_fields(design, arr8.positions)[0]
    mc = sensing.sense(arr8, sensing.rotor_field(design, true_pos, Rc) + cores8.field(Rc), rng) * gain + offset
    start = so3.exp(np.radians(0.5) * rng.normal(size=(len(Rc), 3)) / math.sqrt(3)) @ Rc
    run["iron_calibration"] = {"sensors": 8, "poses": 80, "rounds": 5,
                               "position_before_mm": float(1e3 * np.sqrt(np.mean((arr8.positions - true_pos) ** 2)))}
    for label, cores in (("with", None), ("without", False)):
        cal = sensing.calibrate(design, arr8, mc, start, rounds=5, cores=cores)
        run["iron_calibration"][label] = {
            "residual_mT": float(cal.residual_T[-1] * 1e3), "field_model": cal.field_model,
            "position_after_mm": float(1e3 * np.sqrt(np.mean((cal.array.positions - true_pos) ** 2)))}
    _step(run, "iron self-calibration")
    run["iron_accuracy"] = {}
    for label, cores in (("with", None), ("without", False)):
        a = sensing.accuracy(design, iron_array, samples=200, cores=cores)
        run["iron_accuracy"][label] = {"rms_deg": math.degrees(a.rms), "worst_deg": math.degrees(a.worst),
                                       "field_model": a.field_model}
    return _run_footer(run)


def _sn_when(n: dict) -> str:
    return f"{_notes_when(n)}; {n['machine']}"


def sensing_notes_run(n: dict) -> str:
    return f"{n['measured']} (load {n['load'][0]:.1f} → {n['load'][1]:.1f}, {n['machine']}; {n['wall_s']:.0f} s)"


def sensing_notes_table(n: dict) -> str:
    rows = []
    for r in n["table"]:
        b = "**" if r["nodes"] == 16385 else ""
        name = f"{_thin(r['nodes'])} (default)" if r["nodes"] == 16385 else _thin(r["nodes"])
        rows.append((f"{b}{name}{b}", f"{b}{r['max_T'] * 1e6:.2g} µT{b}", f"{b}{r['rms_T'] * 1e6:.2g} µT{b}",
                     f"{r['build_s']:.2f} s"))
    return table(("nodes", "max abs error", "RMS error", "build"), rows)


def sensing_notes_onestep(n: dict) -> str:
    return (f"one-step error {n['one_step_deg']:.4f}° against {n['solved_deg']:.4f}° after full convergence, from a "
            f"0.06° start (1 rad/s for 1 ms)")


def sensing_notes_loop_cost(n: dict) -> str:
    return f"{n['loop']['hall']['us_per_sample'] / 1e3:.1f} ms per sample"


def sensing_notes_global(n: dict) -> str:
    g = n["global"]
    rows = [(r["rotor"], r["averaged"], f"{r['success']}/{g['trials']}", f"{r['median_s']:.2f} s",
             ", ".join(f"{x:g}°" for x in r["failures_deg"]) or "—") for r in g["rows"]]
    return table(("rotor", "readings averaged", "success (error < 0.05°)", "median time", "failures"), rows,
                 f"{g['trials']} Haar-random orientations per row (shortened from the 50 of the first run), 24 sensors, "
                 f"grid 2000; {_sn_when(n)}:")


def sensing_notes_global_short(n: dict) -> str:
    g = n["global"]
    rows = {(r["rotor"], r["averaged"]): r for r in g["rows"]}
    p, m = rows[("prototype, up to its 60 symmetries", 1)], rows[("marked, exact", 32)]
    return (f"{p['success']}/{g['trials']} (prototype, up to its symmetry), {m['success']}/{g['trials']} (marked rotor "
            f"with 32 averaged readings), ≈ {statistics.median(r['median_s'] for r in g['rows']):.1f} s ({n['measured']})")


def sensing_notes_placement(n: dict) -> str:
    p = n["placement"]
    return f"24 sensors from {p['candidates']} candidates in {p['seconds']:.1f} s ({_notes_when(n)})"


def sensing_notes_accuracy(n: dict) -> str:
    rows = []
    for r in n["accuracy"]:
        b = "**" if r["sensors"] == 24 and r["layout"] == "greedy" else ""
        rows.append((f"{b}{r['sensors']}{b}", f"{b}{r['layout']}{b}", f"{b}{r['rms_deg']:.4f}{b}",
                     f"{b}{r['worst_deg']:.4f}{b}", f"{b}{r['predicted_deg']:.4f}{b}",
                     None if r["bound_deg"] is None else f"{b}{r['bound_deg']:.4f}{b}", f"{r['coil_residual_uT']:.1f}"))
    return table(("sensors", "layout", "RMS (°)", "worst (°)", "Cramér–Rao RMS (°)", "worst-case bound (°)",
                  "coil residual RMS (µT)"), rows, f"Measured {n['measured']}, load {n['load'][0]:.1f} → "
                 f"{n['load'][1]:.1f} (`scripts/docs_numbers.py sensing-notes`):")


def _acc(n: dict, k: int, layout: str = "greedy") -> dict:
    return next(r for r in n["accuracy"] if r["sensors"] == k and r["layout"] == layout)


def sensing_notes_few(n: dict) -> str:
    """docs/sensing.md, inline: what the greedy layout buys with few sensors."""
    a3, s3, a12, s12 = _acc(n, 3), _acc(n, 3, "spread"), _acc(n, 12), _acc(n, 12, "spread")
    return (f"3 sensors: worst {a3['worst_deg']:.3f}° against {s3['worst_deg']:.3f}°; 12: {a12['worst_deg']:.3f}° against "
            f"{s12['worst_deg']:.3f}°")


def sensing_notes_model_error(n: dict) -> str:
    return table(("error source", "RMS (°)", "worst (°)"),
                 [(r["source"], f"{r['rms_deg']:.3f}", f"{r['worst_deg']:.3f}") for r in n["model_error"]])


def sensing_notes_calibration(n: dict) -> str:
    c = n["calibration"]
    return table(("", "nominal model", "calibrated"), [
        ("residual per channel (µT)", f"{c['residual_before_uT']:.0f}", f"{c['residual_after_uT']:.0f} (the noise: 100 µT)"),
        ("sensor position error RMS per axis (mm)", f"{c['position_before_mm']:.3f}", f"{c['position_after_mm']:.3f}"),
        ("orientation error RMS (°)", f"{c['orientation_before_deg']:.4f}", f"{c['orientation_after_deg']:.4f} = a common "
         f"turn of {c['common_deg']:.4f} + scatter {c['scatter_deg']:.4f}")], f"5 rounds in {c['seconds']:.0f} s; {_sn_when(n)}:")


def sensing_notes_common(n: dict) -> str:
    c = n["calibration"]
    return f"{c['common_deg']:.3f}° here"


def sensing_notes_scatter(n: dict) -> str:
    return f"{n['calibration']['scatter_deg']:.4f}°"


def sensing_notes_imu(n: dict) -> str:
    lo = n["loop"]
    names = (("hall", "magnetometer array, 1 Gauss–Newton step per sample"), ("imu", "IMU alone (MEKF: gyro, gravity, field)"),
             ("fused", "**fused: gyro + array (MEKF)**"))
    return table(("sensor", "RMS (°)", "worst (°)", "time per sample (µs, incl. simulation)"),
                 [(label, _deg(lo[k]["rms_deg"]), _deg(lo[k]["worst_deg"]), f"{lo[k]['us_per_sample']:.0f}")
                  for k, label in names], f"{_sn_when(n)}:")


def sensing_notes_servo(n: dict) -> str:
    names = (("ideal", "ideal"), ("hall", "**array (24 × TMAG5273A2, 1 % current error)**"),
             ("fused", "fused (gyro + array)"), ("imu", "IMU alone"))
    s = n["servo"]
    return table(("sensor", "max tracking error (°)", "final error (°)", "estimate error RMS (°)"),
                 [(label, _deg(s[k]["max_tracking_deg"]), _deg(s[k]["final_deg"]), _deg(s[k]["estimate_rms_deg"]))
                  for k, label in names], f"{_sn_when(n)}:")


def sensing_notes_iron_cost(n: dict) -> str:
    c, s, lo = n["iron_cost_us"], n["iron_static"], n["iron_loop"]
    rate = lambda us: _thin(int(round(1e6 / us, -2)))  # noqa: E731
    w, wo = lo["turn with"], lo["turn without"]
    hw, hwo = lo["hold with"], lo["hold without"]
    costs = table(("call", "median", "rate"), [
        ("rotor table: field + Jacobian", f"{c['rotor']:.0f} µs", f"{rate(c['rotor'])} /s"),
        ("cores: field / field + Jacobian (compiled B-spline, 92 poles × 24 sensors)",
         f"{c['cores field']:.0f} / {c['cores jacobian']:.0f} µs", f"{rate(c['cores field'])} / {rate(c['cores jacobian'])} /s"),
        ("update without the cores (`track`, one Gauss–Newton step)", f"{c['update without']:.0f} µs",
         f"{rate(c['update without'])} /s"),
        ("**update with the cores**", f"**{c['update with']:.0f} µs**", f"**{rate(c['update with'])} /s**")],
        f"CPU medians of 200 calls; {_sn_when(n)}:")
    errors = table(("estimation error, iron prototype (24 × TMAG5273A2, 0.1 mT noise, 4 coils at ±1, 1 % current error)",
                    "cores modelled (default)", "cores ignored (`cores=False`)"), [
        ("200 Haar orientations, LM from 0.06° off: RMS / worst",
         f"**{s['with']['rms_deg']:.4f}° / {s['with']['worst_deg']:.4f}°**",
         f"{s['without']['rms_deg']:.2f}° / {s['without']['worst_deg']:.2f}°"),
        ("in the loop, 90° turn about x (the drive's fastest turn on the iron model, 1 kHz, 0.5 s settle): sensor RMS "
         "/ worst", f"**{w['rms_deg']:.4f}° / {w['worst_deg']:.4f}°**", f"{wo['rms_deg']:.2f}° / {wo['worst_deg']:.2f}°"),
        ("same turn: tracking max / final", f"{w['tracking_deg']:.3f}° / {w['final_deg']:.4f}°",
         f"{wo['tracking_deg']:.2f}° / {wo['final_deg']:.2f}°"),
        ("in the loop, hold at the turn's start (0.5 s): sensor RMS / final",
         f"**{hw['rms_deg']:.4f}°** / {hw['final_sensor_deg']:.4f}°", f"{hwo['rms_deg']:.2f}° / {hwo['final_sensor_deg']:.2f}°"),
        ("wall time per simulated second (turn, hold)", f"{w['wall_per_simulated']:.1f}, {hw['wall_per_simulated']:.1f}",
         f"{wo['wall_per_simulated']:.1f}, {hwo['wall_per_simulated']:.1f}")])
    return costs + "\n\n" + errors


def sensing_notes_iron_accuracy(n: dict) -> str:
    a = n["iron_accuracy"]
    return (f"**{a['with']['rms_deg']:.4f}° RMS, {a['with']['worst_deg']:.4f}° worst** with the cores modelled "
            f"(`field_model` `\"{a['with']['field_model']}\"`), {a['without']['rms_deg']:.2f}° / "
            f"{a['without']['worst_deg']:.2f}° ignoring them ({n['measured']})")


def sensing_notes_iron_calibration(n: dict) -> str:
    c = n["iron_calibration"]
    w, wo = c["with"], c["without"]
    return (f"{c['sensors']} sensors, {c['poses']} poses, {c['rounds']} rounds, the errors of "
            f"`tests/test_sensing_model.py`; {n['measured']}: with the cores (`\"{w['field_model']}\"`) the residual "
            f"falls to {w['residual_mT']:.3f} mT (noise 0.100) and the positions come back from "
            f"{c['position_before_mm']:.3f} to {w['position_after_mm']:.3f} mm RMS; ignoring the cores (`cores=False`) the "
            f"residual stays at {wo['residual_mT']:.1f} mT and the positions wander to {wo['position_after_mm']:.1f} mm")


def sensing_notes_iron_bias(n: dict) -> str:
    w = n["iron_static"]["without"]
    return f"**{w['rms_deg']:.2f}° RMS ({w['worst_deg']:.1f}° worst)**"


def sensing_notes_iron_margin(n: dict) -> str:
    return f"{0.05 / n['iron_loop']['turn with']['rms_deg']:.0f}× margin"


def sensing_notes_field(n: dict) -> str:
    """docs/sensing.md, inline: the largest rotor field on the sensor shell at each standoff, and at the array."""
    f = n["field_max_mT"]
    return (f"**{f['10']:.0f} mT** (|B| at 20 000 directions with the rotor at rest, which covers every orientation; "
            f"{f['8']:.0f} mT at 8 mm, {f['5']:.0f} mT at 5 mm, {f['3']:.0f} mT at 3 mm; {f['array']:.0f} mT at the chosen 24 "
            f"sensors over 200 orientations)")


def sensing_notes_symmetry(n: dict) -> str:
    y = n["symmetry"]
    return f"**{y['copies_spread_T']:.1e} T**"


def sensing_notes_marker(n: dict) -> str:
    y = n["symmetry"]
    return f"{y['margin_min']:.1f} (min), {y['margin_p5']:.1f} (5th percentile), {y['margin_median']:.1f} (median)"


def sensing_notes_marker_cost(n: dict) -> str:
    """docs/sensing.md: ``marker_effect`` on the torque map (2 random states each, 300 random drives)."""
    m = n["marker"]
    pair = lambda xs: ", ".join(f"{x:.3f}" for x in xs)  # noqa: E731
    change = [100 * (a / b - 1) for a, b in zip(m["holding_marker_after_Nm"], m["holding_marker_before_Nm"])]
    other = max(abs(a - b) for a, b in zip(m["holding_other_after_Nm"], m["holding_other_before_Nm"]))
    return table(("", "before", "after"), [
        ("share of stepper states that hold the marked pole", "—", f"{100 * m['states_holding_marker']:.1f} %"),
        ("holding torque, states holding the marked pole (N·m)", pair(m["holding_marker_before_Nm"]),
         f"{pair(m['holding_marker_after_Nm'])} ({_signed(min(change), 0)} to {_signed(max(change), 0)} %)"),
        ("holding torque, other states (N·m)", pair(m["holding_other_before_Nm"]),
         f"{pair(m['holding_other_after_Nm'])} (changed by at most {other:.1g} N·m)"),
        ("net dipole of the rotor (A·m²)", f"{m['dipole_before_Am2']:.0e}", f"{m['dipole_after_Am2']:.1f} (an Earth-field "
         f"torque of at most {m['dipole_after_Am2'] * 65e-6:.0e} N·m in 65 µT)"),
        ("RMS torque change, 300 random orientations × random drives (±1 on 40 % of coils)", "",
         f"{100 * m['torque_change_rms']:.0f} % of the RMS torque")], f"{_sn_when(n)}:")


def sensing_notes_pub(key: str) -> Callable[[dict], str]:
    """docs/sensing.md: one cell of the table beside the published numbers."""
    def render(n: dict) -> str:
        if key == "3":
            a = _acc(n, 3)
            return f"{a['rms_deg']:.3f}° RMS, {a['worst_deg']:.3f}° worst"
        if key == "positions":
            return f"{n['model_error'][0]['rms_deg']:.3f}° RMS"
        if key == "calibrated":
            c = n["calibration"]
            return f"{c['orientation_after_deg']:.3f}° RMS ({c['scatter_deg']:.3f}° after one reference pose)"
        if key == "fused":
            return f"{n['loop']['fused']['rms_deg']:.4f}° RMS"
        return f"{n['loop']['imu']['rms_deg']:.1f}° RMS"
    return render
