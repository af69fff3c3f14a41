"""The stored benchmarks' tables (``data/bench_*.json``; :data:`BENCHES`, the commands that store them)."""

from __future__ import annotations

from .common import DATA, STORES, _thin, _times, _when, table


# each benchmark's command (in benchmarks/) and its store, data/bench_NAME.json: ``docs_numbers.py bench [NAME...]``
BENCHES = {
    "servo_loop": ("bench_servo_loop.py",),
    "hardware": ("bench_hardware.py",),
    "iron": ("bench_iron.py",),
    "packing": ("bench_packing.py",),
    "motor": ("bench_motor.py", "--levels", "1", "2", "3"),
    "harmonics": ("bench_harmonics.py",),
    "potential": ("bench_potential.py",),
    "dynamics": ("bench_dynamics.py",),
    "planners": ("bench_planners.py",),
    "control": ("bench_control.py", "--quick"),
    "sensing": ("bench_sensing.py", "--docs"),
}
STORES.update({f"bench-{name}": DATA / f"bench_{name}.json" for name in BENCHES})


def _us(x: float) -> str:
    return f"{x:.0f}" if x >= 10 else f"{x:.1f}"


def _range(values, fmt: str = "{:.2f}", sep: str = "–") -> str:
    lo, hi = min(values), max(values)
    a, b = fmt.format(lo), fmt.format(hi)
    return a if a == b else f"{a}{sep}{b}"


LAW_ROWS = (("estimate (observer predict + correct)", "estimate"),
            ("feedback (trajectory + geometric PD)", "feedback"),
            ("`K(R)` and bias, one evaluation (`ModelCache`, compiled: `spherestep._fast.linear`)", "K(R) and bias"),
            ("allocation, warm-started (compiled Newton: `spherestep._fast.allocation`)", "allocation"),
            ("the supply box + allocation (the law's)", "supply box + allocation"),
            ("out of reach: closest reachable torque (compiled bisection \\| Clarabel)", "closest reachable"),
            ("`ServoLaw.step` on a 20° turn", "law.step (turn)"),
            ("`ServoLaw.step`, `K(R)` every period (the fast turn's worst case)", "law.step, K each"))


def loop_cost_table(b: dict) -> str:
    """docs/hardware.md: the law's cost per period by part, now | before (``bench_servo_loop.py``)."""
    v = b["values"]
    air, iron = v["law air"], v["law iron"]
    rows = []
    for label, key in LAW_ROWS:
        if key == "law.step (turn)":
            label += (f" (`K(R)` re-evaluated in {air['K evaluations'][0]} / {iron['K evaluations'][0]} of "
                      f"{air['K evaluations'][1]} periods)")
        rows.append((label, f"{_us(air[key][0])} \\| {_us(air[key][1])}", f"{_us(iron[key][0])} \\| {_us(iron[key][1])}"))
    mag = _us(v["magnetometer update"])
    rows.append(("+ magnetometer update (the Hall tracker, 8 magnetometers)", mag, mag))
    return table(("part of one period", "air-core map, µs", "iron model (pairwise), µs"), rows,
                 f"Measured {_when(b)} (`benchmarks/bench_servo_loop.py`; {b['machine']}); CPU µs, now \\| before issue "
                 "27 (the reference paths in the same run):")


def _simulate(b: dict) -> list[dict]:
    return [r for k, r in b["values"].items() if k.startswith("simulate ")]


def loop_simulate(b: dict) -> str:
    """docs/hardware.md: ``simulate_servo``'s cost per 1 kHz period and the emulated motor's tick."""
    sims = _simulate(b)
    now, before = [r["now"] / 1e3 for r in sims], [r["before"] / 1e3 for r in sims]
    emu = [r for k, r in b["values"].items() if k.startswith("emulator ")]
    return (f"`simulate_servo` at 1 kHz: {_range(now)} ms per period, "
            f"{_range([1 / t for t in now], '{:.1f}')}× real time (before: {_range(before)} ms); the emulated motor's "
            f"tick: {_range([r['device step'] for r in emu], '{:.0f}')} µs a device step with the coils and rotor, "
            f"{_range([r['magnetometer read'] for r in emu], '{:.0f}')} µs a magnetometer read ({_when(b)})")


