"""docs/explore.md's default sweep (``data/explore_default.json``: :func:`run_explore`)."""

from __future__ import annotations

import datetime
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from .common import ROOT, _machine, _signed, _thin, table


# docs/explore.md's published sweep: the default grid restricted to six rotor-stator pairs (the paper's, the old air-core
# front's and both family rules; 72 designs) — the whole default grid (648 designs, iron) takes hours on the shared
# 2-core machine under load; dropping --rotors/--stators here runs it whole
EXPLORE_SUBSET = {"rotors": ("truncated-icosahedron", "rhombicosidodecahedron", "truncated-octahedron"),
                  "stators": ("truncated-cuboctahedron", "truncated-icosahedron", "truncated-cube", "icosidodecahedron")}
EXPLORE_OPTIONS = ("--budget-coils", "32", "--workers", "2", "--rotors", ",".join(EXPLORE_SUBSET["rotors"]),
                   "--stators", ",".join(EXPLORE_SUBSET["stators"]))
EXPLORE_KEEP = ("rotor", "rotor_level", "rotor_poles", "stator", "stator_level", "cap_half_angle_deg", "coils", "states",
                "resolution_median_deg", "resolution_p95_deg", "escape_violations", "holding_torque_median_Nm",
                "capability_median_Nm", "capability_p5_Nm", "family_rule", "rotor_family", "stator_family", "model")
# the paper's pair, as the sweep names it (docs/explore.md compares it with the proposals)
EXPLORE_PROTOTYPE = {"rotor": "truncated-icosahedron", "rotor_level": 1, "stator": "truncated-cuboctahedron",
                     "stator_level": 1, "cap_half_angle_deg": 80.0}


def _records(df) -> list[dict]:
    """Rows as plain JSON values (NaN → None; the counts, floats in a CSV column with gaps, as integers)."""
    counts = ("rotor_level", "rotor_poles", "stator_level", "coils", "states", "escape_violations")
    return [{k: int(v) if k in counts and v is not None else v for k, v in r.items()}
            for r in json.loads(df.to_json(orient="records"))]


def summarise_explore(folder: Path, run: dict) -> dict:
    """The numbers docs/explore.md quotes from a finished sweep folder (``results.csv``, ``pareto.csv``) and how it
    ran (``run``: command, measured, wall_s, load, machine)."""
    import pandas as pd

    t = pd.read_csv(folder / "results.csv")
    front = pd.read_csv(folder / "pareto.csv")
    reason = t["reason"].fillna("")
    status = t["status"]
    ok = t[status == "ok"]
    reach = ok[ok["reaches_all"].astype(bool)]

    def share(df):
        return df["escape_violations"] / df["states"]

    def family(df) -> dict:
        esc = share(df)
        return {"designs": len(df), "resolution_median_deg": float(df["resolution_median_deg"].median()),
                "resolution_best_deg": float(df["resolution_median_deg"].min()),
                "escape_share_median": float(esc.median()), "escape_under_5pct": int((esc < 0.05).sum()),
                "holding_median_Nm": None if df["holding_torque_median_Nm"].isna().all()
                else float(df["holding_torque_median_Nm"].median()),
                "holding_measured": int(df["holding_torque_median_Nm"].notna().sum())}

    over = t[status == "over_budget"]
    proto = t
    for k, v in EXPLORE_PROTOTYPE.items():
        proto = proto[proto[k] == v]
    return {
        **run,
        "designs": len(t),
        "pairs": len(set(zip(t["rotor"], t["stator"]))),
        "status_counts": {k: int(v) for k, v in status.value_counts().items()},
        "no_states": {"few_coils": int(((status == "no_states") & reason.str.contains("coils? in the stator cap")).sum()),
                      "no_alignment": int(((status == "no_states") & reason.str.startswith("no orientation")).sum())},
        "too_large": {"lookup": int(((status == "too_large") & reason.str.contains("lookup grid")).sum()),
                      "candidates": int(((status == "too_large") & reason.str.contains("candidate alignments")).sum()),
                      "poles": int(((status == "too_large") & reason.str.contains("poles, over")).sum())},
        "over_budget": {"designs": len(over), "stators": sorted(set(over["stator"])),
                        "coils": [int(over["coils"].min()), int(over["coils"].max())] if len(over) else []},
        "does_not_fit_reasons": sorted(set(reason[status == "does_not_fit"])),
        "measured_designs": len(ok),
        "torques_measured": int(ok["model"].notna().sum()),
        "models": {k: int(v) for k, v in ok["model"].value_counts().items()},
        "reach_all": len(reach),
        "seconds_inside_designs": float(t["seconds"].fillna(0).sum()),
        "pareto": _records(front[list(EXPLORE_KEEP)]),
        "prototype": _records(proto[list(EXPLORE_KEEP)])[0] if len(proto) else None,
        "family": {"different": family(reach[reach["family_rule"] != "same"]),
                   "same": family(reach[reach["family_rule"] == "same"])},
    }


