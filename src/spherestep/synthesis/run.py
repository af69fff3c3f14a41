"""The search (issue 29 §2): candidates on a Dask cluster through the ladder, the Pareto set of what the spec leaves
free, finalists verified by full simulation, and the answer.

**The optimiser.** The layout choice is discrete and small — a few hundred rotor × stator × refinement × cap × ball
size × core combinations per spec — and most of it is pruned by the cheap rungs, so the search *enumerates* it
(:func:`candidates`) instead of sampling it with optuna or pymoo: enumeration is exhaustive over the budget's grid,
deterministic for a seed, trivially parallel on Dask and resumable by key from the explore room's store
(:class:`spherestep.explore.ResultStore`), and a multi-objective Pareto set over every candidate is exact rather than
estimated (:func:`spherestep.explore.pareto_mask`). A sampler would pay off for continuous part sizes, which only the
``thorough`` budget varies (on a grid of ball sizes; iron with other parts costs a table solve each).
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import checks
from ..errors import InputError, bad_value
from .eta import (ALIGNMENT_SECONDS, BUILD_SECONDS, REPORT_SECONDS, REPORT_STATES, SOLVE_SECONDS, Progress,
                  after_ladder, relay_rung_seconds, verify_seconds)
from .answer import _answer, closest_row, nearest_rows
from .front import Finalist, _json, _missing, choose_finalists, pareto
from . import tasks
from .ladder import GRADES, N42, PROTOTYPE, WINDINGS, Candidate, _row, baseline_layout, build, climb, relay_rung

STORE = "results"
TASKS = "tasks.jsonl"  # one line per ladder task: its layout, kind, core and seconds (tasks.timings)
GAP_SCALES = (2.0, 4.0, 8.0)  # the baseline's air gap widened (iron: a table solve each, thorough budget)


@dataclass(frozen=True)
class Budget:
    """How much of the design space a search covers and how finely it measures (``BUDGETS``)."""

    name: str
    rotors: tuple[str, ...] | None  # None: the 16 distinct packings
    stators: tuple[str, ...] | None
    primary_ratio: float
    rotor_levels: tuple[int, ...]
    stator_levels: tuple[int, ...]
    caps: tuple[float, ...]
    diameters: int
    samples: int
    capability_samples: int
    finalists: int
    holds: int
    verify_samples: int
    verify_capability: int
    allow_costly: bool = False
    costly_neighbourhood: bool = False  # the baseline's wider gaps with iron solved even so (a few table solves)
    neighbourhood: bool = True  # with a baseline, every layout one choice away from it (else the baseline alone)
    parts: bool = True  # with a baseline, its parts in every combination (magnet grade × winding)
    rounds: int = 1  # when no candidate passes: local rounds around the closest ones (their one-change neighbours)
    round_seeds: int = 3


BUDGETS = {
    "quick": Budget("quick", ("truncated-icosahedron",), ("truncated-cuboctahedron",), 9.0, (0, 1), (0,),
                    (60.0, 80.0), 1, 400, 32, 2, 1, 1000, 64, neighbourhood=False, parts=False, rounds=0),
    "normal": Budget("normal", None, None, 1.25, (0, 1), (0, 1), (60.0, 70.0, 80.0), 2, 1000, 64, 4, 3, 4000, 200,
                     costly_neighbourhood=True),
    "thorough": Budget("thorough", None, None, 1.6, (0, 1, 2), (0, 1, 2), (50.0, 60.0, 70.0, 80.0, 85.0), 3, 2000,
                       128, 8, 5, 8000, 400, True, True, rounds=2, round_seeds=5),
}


def ball_diameters(spec, count: int) -> list[float]:
    """``count`` ball diameters spread over the envelope, largest first; the prototype's 12 in exactly when it lies
    in the envelope (its parts reuse the stored iron table)."""
    low, high = spec.envelope.ball_diameter
    values = [high] if count == 1 or math.isclose(low, high) else list(np.linspace(high, low, count))
    proto = PROTOTYPE["sphere_diameter"]
    if low * (1 - 1e-9) <= proto <= high * (1 + 1e-9) and not any(math.isclose(v, proto) for v in values):
        values[int(np.argmin([abs(v - proto) for v in values]))] = proto
    return [proto if math.isclose(v, proto, rel_tol=1e-9) else float(v) for v in values]


def candidates(spec, budget: Budget, seed: int = 0) -> list[Candidate]:
    """The layouts a budget searches for ``spec`` (module docstring): rotor × stator pairs whose primary circles are
    within the budget's ratio (both symmetry-family rules, as the sweep), refinements, caps and ball sizes; with a
    baseline, also every layout one choice away from it (packings at its levels, levels, caps 50°–85°, the air gap
    widened by :data:`GAP_SCALES`, the magnets' grade, the winding) and the baseline's parts in every combination
    (:data:`~.ladder.GRADES` × :data:`~.ladder.WINDINGS`: both move the detent-to-winding ratio, docs/synthesis.md)."""
    from ..explore import distinct_names, primary_ratio

    names = distinct_names()
    rotors = budget.rotors or names
    stators = budget.stators or names
    common = dict(samples=budget.samples, capability_samples=budget.capability_samples, seed=seed)
    out: dict = {}
    for D in ball_diameters(spec, budget.diameters):
        for r in rotors:
            for s in stators:
                if primary_ratio(r, s) > budget.primary_ratio:
                    continue
                for rl in budget.rotor_levels:
                    for sl in budget.stator_levels:
                        for cap in budget.caps:
                            c = Candidate(r, rl, s, sl, cap, D, **common)
                            out[c] = None
    base = baseline_layout(spec)
    if base is not None:
        one = dict(rotor=base["rotor"], rotor_level=base["rotor_level"], stator=base["stator"],
                   stator_level=base["stator_level"], cap_deg=base["cap_deg"], sphere_diameter=base["sphere_diameter"],
                   remanence=base.get("remanence", N42))
        out[Candidate(**one, **common)] = None
        if budget.neighbourhood:  # (the quick budget: the baseline itself)
            for c in neighbours(Candidate(**one, **common)):
                out[c] = None
        if budget.parts:
            for grade in GRADES:
                for n in (0,) + WINDINGS:
                    out[Candidate(**(one | {"remanence": grade}), **common, wound_for=n)] = None
    return list(out)


def neighbours(c: Candidate, gaps: tuple[float, ...] = GAP_SCALES) -> list[Candidate]:
    """Every layout one choice away from ``c``: the cap 50°–85° in 5° steps, either refinement 0–2, either packing
    among the distinct ones, the air gap widened by ``gaps``, the magnets' grade (:data:`~.ladder.GRADES`), the
    winding (as built, or rewound for :data:`~.ladder.WINDINGS` coils on)."""
    from dataclasses import replace

    from ..explore import distinct_names

    out = [replace(c, cap_deg=float(cap)) for cap in range(50, 90, 5)]
    out += [replace(c, rotor_level=lv) for lv in range(3)] + [replace(c, stator_level=lv) for lv in range(3)]
    out += [replace(c, rotor=n) for n in distinct_names()] + [replace(c, stator=n) for n in distinct_names()]
    out += [replace(c, gap_scale=k) for k in gaps]
    out += [replace(c, remanence=g) for g in GRADES] + [replace(c, wound_for=n) for n in (0,) + WINDINGS]
    return [x for x in dict.fromkeys(out) if x != c]


def failed_rows(candidate: Candidate, spec, baseline, exc: BaseException) -> list[dict]:
    """The rows of a task that failed on the cluster (status ``failed`` at stage ``cluster``, one per core), so the
    search's counts and store keep it; a worker that died running it (Dask's ``KilledWorker``) is, on one machine,
    almost always one that exceeded its memory limit."""
    try:
        text = str(exc)
    except Exception:  # noqa: BLE001 (an exception that cannot even print itself: its type says enough)
        text = ""
    why = f"{type(exc).__name__}: {text}"
    if type(exc).__name__ == "KilledWorker":
        why = ("the workers running it died (Dask KilledWorker; on one machine: the task exceeded the worker's memory "
               f"limit, the machine's memory over the workers); {text}")
    return [{**_row(candidate, core, spec, baseline), "stage": "cluster", "status": "failed",
             "reason": f"the task failed on the cluster: {why}"} for core in spec.cores]


def _store(out: Path):
    import pyarrow as pa

    from ..explore import ResultStore
    return ResultStore(out / STORE, schema=pa.schema(_schema()))


def _schema():
    import pyarrow as pa

    s, i, f, b = pa.string(), pa.int64(), pa.float64(), pa.bool_()
    return [("key", s), ("spec", s), ("rotor", s), ("rotor_level", i), ("stator", s), ("stator_level", i),
            ("cap_deg", f), ("sphere_diameter_mm", f), ("core", s), ("gap_scale", f), ("stage", s), ("status", s), ("reason", s),
            ("motor", s), ("coils", i), ("rotor_poles", i), ("magnet_diameter_mm", f), ("coil_diameter_mm", f),
            ("air_gap_mm", f), ("magnet_mass_kg", f), ("power_W", f), ("iron_stored", b), ("states", i),
            ("resolution_median_deg", f), ("resolution_p95_deg", f), ("range_fraction", f), ("reaches_all", b),
            ("torque_quantile_Nm", f), ("torque_median_Nm", f), ("torque_positive_fraction", f), ("detent_Nm", f),
            ("failed_coil_torque_Nm", f), ("step_torque_Nm", f), ("time_estimate_s", f), ("relay_steps", i),
            ("relay_steps_on_plan", i), ("relay_executed", b), ("relay_worst_deg", f), ("relay_peak_W", f),
            ("relay_turns_fraction", f),
            ("remanence_T", f), ("ampere_turns", f), ("change", f), ("model", s), ("params", s),
            ("seconds", f), ("worker", s)]


def _submit_all(client, fn, items: list, *, say, bar: Progress, stage: str, what: str, costs: list[float],
                seconds: Callable | None = None, retries: int = 2, priority=None) -> list:
    """Run ``fn(item)`` for every item on ``client``, in order of completion, as the progress ``bar``'s ``stage``
    (the items' estimated ``costs``, seconds of one worker; ``seconds(result)`` a result's measured seconds);
    returns the results in item order (a failed future's exception re-raised as a ComputationError after all
    others finish)."""
    from distributed import as_completed

    from ..errors import ComputationError

    futures = {client.submit(fn, item, pure=False, retries=retries,
                             priority=0 if priority is None else priority(item)): n for n, item in enumerate(items)}
    results: list = [None] * len(items)
    bar.begin(stage, costs, slots=_slots(client))
    say(bar.line(what), done=0, total=len(items))
    lost = []
    for future in as_completed(list(futures)):
        n = futures[future]
        took = None
        if future.status != "finished":
            lost.append(f"{items[n]}: {future.exception()!r}")
        else:
            results[n] = future.result()
            took = None if seconds is None else seconds(results[n])
        future.release()
        bar.advance(costs[n], took)
        say(bar.line(what), done=bar.done, total=bar.total)
    if lost:
        raise ComputationError(f"{len(lost)} of {len(items)} tasks failed on the cluster; first: {lost[0]}")
    return results


def _slots(client) -> int:
    """The tasks the cluster runs at once: its workers' threads."""
    try:
        return max(1, sum(client.nthreads().values()))
    except Exception:  # noqa: BLE001 (a cluster that cannot say: one at a time, the ETA's safe side)
        return 1


