"""docs/potential.md's and docs/dynamics.md's numbers (``data/potential_numbers.json``, ``data/dynamics_tune.json``)."""

from __future__ import annotations

import math
from .common import _thin, _times, _when, table


POTENTIAL_OFFSET_STATES, POTENTIAL_SEED = 5000, 0


def measure_potential() -> dict:
    """docs/potential.md's numbers of the prototype's energy model: profiles, band limit, kernel table, cut-off, the
    equilibria of ``POTENTIAL_OFFSET_STATES`` random states (seed ``POTENTIAL_SEED``) and the example curve's fit.
    Deterministic; ~1 min."""
    import numpy as np

    from spherestep import so3
    from spherestep.motor import coil_currents, prototype
    from spherestep.potential import MotorPotential, example_force_curve, fit_profile
    from spherestep.statics import equilibrium

    d = prototype()
    p = MotorPotential(d)
    stator_alone = MotorPotential(d, rotor_profile=p.stator_profile).bandlimit
    field = p.rotor_field
    cut = float(field.cut)
    x = np.random.default_rng(POTENTIAL_SEED).normal(size=(20_000, 3))
    x /= np.linalg.norm(x, axis=1, keepdims=True)
    inside = float(np.mean(np.sum(x @ field.poles.T > math.cos(cut), axis=1)))
    states = d.states()
    picks = np.sort(np.random.default_rng(POTENTIAL_SEED).choice(len(states), POTENTIAL_OFFSET_STATES, replace=False))
    coils = [states.coils(int(i)) for i in picks]
    c = np.array([coil_currents(k, len(d.stator)) for k in coils])
    geo = states.rotations[picks]
    eq = equilibrium(p, geo, c)
    off = np.degrees(so3.distance(eq.rotation, geo))
    held = np.array([len(k) for k in coils])
    rows = []
    for n in [*sorted(set(held.tolist())), None]:
        sel = off if n is None else off[held == n]
        rows.append({"held": n, "states": int(sel.size), "median": float(np.median(sel)), "mean": float(np.mean(sel)),
                     "p90": float(np.percentile(sel, 90)), "max": float(np.max(sel))})
    fit = fit_profile(*example_force_curve(), 0.1524, p.rotor_profile)
    return {
        "rotor_half_width_deg": math.degrees(p.rotor_profile.half_width), "rotor_kappa": p.rotor_profile.kappa,
        "stator_half_width_deg": math.degrees(p.stator_profile.half_width), "stator_kappa": p.stator_profile.kappa,
        "bandlimit": p.bandlimit, "bandlimit_stator_alone": stator_alone,
        "kernel_intervals": p.kernel.intervals, "kernel_errors": list(p.kernel.table_error),
        "cutoff_deg": math.degrees(cut), "poles": len(field.poles), "poles_inside_mean": inside,
        "equilibria": {"states": POTENTIAL_OFFSET_STATES, "seed": POTENTIAL_SEED,
                       "minima": int(np.sum(eq.is_minimum)), "iterations_max": int(np.max(eq.iterations)),
                       "iterations_mean": float(np.mean(eq.iterations)), "rows": rows,
                       "stiffness_median": [float(v) for v in np.median(eq.stiffness, axis=0)],
                       "stiffness_min": float(np.min(eq.stiffness))},
        "example_fit": {"kappa_s": fit.stator.kappa, "amplitude_s": fit.stator.amplitude},
    }


def potential_profiles(m: dict) -> str:
    return (f"`ρ_r = {m['rotor_half_width_deg']:.3f}°`, `κ_r = {m['rotor_kappa']:.2f}` and "
            f"`ρ_s = {m['stator_half_width_deg']:.3f}°`, `κ_s = {m['stator_kappa']:.2f}`")


def potential_bandlimit(m: dict) -> str:
    return (f"`L = {m['bandlimit']}` for the prototype (the rotor's sharper bump decides; the stator alone needs "
            f"{m['bandlimit_stator_alone']})")


def potential_kernel(m: dict) -> str:
    g, g1, g2 = m["kernel_errors"]
    return f"{m['kernel_intervals']} intervals, errors {g:.1e} (G), {g1:.1e} (G'), {g2:.1e} (G'')"


def potential_cutoff(m: dict) -> str:
    return (f"**{m['cutoff_deg']:.0f}°** for the prototype, so {m['poles_inside_mean']:.0f} of {m['poles']} poles per "
            "point on average")


def potential_offsets(m: dict) -> str:
    """docs/potential.md: equilibria of random states against their geometric states."""
    e = m["equilibria"]
    rows = [(r["held"] if r["held"] is not None else "all", r["states"], f"{r['median']:.3f}°", f"{r['mean']:.3f}°",
             f"{r['p90']:.3f}°", f"{r['max']:.3f}°") for r in e["rows"]]
    return table(("held pairs", "states", "median", "mean", "90th pct", "max"), rows,
                 f"({e['states']:,} random states of the prototype (seed {e['seed']}), each with its held coils "
                 f"energised with the polarity of their poles, started at the state): {e['minima']:,} of {e['states']:,} "
                 f"converge to strict minima (Hessian positive definite) in at most {e['iterations_max']} Newton "
                 f"iterations (mean {e['iterations_mean']:.1f}). Park distance equilibrium ↔ geometric state:", "rrrrrr")