def run_explore(folder: Path | None) -> dict:
    """``spherestep explore`` with docs/explore.md's options into ``folder`` (a fresh temporary one by default),
    timed, the load at its start and end recorded; its summary (what data/explore_default.json stores). Given a finished
    ``folder`` whose ``run.json`` says how it ran, only the summary is stored."""
    if folder is not None and (folder / "results.csv").exists():
        run = json.loads((folder / "run.json").read_text(encoding="utf-8")) if (folder / "run.json").exists() else {}
    else:
        folder = folder or Path(tempfile.mkdtemp(prefix="explore-"))
        cmd = [sys.executable, "-c", "from spherestep.cli import main; main()", "explore", *EXPLORE_OPTIONS,
               "--out", str(folder), "--json"]
        load0, start = os.getloadavg()[0], datetime.datetime.now(datetime.UTC)
        print(f"running spherestep explore {' '.join(EXPLORE_OPTIONS)} --out {folder} (load {load0:.1f})", flush=True)
        out = subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.PIPE, text=True,
                             env={**os.environ, "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS", "1")})
        wall = (datetime.datetime.now(datetime.UTC) - start).total_seconds()
        info = json.loads(out.stdout)
        run = {"command": f"spherestep explore {' '.join(EXPLORE_OPTIONS)} --out …",
               "measured": start.strftime("%Y-%m-%d %H:%M UTC"), "wall_s": round(wall, 1),
               "load": [round(load0, 1), round(os.getloadavg()[0], 1)], "machine": _machine(),
               "stored_before": info["stored_before"], "evaluated": info["evaluated"]}
        (folder / "run.json").write_text(json.dumps(run, indent=1) + "\n", encoding="utf-8")
    return summarise_explore(folder, run)


def _pack(name: str) -> str:
    return name.replace("-", " ")


def _ex_when(e: dict) -> str:
    lo, hi = sorted(e["load"])
    return f"{e['measured']}, load {lo:.1f}–{hi:.1f}"


def explore_run(e: dict) -> str:
    """docs/explore.md: how the default sweep ran and what became of its designs."""
    c, ns, tl, ob = e["status_counts"], e["no_states"], e["too_large"], e["over_budget"]
    minutes, seconds = divmod(round(e["wall_s"]), 60)
    models = "; ".join(f"{n} on {m}" for m, n in e["models"].items())
    fit = c.get("does_not_fit", 0)
    resumed = (f"; {e['stored_before']} of the {e['designs']} designs had been stored minutes before by an "
               f"interrupted run of the whole grid (same keys: a sweep resumes by key), the other {e['evaluated']} "
               "were evaluated in this run" if e.get("stored_before") else "")
    return (
        f"Measured {_ex_when(e)} with `{e['command']}` under `nice -n 5` ({e['machine']}; other jobs shared the "
        f"two cores): the default grid restricted to {e['pairs']} rotor–stator pairs, {e['designs']} designs — the "
        f"whole grid on the iron model takes hours on this machine under load, so this stated subset is what is "
        f"published (without `--rotors` and `--stators` the same command runs the whole grid). {minutes} min "
        f"{seconds:02d} s wall{resumed}; {e['seconds_inside_designs']:.0f} s inside designs summed over both "
        "workers. The coils are iron-cored (the default `--core iron`), the torques measured on each design's own "
        "model.\n\n"
        f"Of the {e['designs']} designs {e['measured_designs']} were measured; {c.get('no_states', 0)} have no states "
        f"({ns['no_alignment']} with no alignment of two poles on two coils, {ns['few_coils']} with fewer than two "
        f"coils in the cap), {c.get('too_large', 0)} were too large ({tl['lookup']} lookup grids, {tl['candidates']} "
        f"candidate counts, {tl['poles']} rotors over 300 poles), {fit} do not fit and {ob['designs']} are over the "
        "budget"
        + (f" ({', '.join(_pack(s) for s in ob['stators'])} as a stator: {ob['coils'][0]} to {ob['coils'][1]} coils)"
           if ob["designs"] else "") + ". "
        f"Torques were measured on {e['torques_measured']} of the {e['measured_designs']} ({models})"
        + ("" if e["torques_measured"] == e["measured_designs"] else
           "; the others' parts have no stored iron tables (their reason says so)")
        + f". {e['reach_all']} of the {e['measured_designs']} reach every orientation. The Pareto set within 32 coils:")