class Ladder:
    """The cheap rungs for one spec as a picklable callable, ``Ladder(spec, allow_costly, baseline)(candidate)`` →
    rows (:func:`~spherestep.synthesis.ladder.climb`, then :func:`relay_rung` for relay specs on the same designs,
    their stepper states found once): what each Dask
    task runs."""

    def __init__(self, spec, allow_costly: bool, baseline: dict | None, costly_neighbourhood: bool = False):
        self.spec, self.allow_costly, self.baseline = spec, allow_costly, baseline
        self.neighbourhood = costly_neighbourhood

    def may_solve(self, candidate: Candidate) -> bool:
        """Whether the task may solve an iron table (the budget allows costly iron, or the baseline's wider gaps)."""
        return self.allow_costly or (self.neighbourhood and candidate.gap_scale != 1.0)

    def __call__(self, candidate: Candidate) -> list[dict]:
        rows, designs = climb(candidate, self.spec, self.may_solve(candidate), self.baseline)
        if self.spec.relays:
            for row in rows:
                if row.get("status") == "ok":
                    relay_rung(candidate, row, self.spec, designs.get(row["core"]))
        return rows


SOLVE_COST = 1e15  # cost_estimate of a task that solves an iron table (minutes): above any enumeration's


def pairs(c: Candidate) -> int:
    """``M N``: the rotor poles of ``c`` times the stator caps within its cap (the cost models' one size)."""
    from ..packing import named

    poles = len(named(c.rotor, c.rotor_level))
    caps = named(c.stator, c.stator_level).centers
    return poles * int(np.count_nonzero(-caps[:, 2] >= math.cos(math.radians(c.cap_deg)) - 1e-12))