def hardware_cycle(b: dict) -> str:
    """docs/hardware.md: the host's whole cycle against the emulated motor over the pty (``bench_hardware.py``)."""
    rows = {r["case"]: r for r in b["values"]["sessions"] if r["how"] == "pty" and r["rate asked Hz"] == 500}
    hold, turn = rows["hold"], rows["turn"]
    return (f"{hold['cpu mean ms']:.2f} ms (hold) to {turn['cpu mean ms']:.2f} ms (the 360° turn in 2.4 s) of CPU on "
            f"the air-core map, against a 2 ms period, at {hold['rate Hz']:.0f} / {turn['rate Hz']:.0f} Hz with "
            f"{hold['missed']} / {turn['missed']} deadlines missed (`bench_hardware.py --servo`, {_when(b)})")


def control_speed_table(b: dict) -> str:
    """docs/control.md, Speed: ``bench_control.py --quick`` (allocation, closed loop, holds, capability)."""
    v = b["values"]
    a, cpu, loop = v["allocation us"], v["allocation cpu us"], v["closed loop"]
    rows = [
        ("allocation, 29 coils, dual Newton (exact)",
         f"{a['newton']:.0f} µs wall, **{cpu['newton']:.0f} µs CPU** per call ({_thin(round(1e6 / a['newton']))}/s); "
         f"`pinv(K)t` without limits {a['pinv']:.0f} µs wall, {cpu['pinv']:.0f} µs CPU; Clarabel on the same QP "
         f"{a['clarabel'] / 1e3:.2f} ms ({a['clarabel'] / a['newton']:.0f}×), {cpu['clarabel'] / 1e3:.2f} ms CPU; "
         f"currents agree to {v['newton vs clarabel']:.1e}"),
        ("out-of-reach allocation (Clarabel SOCP + Newton)", _us_or_ms(a["out of reach"])),
        ("relay allocation (exhaustive, ≤ 4 coils)", _us_or_ms(a["relay"])),
        ("closed loop at 1 kHz, hold (`dynamics.hold`, magnets' torque map)",
         f"{loop['x real time']:.2f}× real time ({loop['ms per period']:.2f} ms per control period; one `K(R)` "
         f"{loop['K(R) ms']:.2f} ms, one torque evaluation {loop['torque ms']:.2f} ms of the torque map)"),
        ("holding 5 random orientations, 0.02° noise",
         "largest error over the last 0.15 s of 0.3 s: " + ", ".join(f"{w:.4f}°" for w in loop["hold worst deg"])),
        ("capability map, 1000 orientations", f"{v['capability 1000 s']:.1f} s"),
    ]
    return table(("what", "measured"), rows, f"Measured {_when(b)} (`{b['command']}`; {b['machine']}):")


def control_loop_table(b: dict) -> str:
    """docs/control.md: ``simulate_servo`` per period and the law alone (``bench_servo_loop.py``)."""
    v = b["values"]
    rows = []
    for name, label in (("air", "air core (`magnetics.torque_map`)"), ("iron", "iron (`magnetics.iron_model`, pairwise)")):
        hold, turn, law = v[f"simulate {name} hold"], v[f"simulate {name} turn"], v[f"law {name}"]
        rows.append((label, f"{hold['now'] / 1e3:.2f} ms (before {hold['before'] / 1e3:.2f})",
                     f"{turn['now'] / 1e3:.2f} ms (before {turn['before'] / 1e3:.2f})",
                     f"**{law['law.step (turn)'][0] / 1e3:.3f} ms** (before {law['law.step (turn)'][1] / 1e3:.2f})",
                     f"{law['law.step, K each'][0] / 1e3:.3f} ms (before {law['law.step, K each'][1] / 1e3:.2f})"))
    return table(("model", "hold", "20° turn", "`ServoLaw.step`", "the law with K and bias every period"), rows,
                 f"Measured {_when(b)} ({b['machine']}); \"before\" is the same run through the reference paths "
                 "(the models' own methods, the NumPy Newton and Clarabel):")