def explore_pareto_table(e: dict) -> str:
    """docs/explore.md: the default sweep's Pareto set, and the paper's pair beside it."""
    rows, seen = [], set()
    for i, r in enumerate(e["pareto"], start=1):
        rotor = f"{_pack(r['rotor'])} L{r['rotor_level']}"
        if rotor not in seen:
            rotor += f" ({r['rotor_poles']})"
            seen.add(rotor.rsplit(" (", 1)[0])
        hold = "—" if r["holding_torque_median_Nm"] is None else f"{r['holding_torque_median_Nm']:.2f}"
        cap = "—" if r["capability_p5_Nm"] is None else _signed(r["capability_p5_Nm"], 2)
        same = " same" if r["family_rule"] == "same" else ""
        rows.append((i, rotor, f"{_pack(r['stator'])} L{r['stator_level']}", f"{r['cap_half_angle_deg']:.0f}°", r["coils"],
                     f"{r['resolution_median_deg']:.2f}°", f"{r['resolution_p95_deg']:.2f}°",
                     f"{100 * r['escape_violations'] / r['states']:.0f} %", hold, cap,
                     f"{r['rotor_family']}/{r['stator_family']}{same}"))
    return table(("#", "rotor", "stator", "cap", "coils", "median", "95 %", "escape", "holding (N·m)",
                  "capability p5 (N·m)", "families"), rows)


def explore_prototype(e: dict) -> str:
    """docs/explore.md: the paper's pair as the sweep measured it."""
    p = e["prototype"]
    hold = "not measured" if p["holding_torque_median_Nm"] is None else f"{p['holding_torque_median_Nm']:.2f} N·m"

    def dominates(r) -> bool:
        h, hp = r["holding_torque_median_Nm"], p["holding_torque_median_Nm"]
        torque = h is None or hp is None or h >= hp
        no_worse = r["resolution_median_deg"] <= p["resolution_median_deg"] and r["coils"] <= p["coils"] and torque
        return no_worse and r != p

    by = [(i, r) for i, r in enumerate(e["pareto"], start=1) if dominates(r)]
    if any(r == p for r in e["pareto"]):
        verdict = "it is on the Pareto front"
    elif by:
        i, r = by[-1]
        rh = "" if r["holding_torque_median_Nm"] is None else f", {r['holding_torque_median_Nm']:.2f} N·m"
        verdict = (f"it is dominated by #{i} ({_pack(r['rotor'])} L{r['rotor_level']} × {_pack(r['stator'])} "
                   f"L{r['stator_level']}, {r['cap_half_angle_deg']:.0f}°: {r['coils']} coils, "
                   f"{r['resolution_median_deg']:.2f}°{rh})")
    else:
        verdict = "it is dominated (by a design outside the coil budget or the reach condition)"
    return (f"{p['coils']} coils, {_thin(p['states'])} states, median {p['resolution_median_deg']:.2f}°, 95 % "
            f"{p['resolution_p95_deg']:.2f}°, escape {100 * p['escape_violations'] / p['states']:.0f} %, holding "
            f"torque {hold}: {verdict}")


def explore_measured(e: dict) -> str:
    return f"{e['measured_designs']} measured designs"


def explore_family(e: dict) -> str:
    """docs/explore.md: the family rule on the designs that reach every orientation."""
    d, s = e["family"]["different"], e["family"]["same"]
    same_front = sum(r["family_rule"] == "same" for r in e["pareto"])

    def hold(f):
        return "—" if f["holding_median_Nm"] is None else f"{f['holding_median_Nm']:.2f}"

    return (f"Among the {e['reach_all']} designs that reach every orientation, the {d['designs']} different-family "
            f"ones have a median resolution of {d['resolution_median_deg']:.2f}° (best "
            f"{d['resolution_best_deg']:.2f}°) and the {s['designs']} same-family ones {s['resolution_median_deg']:.2f}° "
            f"(best {s['resolution_best_deg']:.2f}°); the median share of states failing the escape test is "
            f"{100 * d['escape_share_median']:.1f} % and {100 * s['escape_share_median']:.1f} %, and "
            f"{d['escape_under_5pct']} and {s['escape_under_5pct']} designs have fewer than 5 % failing; the median "
            f"holding torque (of the {d['holding_measured']} and {s['holding_measured']} with torques measured) is "
            f"{hold(d)} and {hold(s)} N·m. {same_front} of the {len(e['pareto'])} proposals are same-family pairs")