def _solves(c: Candidate, spec, costly: bool) -> bool:
    """Whether the task of ``c`` may solve an iron table (``costly``, iron allowed, its ball or gap not the
    prototype's)."""
    scaled = c.gap_scale != 1.0 or not math.isclose(c.sphere_diameter, PROTOTYPE["sphere_diameter"], rel_tol=1e-9)
    return costly and "iron" in spec.cores and scaled


def cost_estimate(c: Candidate, spec, costly: bool = False) -> float:
    """A task's relative cost, for submitting the longest first (Dask ``priority``): the state enumeration's,
    ``(M N)²`` for ``M`` rotor poles and ``N`` stator caps within the cap (its candidate alignments grow so;
    measured: the 182-pole layout on 29 coils 247 s, the 92-pole one 68 s, ratio 3.6 against 3.9), twice that
    with a relay rung; a task that may solve an iron table (``costly``, and its ball or gap not the prototype's)
    :data:`SOLVE_COST` more. Only the order matters (the ETA's estimate is :func:`task_seconds`)."""
    cost = float(pairs(c)) ** 2 * (2.0 if spec.relays else 1.0)
    return cost + (SOLVE_COST if _solves(c, spec, costly) else 0.0)


def task_seconds(c: Candidate, spec, costly: bool = False) -> float:
    """A ladder task's estimated seconds of one worker, for the ETA (:mod:`.eta`): as :func:`cost_estimate`,
    :data:`~.eta.ALIGNMENT_SECONDS` × ``(M N)²``, twice that with a relay rung and its many-turn check
    (:func:`~.eta.relay_rung_seconds`), and :data:`~.eta.SOLVE_SECONDS` for a task that may solve an iron table."""
    seconds = ALIGNMENT_SECONDS * float(pairs(c)) ** 2 * (2.0 if spec.relays else 1.0) + relay_rung_seconds(spec.relays)
    return seconds + (SOLVE_SECONDS if _solves(c, spec, costly) else 0.0)