def potential_stiffness(m: dict) -> str:
    e = m["equilibria"]
    return (f"median {', '.join(f'{v:.1f}' for v in e['stiffness_median'])}; smallest over the sample "
            f"{e['stiffness_min']:.2f}")


def potential_fit(m: dict) -> str:
    f = m["example_fit"]
    return (f"`κ_s = {f['kappa_s']:.2f}`, `A_s = {f['amplitude_s']:.3f}` ({100 * abs(f['kappa_s'] / 51.03 - 1):.1f} % "
            f"and {100 * abs(f['amplitude_s'] / 6.0 - 1):.1f} % off: noise)")


def potential_timings(b: dict) -> str:
    """docs/potential.md, Timings: ``bench_potential.py``'s batches of 1000 orientations and its other figures."""
    v = b["values"]
    batch, vs, single = v["batch us per orientation"], v["batch vs exact"], v["single us"]
    rows = []
    for task, us in batch.items():
        coils = task.rsplit(", ", 1)[1]
        anchor = batch[f"ducc0 synthesis of F (anchor), {coils}"]
        name = task.replace("K(R)", "`K(R)`").replace("synthesis of F", "synthesis of `F`")
        if ", fast, " in task:
            name = "**" + name.replace(f", {coils}", "") + f"**, {coils}"
        ratio = vs.get(task)
        rows.append((name, _thin(round(us)) if us >= 100 else f"{us:.2f}", _thin(round(1e6 / us)),
                     f"{_times(us / anchor)}×", None if ratio is None else f"{ratio:.1f}×"))
    eq, pl, dy = v["equilibria 1e4 s"], v["planner steps per s"], v["dynamics"]
    same = []
    for n in (4, 29):
        same += [(f"single call, energy + torque, {n} coils",
                  f"{single[f'single call energy + torque, fast, {n} coils']:.1f} µs (the compiled call alone "
                  f"{single[f'single call energy + torque, the compiled call alone, {n} coils']:.1f} µs)",
                  f"{single[f'single call energy + torque, pairwise, {n} coils']:.1f} µs (pairwise)"),
                 (f"single call, torque only, {n} coils", f"{single[f'single call torque, fast, {n} coils']:.1f} µs", ""),
                 (f"single call, E, τ, Hessian, {n} coils",
                  f"{single[f'single call E, τ, Hessian, fast, {n} coils']:.1f} µs", "")]
    same += [(f"equilibria of 10⁴ starts (2° off a state, its coils; {100 * eq['converged']:.0f} % converged)",
              f"**{eq['fast']:.2f} s**", f"{eq['exact']:.1f} s"),
             ("potential planner, one 360° turn", f"{_thin(round(pl['fast']))} steps/s", f"{_thin(round(pl['exact']))} steps/s"),
             (f"dynamics at the tuned step ({dy['fast']['dt ms']:.1f} ms)", f"{_thin(round(dy['fast']['x real time']))}× real "
              "time", f"{_times(dy['exact']['x real time'])}× real time")]
    batches = table(("task (1000 orientations)", "µs per orientation", "per second", "vs ducc0", "vs exact"), rows,
                    f"Measured {_when(b)} (`benchmarks/bench_potential.py`; {b['machine']}, `OPENBLAS_NUM_THREADS="
                    f"{b.get('OPENBLAS_NUM_THREADS', '?')}`). Batches of 1000 random orientations; \"vs ducc0\" is the "
                    "row's time over the anchor's (ducc0's `synthesis_general` of `F` alone at the same points, library "
                    "time only); \"vs exact\" the matching exact row's time over the row's. The accuracy of each row is "
                    "the tests' (Accuracy, above).", "lrrrr")
    return batches + "\n\n" + table(("task", "fast path", "exact forms"), same, "Same script, same run:", "lrr")


def _met(ok: bool) -> str:
    return "met" if ok else "**not reached**"