def loop_law(b: dict) -> str:
    """docs/control.md, the robust servo's cost: the law's step and the supply box (``bench_servo_loop.py``)."""
    v = b["values"]
    air, iron = v["law air"], v["law iron"]
    every = _range([iron["law.step, K each"][0], air["law.step, K each"][0]], "{:.0f}")
    return (f"`law.step` iron {iron['law.step (turn)'][0]:.1f} µs, air {air['law.step (turn)'][0]:.1f} µs ({every} µs "
            f"when `K` is re-evaluated every period); the supply box + allocation "
            f"{iron['supply box + allocation'][0]:.1f} µs against {iron['allocation'][0]:.1f} µs for the symmetric "
            f"box alone (`bench_servo_loop.py`, {_when(b)})")


def loop_evaluations(b: dict) -> str:
    """docs/control.md: how often the law re-evaluates ``K(R̂)`` on the 20° turn."""
    n, periods = b["values"]["law iron"]["K evaluations"]
    return f"{n} times in {periods} periods"


def iron_bench_table(b: dict) -> str:
    """docs/magnetics.md: the pairwise and the coupled model's costs side by side (``bench_iron.py``)."""
    m = b["values"]["model"]
    pair = m["E+tau pairwise us"]
    rows = {r["model"].split()[0]: r for r in m["rows"]}
    p, c = rows["pairwise"], rows["coupled"]
    rows = [("E + τ, one orientation, pairwise (compiled zonal sums, 29 cores × 92 poles)", f"{pair:.0f} µs", "1"),
            ("E + τ, one orientation, coupled, NumPy sums", f"{m['E+tau coupled numpy us'] / 1e3:.1f} ms",
             f"{m['E+tau coupled numpy us'] / pair:.0f} ×"),
            ("E + τ, one orientation, coupled, tables (the model's call)", f"{m['E+tau coupled tables us']:.0f} µs",
             f"1/{pair / m['E+tau coupled tables us']:.0f}"),
            ("E + τ, one orientation, coupled, tables (the compiled call the integrator makes)",
             f"{m['E+tau coupled packed us']:.1f} µs", f"1/{pair / m['E+tau coupled packed us']:.0f}"),
            ("coupled tables, cold build (of which `G` on its grid)",
             f"{m['tables cold build s']:.1f} s ({m['coupling grid s']:.1f} s)", ""),
            (f"dynamics at the tuned step ({p['dt ms']:.2f} / {c['dt ms']:.2f} ms), pairwise",
             f"{p['x real time']:.1f} × real time", ""),
            ("dynamics at the tuned step, coupled (tables)", f"{c['x real time']:.0f} × real time",
             f"{c['x real time'] / p['x real time']:.0f} × pairwise"),
            ("capability map, 400 orientations, pairwise / coupled",
             f"{p['capability s']:.1f} s / {c['capability s']:.1f} s", "")]
    return table(("what", "measured", "ratio to pairwise"), rows, f"Measured {_when(b)} (`benchmarks/bench_iron.py`; "
                 f"{b['machine']}; the design's own model: {m['label']}):")


def iron_mom_table(b: dict) -> str:
    """docs/magnetics.md: the moment method's and the FEM's costs (``bench_iron.py`` without ``--no-mom``)."""
    m = b["values"]["mom"]
    rows = [(f"MoM: factorise one core (level {m['level']}, {m['cells']} cells; `demag_tensor` + LU)",
             f"{m['factorise s']:.1f} s", ""),
            ("MoM: pair table, per angle (detent + linear)", f"{m['per angle s']:.2f} s", ""),
            ("iron map (pairwise): 1000 orientations (compiled spline sums, detent over all 29 cores)",
             f"{m['iron map 1000 ms']:.0f} ms", f"{m['iron map 1000 ms'] / m['air map 1000 ms']:.2f} × air map"),
            ("iron map (pairwise): one orientation", f"{m['iron map one us']:.0f} µs",
             f"{m['iron map one us'] / m['air map one us']:.2f} × air map")]
    if "fem solve s" in m:
        rows += [("FEM (NGSolve): mesh one angle, median of the stored runs", f"{m['fem mesh s']:.0f} s", ""),
                 ("FEM (NGSolve): one solve (order 2, sparse Cholesky), median of the stored runs",
                  f"{m['fem solve s']:.0f} s", f"{m['fem solve s'] / m['per angle s']:.0f} × a MoM angle")]
    return table(("what", "time", "ratio"), rows,
                 f"Measured {_when(b)} (`benchmarks/bench_iron.py`; the FEM rows: medians of `data/iron_fem.csv`):")