@dataclass(frozen=True)
class SynthesisResult:
    """The answer: the ``spec``, the ``budget`` name, every candidate row (``table``, a DataFrame), the Pareto
    ``front``, the verified ``finalists``, the ``winner`` (a Finalist meeting every requirement, or None), a
    ``statement`` for people (what won and which requirement binds, or that nothing was found in the budget), the
    files ``written`` and ``seconds`` of wall time."""

    spec: object
    budget: str
    table: object
    front: object
    finalists: tuple
    winner: Finalist | None
    statement: str
    written: tuple
    seconds: float
    counts: dict

    def to_dict(self) -> dict:
        return {"spec": self.spec.to_dict(), "budget": self.budget, "candidates": int(len(self.table)),
                "counts": self.counts, "pareto": int(len(self.front)),
                "finalists": [f.to_dict() for f in self.finalists],
                "winner": None if self.winner is None else self.winner.row["key"], "statement": self.statement,
                "seconds": self.seconds, "files": [str(p) for p in self.written]}


def synthesize(spec, out, *, budget: str = "quick", scheduler: str | None = None, workers: int | None = None,
               threads: bool = False, resume: bool = False, seed: int = 0, client=None,
               progress: Callable[..., None] | None = None) -> SynthesisResult:
    """Search designs for ``spec`` (a :class:`~spherestep.synthesis.Spec` or a spec file's path) into the folder
    ``out`` (module docstring; docs/synthesis.md): candidates through the ladder on a Dask cluster (``client``; else
    :func:`spherestep.explore.dask_client` with ``scheduler``/``workers``/``threads``), rows into ``out/results``
    (``resume`` continues from them; without it a folder holding results is refused), the Pareto front, the
    finalists verified (:func:`~spherestep.synthesis.verify`, their design files loaded fresh), the files and the
    HTML report. ``progress(text, done=, total=)`` hears each stage with an ETA."""
    from ..explore import dask_client
    from .spec import Spec, load_spec

    started = time.perf_counter()
    if not isinstance(spec, Spec):
        spec = load_spec(spec)
    if budget not in BUDGETS:
        raise bad_value("budget", f"one of {', '.join(BUDGETS)}", budget)
    seed = checks.count(seed, "seed", 0, expected="a non-negative integer")
    plan = BUDGETS[budget]
    out = Path(out)
    store = _store(out)
    if store.parts() and not resume:
        error = InputError(f"--out {str(out)!r} holds the results of an earlier search; give --resume to continue "
                           "it or another folder")
        error.field = "resume"
        raise error
    say = progress or (lambda text, done=None, total=None: None)
    base = baseline_layout(spec)
    todo = candidates(spec, plan, seed)
    say(f"{len(todo)} layouts × {len(spec.cores)} cores for {spec.name!r} ({budget} budget)")
    if client is None:
        with dask_client(scheduler, workers=workers, threads=threads) as own:
            return _search(spec, plan, out, store, own, todo, base, seed, started, say)
    return _search(spec, plan, out, store, client, todo, base, seed, started, say)