def potential_targets(bs: dict) -> str:
    """docs/potential.md: issue 17's targets against the stored runs of bench_potential, bench_planners, bench_dynamics."""
    po, pl, dy = bs["bench-potential"], bs["bench-planners"], bs["bench-dynamics"]
    v = po["values"]
    batch, single = v["batch us per orientation"], v["single us"]
    et, k, h = (batch[f"{t}, fast, 29 coils"] for t in ("energy + torque", "K(R)", "E, τ, Hessian"))
    one = single["single call energy + torque, fast, 4 coils"]
    eq, steps, dyn = v["equilibria 1e4 s"], v["planner steps per s"], dy["values"]["potential"]
    planner = pl["values"]["potential"]
    rows = [("energy + torque, 29 coils, batches of 1000",
             f"{et:.1f} µs per orientation ({_times(et / batch['ducc0 synthesis of F (anchor), 29 coils'])}× the anchor; "
             f"{batch['energy + torque, pairwise (exact), 29 coils'] / et:.0f}× faster than pairwise)",
             f"≤ 5 µs — {_met(et <= 5)}"),
            ("`K(R)`, 29 coils, batches", f"{k:.1f} µs → {_thin(int(round(1e6 / k, -3)))} per second",
             f"≥ 10⁵ /s — {_met(1e6 / k >= 1e5)}"),
            ("E, τ, Hessian, 29 coils, batches", f"{h:.1f} µs", "—"),
            ("one orientation per call, energy + torque, 4 coils",
             f"{one:.1f} µs (the compiled call alone "
             f"{single['single call energy + torque, the compiled call alone, 4 coils']:.1f} µs; pairwise "
             f"{single['single call energy + torque, pairwise, 4 coils']:.0f} µs)", f"≤ 30 µs — {_met(one <= 30)}"),
            ("equilibria of 10⁴ starts", f"{eq['fast']:.2f} s (exact forms {eq['exact']:.1f} s)",
             f"< 1 s — {_met(eq['fast'] < 1)}"),
            ("potential planner, one 360° turn",
             f"{_thin(round(steps['fast']))} steps/s in `bench_potential.py`, {_thin(round(planner['steps per s']))} in "
             f"`bench_planners.py` (median of {planner['trials']} turns; exact forms {_thin(round(steps['exact']))})",
             f"≥ 1000 — {_met(min(steps['fast'], planner['steps per s']) >= 1000)}"),
            (f"dynamics at the tuned step ({dyn['dt ms']:.1f} ms)",
             f"{_thin(round(dyn['x real time']))}× real time (NumPy `Rotor.step` {_thin(round(dyn['numpy x real time']))}×)",
             f"≥ 500× — {_met(dyn['x real time'] >= 500)}")]
    return table(("task", "stored runs", "target"), rows,
                 f"`bench_potential.py` {_when(po)}; `bench_planners.py` {_when(pl)}; `bench_dynamics.py` {_when(dy)}:",
                 "lrr")


def planners_potential(b: dict) -> str:
    """docs/potential.md: the potential planner over bench_planners.py's turns, as stored."""
    p = b["values"]["potential"]
    return (f"median {p['median error deg']:.2f}°, worst {p['worst error deg']:.2f}°, final {p['final error deg']:.2f}° "
            f"over {p['trials']} turns, {_thin(round(p['steps per s']))} steps/s ({_when(b)})")


def measure_dynamics() -> dict:
    """docs/dynamics.md's numbers: the prototype's inertia and ``dynamics.tune`` on the torque map and the iron
    model (deterministic; ~30 s)."""
    from spherestep.dynamics import Rotor, tune
    from spherestep.magnetics import iron_model, torque_map
    from spherestep.motor import prototype

    d = prototype()
    out = {"inertia_kg_m2": Rotor.from_design(d).inertia}
    for name, model in (("torque map", torque_map(d)), ("iron model", iron_model(d))):
        t = tune(d, model)
        out[name] = {"stiffness_Nm_per_rad": t.stiffness, "omega_rad_s": t.omega,
                     "damping_Nm_s": t.rotor.damping, "dwell_s": t.dwell, "dt_s": t.dt}
    return out


def dynamics_tune(m: dict) -> str:
    """docs/dynamics.md: ``dynamics.tune`` on the prototype."""
    a, i = m["torque map"], m["iron model"]
    return (f"Prototype on the torque map: `k` = {a['stiffness_Nm_per_rad']:.3f} N·m/rad, `ω` = {a['omega_rad_s']:.2f} "
            f"rad/s, `b` = {a['damping_Nm_s']:.3f} N·m·s, dwell {a['dwell_s']:.2f} s, `dt` {1e3 * a['dt_s']:.1f} ms; on the "
            f"iron model: `k` = {i['stiffness_Nm_per_rad']:.1f} N·m/rad, `ω` = {i['omega_rad_s']:.1f} rad/s, `b` = "
            f"{i['damping_Nm_s']:.2f} N·m·s, dwell {i['dwell_s']:.2f} s, `dt` {1e3 * i['dt_s']:.1f} ms")


def dynamics_inertia(m: dict) -> str:
    return f"{m['inertia_kg_m2']:.4f} kg·m²"


def dynamics_speed(b: dict) -> str:
    """docs/dynamics.md, Speed: ``bench_dynamics.py``, each model at its own tuned step."""
    v = b["values"]
    rows = [(v["potential"], "the potential"), (v["magnets' torque map"], "the torque map"),
            (v["iron model"], "the iron model")]
    at = ", ".join(f"{_times(r['x real time'])}× on {name} ({r['dt ms']:.1f} ms)" for r, name in rows)
    numpy = ", ".join(f"{_times(r['numpy x real time'])}×" for r, _ in rows)
    at5 = ", ".join(f"{_times(r['dt 5 ms x real time'])}×" for r, _ in rows)
    return (f"`benchmarks/bench_dynamics.py`, {_when(b)}, each model at its own tuned step: {at}; `Rotor.step` in "
            f"the same run {numpy}; all three at 5 ms: {at5}")