def _script(b: dict) -> str:
    return f"`{b['command']}`, {_when(b)}"


def performance_table(bs: dict) -> str:
    """README, Performance: one row per benchmark figure, each with its run's date and load."""
    g = {k.removeprefix("bench-"): v for k, v in bs.items()}
    pk, mo, ha, po = g["packing"]["values"], g["motor"]["values"], g["harmonics"]["values"], g["potential"]["values"]
    dy, pl, hw, co = g["dynamics"]["values"], g["planners"]["values"], g["hardware"]["values"], g["control"]["values"]
    lo, se = g["servo_loop"]["values"], g["sensing"]["values"]
    sec = pk["seconds"]
    lv = {r["poles"]: r for r in mo["levels"]}
    proto, finer = lv[min(lv)], sorted(lv)[1:]
    leg = next(r for r in ha["rows"] if r["task"].startswith("P^l matrix, l=64") and "recurrence" in r["baseline"])
    batch, single = po["batch us per orientation"], po["single us"]
    pair29 = batch["energy, pairwise (exact), 29 coils"]
    quad = batch["quadrature (5 orientations, scaled), 29 coils"]
    fast = [batch[f"{t}, 29 coils"] for t in ("energy, fast", "energy + torque, fast", "E, τ, Hessian, fast",
                                                "K(R), fast")]
    vs = po["batch vs exact"]
    speedups = [vs[f"{t}, 29 coils"] for t in ("energy, fast", "energy + torque, fast", "E, τ, Hessian, fast",
                                                "K(R), fast")]
    dyn = {k: dy[k] for k in ("potential", "magnets' torque map", "iron model")}
    rates = hw["relay frames per second"]
    alloc, cpu = co["allocation us"], co["allocation cpu us"]
    sims = _simulate(g["servo_loop"])
    law = lo["law iron"]
    sessions = [r for r in hw["sessions"] if r["rate asked Hz"] == 500]
    pty = {r["case"]: r for r in sessions if r["how"] == "pty"}
    lock = {r["case"]: r for r in sessions if r["how"] == "lockstep"}
    off, drills = hw["faults all off"]
    track = se["timing us"]["track: 1 Gauss–Newton step (update)"]
    acc = se["accuracy"]
    rows = [
        (f"refine the truncated icosahedron to ≥ 10,000 caps ({pk['refined caps']:,})", f"{sec['refine']:.2f} s",
         g["packing"]),
        (f"`validate()` / `min_separation()` on {pk['refined caps']:,} caps (KD-tree)",
         f"{1e3 * sec['validate']:.0f} ms / {1e3 * sec['min_separation']:.1f} ms", g["packing"]),
        (f"min separation, brute-force N² vs KD-tree, {pk['brute caps']:,} caps",
         f"{sec['brute'] / sec['kd']:.1f}× slower", g["packing"]),
        (f"stepper states of the prototype ({proto['states']:,})",
         f"{proto['enumerate s']:.2f} s; dense dot products instead of the voxel lookup: "
         f"{mo['baseline']['dense s']:.1f} s ({mo['baseline']['dense s'] / mo['baseline']['voxel s']:.1f}×)",
         g["motor"]),
        ("stepper states with finer rotors (same stator)",
         "; ".join(f"{r} poles (tol {lv[r]['tol deg']:.2f}°): {lv[r]['states']:,} states in "
                   f"{lv[r]['enumerate s']:.0f} s" for r in finer) + " — they grow with the square of the poles",
         g["motor"]),
        ("geometric planner", f"{proto['plan steps per s']:,.0f} steps/s (prototype), "
         f"{lv[max(lv)]['plan steps per s']:,.0f} steps/s with the {max(lv)}-pole rotor", g["motor"]),
        ("potential planner, prototype (compiled descent)",
         f"{po['planner steps per s']['fast']:,.0f} steps/s over one turn (`bench_potential.py`), "
         f"{pl['potential']['steps per s']:,.0f} (`bench_planners.py`, {pl['potential']['trials']} turns); exact forms "
         f"{po['planner steps per s']['exact']:,.0f}", g["potential"]),
        (f"geometric vs potential planner, {pl['geometric']['trials']} full turns",
         f"tracking error median {pl['geometric']['median error deg']:.2f}° vs {pl['potential']['median error deg']:.2f}°, "
         f"worst {pl['geometric']['worst error deg']:.1f}° vs {pl['potential']['worst error deg']:.1f}°, final "
         f"{pl['geometric']['final error deg']:.2f}° vs {pl['potential']['final error deg']:.2f}°", g["planners"]),
        ("rotor dynamics at the tuned time step (4th order), compiled integrator: potential model / magnets' torque "
         "map / iron model (pairwise)",
         " / ".join(f"{_times(r['x real time'])}× real time ({r['dt ms']:.1f} ms)" for r in dyn.values())
         + "; NumPy `Rotor.step`: " + " / ".join(f"{_times(r['numpy x real time'])}×" for r in dyn.values())
         + "; at 5 ms: " + " / ".join(f"{_times(r['dt 5 ms x real time'])}×" for r in dyn.values()), g["dynamics"]),
        ("generalized Legendre matrix P^l, l = 64, 1000 angles",
         f"{1e3 * leg['s']:.0f} ms; {leg['baseline s'] / leg['s']:.0f}× faster than the element-wise recurrence",
         g["harmonics"]),
        ("motor energy, 1000 orientations, 29 coils: pairwise / harmonic form",
         f"{pair29:.0f} ms / {batch['energy, harmonic (exact), 29 coils']:.0f} ms; {quad / pair29:.0f}× / "
         f"{quad / batch['energy, harmonic (exact), 29 coils']:.0f}× faster than quadrature", g["potential"]),
        ("fast path (rotor function at the coils, ducc0), 1000 orientations, 29 coils: energy / energy + torque / "
         "E, τ, Hessian / `K(R)`",
         " / ".join(f"{x:.1f}" for x in fast) + f" µs per orientation: {_range(speedups, '{:.0f}')}× faster than "
         f"the pairwise form; ducc0's synthesis of the energy alone "
         f"{batch['ducc0 synthesis of F (anchor), 29 coils']:.2f} µs (the anchor)", g["potential"]),
        ("one orientation per call, 4 coils: energy + torque / torque",
         f"{single['single call energy + torque, fast, 4 coils']:.0f} µs / "
         f"{single['single call torque, fast, 4 coils']:.0f} µs (the compiled call alone "
         f"{single['single call energy + torque, the compiled call alone, 4 coils']:.0f} µs); pairwise form "
         f"{single['single call energy + torque, pairwise, 4 coils']:.0f} µs", g["potential"]),
        ("equilibria of 10⁴ starts, fast path (compiled descent) / exact forms",
         f"{po['equilibria 1e4 s']['fast']:.2f} s / {po['equilibria 1e4 s']['exact']:.1f} s", g["potential"]),
        ("serial protocol 1 over a pseudo-terminal (stop-and-wait)",
         f"{rates['SET round trip over pty']:,.0f} acknowledged SET frames/s, `play()` "
         f"{rates['play() over pty, rate unbounded']:,.0f}/s", g["hardware"]),
        ("least-power current allocation, 29 coils",
         f"{alloc['newton']:.0f} µs per call ({cpu['newton']:.0f} µs CPU); Clarabel on the same QP "
         f"{alloc['clarabel'] / 1e3:.2f} ms, same currents to {co['newton vs clarabel']:.1e}", g["control"]),
        ("torque capability over 1000 orientations (magnets' torque map)", f"{co['capability 1000 s']:.1f} s",
         g["control"]),
        ("servo simulation at 1 kHz control (coil electrics, sensor, plant and law)",
         f"{_range([1e3 / r['now'] for r in sims], '{:.1f}')}× real time; one period of the servo law "
         f"{law['law.step (turn)'][0]:.0f} µs CPU on a turn (iron; `K(R)` and bias {law['K(R) and bias'][0]:.0f} µs "
         f"when re-evaluated, allocation {law['allocation'][0]:.0f} µs; {law['law.step (turn)'][1]:.0f} µs through "
         "the reference paths)", g["servo_loop"]),
        (f"orientation from {acc['sensors']} magnetometers (one Gauss–Newton update on the field table)",
         f"{track:.0f} µs ({1e3 / track:.1f} kHz); {acc['rms deg']:.4f}° RMS, {acc['worst deg']:.4f}° worst over "
         f"{acc['samples']} uniform orientations with coils energised", g["sensing"]),
        ("protocol 2 over a pseudo-terminal against the emulated motor (magnets' torque map), the loop at 500 Hz",
         f"{pty['hold']['cpu mean ms']:.2f}–{pty['turn']['cpu mean ms']:.2f} ms host CPU per 2 ms cycle; hold "
         f"{pty['hold']['error deg']:.3f}° at {pty['hold']['rate Hz']:.0f} Hz ({pty['hold']['missed']} deadlines "
         f"missed), the 360° turn about (1, 0.5, 2) in 2.4 s {pty['turn']['error deg']:.3f}° off at the loop's end "
         f"({pty['turn']['missed']} missed); in lockstep {lock['turn']['rate Hz']:.0f} Hz, {lock['turn']['missed']} "
         f"missed, {lock['turn']['error deg']:.4f}°; {off} of {drills} injected faults end all-off within the 100 ms "
         "watchdog", g["hardware"]),
    ]
    machines = sorted({b["machine"] for b in bs.values()})
    return table(("what", "measured", "script, when"), [(what, value, _script(b)) for what, value, b in rows],
                 f"Machine: {'; '.join(machines)}.")