def _climb(client, runner, spec, store, todo, say, bar: Progress, stage: str, passed: list, finalists: int,
           log: Path | None = None) -> None:
    """Evaluate the candidates of ``todo`` that ``store`` lacks on ``client`` as the progress ``bar``'s ``stage``;
    rows stream into ``store``, and each task's time into the lines of ``log`` (:func:`_log_tasks`). ``passed`` collects the measured seconds of the rows that pass, from which the
    later stages are estimated (:func:`~.eta.after_ladder`, for ``finalists`` finalists)."""
    from distributed import as_completed

    stored = store.read()
    done = set(stored["key"]) if len(stored) else set()
    fresh = [c for c in todo if any(c.key(spec.digest, core) not in done for core in spec.cores)]
    if not fresh:
        return
    cost = {c: cost_estimate(c, spec, runner.may_solve(c)) for c in fresh}  # the longest first
    work = {c: task_seconds(c, spec, runner.may_solve(c)) for c in fresh}  # the ETA's estimates (seconds)
    parts = {c: tasks.submit(client, runner, c, cost[c]) for c in sorted(fresh, key=lambda c: -cost[c])}
    waiting = {f: c for c, fs in parts.items() for f in fs[1:]}  # the per-core tasks; the shared one feeds them
    left = {c: len(fs) - 1 for c, fs in parts.items()}
    slots = _slots(client)
    bar.begin(stage, list(work.values()), slots=slots)
    what = f"geometry → states → capability{' → relays' if spec.relays else ''}"
    batch: list = []
    timed: list = []
    last = time.perf_counter()

    def flush():
        store.append(batch)
        _log_tasks(log, timed)

    try:
        for future in as_completed(list(waiting)):
            c = waiting[future]
            left[c] -= 1
            if left[c]:
                continue
            fs = parts.pop(c)
            took = None
            failed = next((f for f in fs[1:] if f.status != "finished"), None)
            if failed is None:
                results = [f.result() for f in fs[1:]]
                rows, took = tasks.merge(spec, results)
                timed.extend(dict(t, stage=stage) for t in tasks.timings(spec, c, results))
                batch.extend(rows)  # its seconds pace the ETA unless it stopped at geometry or may solve
                if all(r.get("stage") == "geometry" for r in rows) or _solves(c, spec, runner.may_solve(c)):
                    took = None
                ok = [float(r["seconds"]) for r in rows if r.get("status") == "ok" and not _missing(r.get("seconds"))]
                if ok:
                    passed.extend(ok)
                    for later, seconds in after_ladder(passed, finalists, slots).items():
                        bar.expect(later, seconds)
            else:  # a task failed on the cluster (e.g. its worker killed for memory): a row per core says so
                batch.extend(failed_rows(c, spec, runner.baseline, failed.exception()))
            for f in fs:
                f.release()
            bar.advance(work[c], took)
            say(bar.line(what), done=bar.done, total=bar.total)
            if len(batch) >= 32 or time.perf_counter() - last > 15:
                flush()
                batch, timed, last = [], [], time.perf_counter()
    finally:
        flush()