SENSING_ROWS = (("magpylib: rotor field at the 24 sensors", "magpylib rotor field (1 call)"),
                ("table: field", "table field"), ("table: field + Jacobian", "table field + Jacobian"),
                ("**update (`track`, 1 Gauss–Newton step)**", "track: 1 Gauss–Newton step (update)"),
                ("`solve`: LM to 1e-10 rad from 0.06°", "solve: LM to 1e-10 rad from 0.06°"))


def _us_or_ms(us: float) -> str:
    return f"{us / 1e3:.1f} ms" if us >= 1000 else f"{us:.0f} µs"


def sensing_timing(b: dict) -> str:
    """docs/sensing.md: time per call of the estimator's pieces (``bench_sensing.py --docs``)."""
    t = b["values"]["timing us"]
    mag = t["magpylib rotor field (1 call)"]
    rows = []
    for label, key in SENSING_ROWS:
        bold = "**" if label.startswith("**") else ""
        ratio = f"{mag / t[key]:.0f}×"
        rows.append((label, f"{bold}{_us_or_ms(t[key])}{bold}", f"{bold}{_thin(round(1e6 / t[key]))} /s{bold}",
                     "1" if ratio == "1×" else ratio))
    return table(("call", "median", "rate", "vs one magpylib call"), rows,
                 f"Measured {_when(b)} (`benchmarks/bench_sensing.py --docs`; {b['machine']}):")


def sensing_rate(b: dict) -> str:
    return f"{1e3 / b['values']['timing us']['track: 1 Gauss–Newton step (update)']:.1f} kHz in Python"


def sensing_magpylib(b: dict) -> str:
    return f"{1e6 / b['values']['timing us']['magpylib rotor field (1 call)']:.0f} Hz"


def sensing_update(b: dict) -> str:
    us = b["values"]["timing us"]["track: 1 Gauss–Newton step (update)"]
    return f"{1e3 / us:.1f} kHz (one Gauss–Newton step, {us:.0f} µs; {b['measured'][:10]})"


def sensing_rms(b: dict) -> str:
    return f"{b['values']['accuracy']['rms deg']:.4f}° RMS"


def sensing_accuracy(b: dict) -> str:
    """docs/sensing.md: the default array's accuracy (``bench_sensing.py --docs``)."""
    a = b["values"]["accuracy"]
    return (f"**{a['rms deg']:.4f}° RMS, {a['worst deg']:.4f}° worst** ({a['samples']} Haar orientations, "
            f"{b['measured'][:10]})")


def sensing_session_update(b: dict) -> str:
    """docs/sensing.md, the emulated path's table: the session's estimator update on iron (8 magnetometers, the cores'
    field modelled), ``bench_servo_loop.py``'s magnetometer update."""
    return (f"{b['values']['magnetometer update']:.0f} µs CPU (`bench_servo_loop.py`, {_when(b)})")