def _log_tasks(log: Path | None, timed: list[dict]) -> None:
    """Append ``timed`` (:func:`~.tasks.timings` records) to ``log`` as JSON lines, written in one call after the
    rows they belong to are stored; a reader skips a last line cut short by an interrupt."""
    if log is None or not timed:
        return
    with open(log, "a", encoding="utf-8") as handle:
        handle.write("".join(json.dumps(t, sort_keys=True) + "\n" for t in timed))


def _search(spec, plan: Budget, out: Path, store, client, todo, base, seed, started, say) -> SynthesisResult:

    from .outputs import write_outputs

    runner = Ladder(spec, plan.allow_costly, base, plan.costly_neighbourhood)
    bar = Progress()
    passed: list = []  # the measured seconds of the rows that pass the cheap rungs
    for later, seconds in after_ladder(passed, plan.finalists, _slots(client)).items():
        bar.expect(later, seconds)
    _climb(client, runner, spec, store, todo, say, bar, "ladder", passed, plan.finalists, out / TASKS)
    todo = list(todo)
    keys = {c.key(spec.digest, core) for c in todo for core in spec.cores}
    table = store.read()
    table = table[table["key"].isin(keys)].reset_index(drop=True)
    for n in range(plan.rounds):  # local search around the closest candidates, while none passes
        if (table["status"] == "ok").any():
            break
        seeds = nearest_rows(table, plan.round_seeds)
        gaps = GAP_SCALES if plan.allow_costly else ()  # a wider gap with iron is a table solve each
        more = [c for row in seeds for c in neighbours(Candidate(**json.loads(row["params"])), gaps)]
        more = [c for c in dict.fromkeys(more) if c not in set(todo)]
        if not more:
            break
        say(f"round {n + 1}: none passed; {len(more)} layouts one change from the {len(seeds)} closest")
        _climb(client, runner, spec, store, more, say, bar, f"round {n + 1}", passed, plan.finalists,
               out / TASKS)
        todo += more
        keys |= {c.key(spec.digest, core) for c in more for core in spec.cores}
        table = store.read()
        table = table[table["key"].isin(keys)].reset_index(drop=True)
    counts = {f"{stage}:{status}": int(n) for (stage, status), n in
              table.groupby(["stage", "status"]).size().items()}
    front = pareto(table, spec) if len(table) else table
    chosen = choose_finalists(front, spec, plan.finalists)
    ladder = [0.0 if _missing(v) else float(v) for v in chosen["seconds"]] if len(chosen) else []
    bar.begin("finalists", [BUILD_SECONDS] * len(chosen))
    bar.expect("verification", sum(map(verify_seconds, ladder)) / min(_slots(client), max(len(ladder), 1)))
    bar.expect("report", REPORT_STATES * max(ladder, default=0.0) + REPORT_SECONDS)
    what = f"building the design files of {len(chosen)} finalists"
    say(bar.line(what), done=0, total=len(chosen))
    finalist_dir = out / "finalists"
    finalist_dir.mkdir(parents=True, exist_ok=True)
    texts, paths = [], []
    for n, row in enumerate(chosen.to_dict("records"), start=1):
        begun = time.perf_counter()
        candidate = Candidate(**json.loads(row["params"]))
        design = build(candidate, row["core"], spec, name=f"{spec.name} finalist {n}")
        path = finalist_dir / f"{n:02d}-{row['key']}.yaml"
        design.save(path)
        paths.append(path)
        texts.append(path.read_text(encoding="utf-8"))
        bar.advance(BUILD_SECONDS, time.perf_counter() - begun)
        say(bar.line(what), done=bar.done, total=bar.total)
    cache = out / "verification"
    results: list = [None] * len(texts)
    need = []
    for n, (row, _text) in enumerate(zip(chosen.to_dict("records"), texts)):
        hit = cache / f"{row['key']}-{seed + 1}.json"
        if hit.is_file():
            results[n] = _verification_from(json.loads(hit.read_text(encoding="utf-8")))
        else:
            need.append(n)
    if need:
        job = _Verify(spec, seed + 1, plan)
        got = _submit_all(client, job, [(texts[n], str(paths[n])) for n in need], say=say, bar=bar,
                          stage="verification", what=f"full simulation of {len(need)} finalists",
                          costs=[verify_seconds(ladder[n]) for n in need], seconds=lambda v: v.seconds)
        from ..atomic import write_text

        cache.mkdir(parents=True, exist_ok=True)
        for n, v in zip(need, got):
            results[n] = v
            write_text(cache / f"{chosen.iloc[n]['key']}-{seed + 1}.json", json.dumps(v.to_dict(), indent=1))
    finalists = tuple(Finalist({k: _json(v) for k, v in row.items()}, str(p), v)
                      for row, p, v in zip(chosen.to_dict("records"), paths, results))
    closest = closest_row(table, spec) if not finalists else None
    winner, statement = _answer(spec, finalists, counts, len(table), closest)
    if closest is not None:  # nothing to verify: the report shows the closest candidate
        design = build(Candidate(**json.loads(closest["params"])), closest["core"], spec,
                       name=f"{spec.name} closest candidate")
        path = finalist_dir / f"closest-{closest['key']}.yaml"
        design.save(path)
        paths.append(path)
    shown = (winner or (finalists[0] if finalists else None))  # the report's design (write_outputs)
    shown = shown.row.get("seconds") if shown is not None else (closest or {}).get("seconds")
    bar.begin("report", [REPORT_STATES * (0.0 if _missing(shown) else float(shown)) + REPORT_SECONDS])
    say(bar.line("writing the answer and the report"))
    result = SynthesisResult(spec, plan.name, table, front, finalists, winner, statement, (), 0.0, counts)
    written = write_outputs(result, out, samples=plan.samples, closest=paths[-1] if closest is not None else None)
    final = SynthesisResult(spec, plan.name, table, front, finalists, winner, statement,
                            tuple(paths) + tuple(written), time.perf_counter() - started, counts)
    from ..atomic import write_text

    write_text(out / "synthesis.json", json.dumps(final.to_dict(), indent=1))  # now with the files and the time
    return final


class _Verify:
    def __init__(self, spec, seed: int, plan: Budget):
        self.spec, self.seed, self.plan = spec, seed, plan

    def __call__(self, item):
        from .verify import verify

        text, source = item
        return verify(text, self.spec, seed=self.seed, samples=self.plan.verify_samples,
                      capability_samples=self.plan.verify_capability, holds=self.plan.holds, source=source)


def _verification_from(data: dict):
    from .verify import Check, Verification

    return Verification(data["design"], tuple(Check(c["name"], c["required"], c["achieved"], c["met"], c["margin"])
                                              for c in data["checks"]), data["numbers"], data["seed"],
                        data["seconds"])
