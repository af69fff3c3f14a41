"""The iron-aware relay planner: commutation on the true equilibria of the design's own energy (issue 39).

On an iron-cored stator the rotor does not rest on the geometric states: the cores' detent ``b(R) = τ(R, 0)``
(up to 85 % of the winding's pull on the prototype) moves every well. Here a relay *mask* is a set of coils with
polarities ``c ∈ {−1, 0, +1}^N`` (currents per unit of the nominal current, the supply's voltage across the
winding), and the states are the minima of the model's whole energy ``E(R, c)`` — detent + winding + coupling,
whatever :func:`spherestep.magnetics.design_model` gives — not the geometric states.

One step, from the current equilibrium ``R̃`` under the current mask, towards the desired ``R_i``:

* **candidates** — the current mask (stay); the coil sets of the 8 stepper states nearest ``R_i`` and of the 8
  reachable states (within ``max_step`` of ``R̃``) nearest it, each trimmed to the ``max_coils`` pairs closest at
  ``R_i`` (as :func:`~.potential_planner.plan_potential`), alone and *with the coils energised now reversed* (a
  push from behind); and *pull masks* (:func:`_pulls`): at poses along the step, every coil's nearest pole, the 3,
  6 and all the supply powers best aligned. Never more coils than the supply powers, ``⌊P / (V I_n)⌋``;
* **landing** — the minimum the energy descends to from ``R̃`` under each (:func:`spherestep.statics.descend`):
  the minimum whose basin holds the current pose. It must be a strict minimum (Hessian positive definite, softer
  than ``min_stiffness`` refused), within one ``max_step`` of ``R̃``, and strictly nearer ``R_i`` than ``R̃`` is;
* **margins** — of those, nearest ``R_i`` first, the first whose landing is robust: descents from ``R̃`` turned
  by ``±margin`` about the three fixed axes (the pose is known only to the model's error and the open loop's
  drift) and from the landing overshot by ``overshoot`` of the step along its own axis (the rotor arrives with
  momentum) all end within ``land_tol`` of the same minimum; on each of ``plants`` (optional) the descents from
  within the margin end within ``plant_tol`` (default the margin) of it; and the tuned rotor (``tuning``,
  :func:`spherestep.dynamics.iron_tuning`) released at rest at ``R̃`` ends its dwell within :data:`SETTLE_TOL` of
  it (one compiled integration, stopped once the rotor is trapped: :meth:`_Landscape.settles`); with ``thermal``
  and ``rate`` (optional) only masks that keep every coil within the thermal limits, the plan streamed at
  ``rate``;
* **intermediate masks** — when no candidate both advances and is robust, a two-mask step: a robust candidate
  that does not advance, then from its minimum one that does (status ``intermediate: …``);
* **the last resort** — every single coil and pair among the :data:`FACING` coils nearest a pole, either polarity;
* otherwise the rotor holds (status ``hold``) or, when the target has run more than a step beyond the states
  nearest it, the step is ``blocked: <why>`` (:func:`_why`). At the end up to ten ``settle`` steps walk on while a
  mask still advances.

The plan's ``achieved`` orientations are these minima, so a rotor simulated on the same model settles on them;
:func:`spherestep.drive.many_turns` judges a plan by exactly that. The plan's ``planner`` is ``"iron"``.

The planner stays on the motor floor (docs/conventions.md, the house map): it imports the statics' descent and the
geometry, and what it checks against the rooms above is handed in — the rotor's settling by the ``tuning``
(:meth:`spherestep.dynamics.Tuning.released`), the coils' heat by the ``thermal`` limits' guard
(:meth:`spherestep.hardware.ThermalLimits.guard`), the model by the caller.
"""

from __future__ import annotations

import math

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from .geometric import DEFAULT_CANDIDATES, MAX_SETTLE_STEPS, SETTLE, start_state
from .plan import Plan
from .potential_planner import _activations, _assemble, _trim
from .trajectory import check_targets
from .._fast.threads import single_blas_thread

DEFAULT_MAX_COILS = 4  # coils of one state's set (before the reversed push coils)
MARGIN = math.radians(1.5)  # rad: the pose's uncertainty a landing must tolerate
OVERSHOOT = 0.3  # of the step's length: the momentum a landing must absorb
LAND_TOL = math.radians(0.1)  # rad: descents from the margin's starts agree within this
SETTLE_TOL = math.radians(0.25)  # rad: the tuned rotor's landing after one dwell, half the verdict's 0.5°
ROBUST_TRIES = 6  # candidates (nearest the target first) checked for margins per step
INTERMEDIATE = "intermediate: a non-advancing mask first, to reach one that advances"


def supply_coils(limits) -> int:
    """The most coils the supply powers at once: ``⌊P / (V I_n)⌋`` (a relay coil draws ``V I_n``)."""
    return max(1, int(math.floor(limits.supply_power / limits.relay_power + 1e-9)))


class _Landscape:
    """The model's minima as seen from one pose: batched descents and the margin test (module docstring).

    Each answer — a mask's landing from a pose, its margins, its settling — depends only on that pose and mask, so
    it is remembered for the plan (keyed by their bytes): a rotor held at one pose over several steps, or a mask
    offered again among the intermediate steps' candidates, costs no second descent."""

    def __init__(self, model, reach: float, margin: float, overshoot: float, land_tol: float, stiffness: float,
                 tuning=None, plants=(), plant_tol: float | None = None):
        from ..statics import descend

        self.plants = tuple(plants)
        self.plant_tol = max(margin, land_tol) if plant_tol is None else plant_tol
        self.model, self.reach, self.descend, self.stiffness = model, reach, descend, stiffness
        self.tuning = tuning
        self.margin, self.overshoot, self.land_tol = margin, overshoot, land_tol
        self.jiggle = so3.exp(margin * np.concatenate([np.eye(3), -np.eye(3)]))  # (6, 3, 3)
        self.landings, self.kept, self.settled = {}, {}, {}  # (pose, mask[, R]) -> (R, ok, softest), bool, bool

    @staticmethod
    def _keys(here: np.ndarray, c: np.ndarray) -> list[bytes]:
        pose = here.tobytes()
        return [pose + row.tobytes() for row in c]

    def land(self, here: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(R (B, 3, 3), ok (B,))``: the minimum descended to from ``here`` under each mask ``c (B, N)``; ``ok``
        where it converged to a strict minimum within ``reach`` of ``here``."""
        keys = self._keys(here, c)
        todo = [b for b, key in enumerate(keys) if key not in self.landings]
        if todo:
            R, _, _, H, _, converged = self.descend(self.model, np.repeat(here[None], len(todo), axis=0), c[todo])
            ok = converged & (so3.distance(R, here, trusted=True) <= self.reach)
            softest = np.full(len(todo), -np.inf)
            softest[ok] = np.linalg.eigvalsh(H[ok])[:, 0]
            ok &= softest > self.stiffness
            for j, b in enumerate(todo):
                self.landings[keys[b]] = (R[j], bool(ok[j]), float(softest[j]))
        found = [self.landings[key] for key in keys]
        return np.array([f[0] for f in found]).reshape(-1, 3, 3), np.array([f[1] for f in found], dtype=bool)

    def robust(self, here: np.ndarray, c: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Whether each landing ``R (B, 3, 3)`` of mask ``c (B, N)`` from ``here`` (:meth:`land`'s) keeps its
        margins: descents from ``here`` turned ``±margin`` about x, y, z and from ``R`` overshot along its step
        all end within ``land_tol`` of ``R``; with ``plants``, their descents from within the margin of ``here``
        within ``plant_tol`` (default the margin) of it."""
        keys = [key + landing.tobytes() for key, landing in zip(self._keys(here, c), R)]
        todo = np.array([b for b, key in enumerate(keys) if key not in self.kept], dtype=np.int64)
        if len(todo):
            for b, good in zip(todo, self._robust(here, c[todo], R[todo])):
                self.kept[keys[b]] = bool(good)
        return np.array([self.kept[key] for key in keys], dtype=bool)

    def _robust(self, here: np.ndarray, c: np.ndarray, R: np.ndarray) -> np.ndarray:
        B = len(c)
        step = np.array([so3.log_single(m) for m in R @ here.T]).reshape(-1, 3)  # fixed frame: R = exp(step) here
        starts = np.concatenate([np.broadcast_to(self.jiggle @ here, (B, 6, 3, 3)),
                                 (so3.exp(self.overshoot * step) @ R)[:, None]], axis=1)  # (B, 7, 3, 3)
        ends, _, _, _, _, converged = self.descend(self.model, starts.reshape(-1, 3, 3).copy(),
                                                   np.repeat(c, 7, axis=0))
        close = converged & (so3.distance(ends, np.repeat(R, 7, axis=0), trusted=True) <= self.land_tol)
        ok = close.reshape(B, 7).all(axis=1)
        for plant in self.plants:  # the pose within the margin of here, on every plant: within plant_tol of R
            if not ok.any():
                break
            near = np.concatenate([here[None], self.jiggle @ here])  # (7, 3, 3)
            ends, _, _, _, _, converged = self.descend(plant, np.tile(near, (B, 1, 1)), np.repeat(c, 7, axis=0))
            apart = so3.distance(ends, np.repeat(R, 7, axis=0), trusted=True)
            close = converged & (apart <= self.plant_tol)
            ok &= close.reshape(B, 7).all(axis=1)
        return ok

    def settles(self, here: np.ndarray, c: np.ndarray, R: np.ndarray) -> bool:
        """Whether the tuned rotor, released at rest at ``here`` under mask ``c``, ends its dwell within
        :data:`SETTLE_TOL` of ``R``, :meth:`land`'s landing (always true without a tuning).

        A model with compiled terms is integrated by :func:`spherestep._fast.settle.settle` (the tuning's
        :meth:`~spherestep.dynamics.Tuning.released` with a ``trap``), which stops once the rotor is *trapped*:
        within ``SETTLE_TOL / 4`` of ``R`` with ``½ I|ω|² + E(R_t) − E(R) ≤ ½ k (SETTLE_TOL / 4)²`` (``k`` the
        landing's softest stiffness). Energy only falls under damping and friction, so the rotor stays in that
        sublevel set of the well — within ``SETTLE_TOL / 4`` of ``R`` while the well is quadratic that far, a
        factor 4 of slack — and the full dwell ends within ``SETTLE_TOL`` too (``tests/test_iron_planner.py``
        checks the verdicts against the full dwell). Other models run the dwell."""
        if self.tuning is None:
            return True
        key = self._keys(here, c[None])[0]
        landing = self.landings.get(key)
        key += R.tobytes()
        if key in self.settled:
            return self.settled[key]
        softest = landing[2] if landing is not None and np.array_equal(landing[0], R) else 0.0  # R: the landing
        trap = (R, SETTLE_TOL / 4, 0.5 * softest * (SETTLE_TOL / 4) ** 2) if softest > 0 else None
        end = self.tuning.released(self.model, here, c, trap)
        self.settled[key] = good = bool(so3.distance(end, R, trusted=True) <= SETTLE_TOL)
        return good

    def first(self, here: np.ndarray, masks: np.ndarray, R: np.ndarray, order: np.ndarray) -> int:
        """The first of the candidates ``order`` (indices into ``masks``/``R``) whose landing keeps its margins and
        settles; −1 if none."""
        for b in order:  # one at a time: the nearest usually passes
            if self.robust(here, masks[b:b + 1], R[b:b + 1])[0] and self.settles(here, masks[b], R[b]):
                return int(b)
        return -1


LEADS = (0.5, 1.0, 1.5)  # poses along the step, in units of the step to the target, that the pull masks aim at


def _pulls(design, here, target, most) -> np.ndarray:
    """Masks drawing the rotor along the step: at each lead pose ``exp(f ω) R̃`` (``ω = log(R_i R̃ᵀ)``, ``f`` in
    :data:`LEADS`) every coil's nearest pole (polarity its pole's), the 3, 6 and ``most`` best aligned coils."""
    u, v, pol = design.rotor.centers, design.stator.centers, design.polarity
    omega = so3.log_single(target @ here.T)
    poses = so3.exp(np.multiply.outer(LEADS, omega)) @ here  # (L, 3, 3)
    cos = np.einsum("lja,ka->lkj", np.einsum("lab,jb->lja", poses, u), v)  # (L, N, M): (P u_j)·v_k
    pole = np.argmax(cos, axis=2)  # (L, N) each coil's nearest pole
    best = np.take_along_axis(cos, pole[..., None], axis=2)[..., 0]
    order = np.argsort(-best, axis=1)
    out = []
    for n in sorted({min(3, most), min(6, most), most}):
        for lead in range(len(LEADS)):
            c = np.zeros(len(v))
            keep = order[lead, :n]
            c[keep] = pol[pole[lead, keep]]
            out.append(c)
    return np.array(out)


FACING = 12  # the coils nearest a pole that the last resort's singles and pairs use


def _pairs(design, here) -> np.ndarray:
    """Masks ``(M, N)`` of every single coil and every pair of coils among the :data:`FACING` coils nearest a pole
    at ``here``, each coil with either polarity (12 coils: 288 masks)."""
    cos = (here @ design.rotor.centers.T).T @ design.stator.centers.T  # (M poles, N coils)
    facing = np.argsort(-cos.max(axis=0), kind="stable")[:FACING]
    N, out = len(design.stator), []
    for a in range(len(facing)):
        for sa in (1.0, -1.0):
            c = np.zeros(N)
            c[facing[a]] = sa
            out.append(c)
            for b in range(a + 1, len(facing)):
                for sb in (1.0, -1.0):
                    d = c.copy()
                    d[facing[b]] = sb
                    out.append(d)
    return np.array(out).reshape(-1, N)


def _masks(design, states, target, here, current, near, reach, candidates, max_coils, most) -> np.ndarray:
    """Candidate masks ``(M, N)``: the current one first, then each candidate state's trimmed coil set, alone and
    with the coils energised now (not in the set) reversed, within ``most`` coils (module docstring)."""
    around = states.within(here, reach)
    if len(around):
        around = around[np.argsort(so3.distance(states.rotations[around], target, trusted=True))[:candidates]]
    ids = np.unique(np.concatenate([near, around]).astype(np.int64))
    ranked = bool(states.counts[ids].max() > max_coils)
    sets = _activations(states, design, target, ids, max_coils, ranked)
    push = np.where(sets == 0, -current, 0.0)
    pushed = sets + push
    fits = np.count_nonzero(pushed, axis=1) <= most
    masks = np.concatenate([current[None], sets, pushed[fits & (np.count_nonzero(push, axis=1) > 0)],
                            _pulls(design, here, target, most)])
    first = {}  # each distinct mask's first row (the bytes of ``+ 0.0``: −0 and 0 are one current)
    for b, row in enumerate(masks + 0.0):
        first.setdefault(row.tobytes(), b)
    return masks[sorted(first.values())]


@single_blas_thread
def plan_iron(design, targets, model, *, limits=None, max_coils: int = DEFAULT_MAX_COILS,
              candidates: int = DEFAULT_CANDIDATES, max_step: float | None = None, margin: float = MARGIN,
              overshoot: float = OVERSHOOT, land_tol: float = LAND_TOL, min_stiffness: float = 0.0,
              tuning=None, plants=(), plant_tol: float | None = None, thermal=None, rate: float | None = None,
              start: int | None = None) -> Plan:
    """Commutate ``targets (n+1, 3, 3)`` on the minima of ``model``'s energy (module docstring).

    ``model``: a :class:`~spherestep.statics.TorqueModel` of ``design`` (the iron model of
    :func:`spherestep.magnetics.design_model`); ``limits``: its :class:`~spherestep.control.DriveLimits` (the
    supply caps the coils energised at once; default no cap beyond ``2 max_coils``); ``margin`` (rad),
    ``overshoot`` (fraction of a step) and ``land_tol`` (rad): the landing's margins; ``plants``: torque models the
    plan must also hold on (e.g. :func:`spherestep.magnetics.mismatch.scaled_model`'s winding ×0.85, detent ×1.2):
    from within ``margin`` of the current pose each plant's minimum under the mask lies within ``plant_tol``
    (rad, default ``max(margin, land_tol)``: the next step starts inside its margin again; the verdict's 0.5° or
    less asks for masks whose minimum the plants barely move) of the planned one; ``start``: the stepper state
    whose coils hold the rotor first (default nearest ``targets[0]``); ``thermal`` (a
    :class:`spherestep.hardware.ThermalLimits`) and ``rate`` (Hz): the plan will be streamed at ``rate``, so only
    masks that keep every coil within those limits are chosen (a mask that would break them is passed over, as
    one without margins; a step that only a hold fits keeps its coils and ``run`` refuses the plan, naming it);
    ``tuning`` (a :class:`spherestep.dynamics.Tuning`, :func:`spherestep.dynamics.iron_tuning` for the iron): the
    relay rotor each landing must settle on within its dwell (None: no settling check)."""
    from ..statics import equilibrium, is_torque_model

    targets = check_targets(targets)
    max_coils = checks.count(max_coils, "max_coils", minimum=2,
                             expected="an integer of at least 2 (two poles fix the rotor)")
    candidates = checks.count(candidates, "candidates", expected="a positive integer")
    margin = checks.non_negative(margin, "margin", "a non-negative angle in radians")
    overshoot = checks.non_negative(overshoot, "overshoot", "a non-negative fraction of a step")
    land_tol = checks.positive(land_tol, "land_tol", "a positive angle in radians")
    states = design.states()
    if len(states) == 0:
        raise bad_value("design", "a design with stepper states", "none")
    most = 2 * max_coils if limits is None else supply_coils(limits)
    if most < 2:
        raise bad_value("limits", "a supply that powers at least two coils at once (two poles fix the rotor)",
                        f"{most} coil")
    max_coils = min(max_coils, most)
    reach = design.max_step if max_step is None else checks.positive(max_step, "max_step")
    first = start_state(states, targets[0]) if start is None else int(start)
    coils = _trim(states.held(first), design, states.rotations[first], max_coils)
    current = design.coil_currents(coils)
    here = rest_pose(model, equilibrium(model, states.rotations[first], current), current)  # checks model and N
    min_stiffness = checks.non_negative(min_stiffness, "min_stiffness", "a non-negative stiffness in N·m/rad")
    plants = tuple(plants)
    for n, plant in enumerate(plants):
        if not is_torque_model(plant) or plant.coil_count != model.coil_count:
            raise bad_value(f"plants[{n}]", f"a torque model of the design's {model.coil_count} coils",
                            type(plant).__name__)
    if plant_tol is not None:
        plant_tol = checks.positive(plant_tol, "plant_tol", "a positive angle in radians")
    land = _Landscape(model, reach, margin, overshoot, land_tol, min_stiffness, tuning, plants, plant_tol)
    _, near = states.nearest(targets, k=candidates)
    rows = [(targets[0], here, coils, "ok")]
    if (thermal is None) != (rate is None):
        raise bad_value("thermal" if thermal is None else "rate", "given with the other (the limits, the step rate)",
                        None)
    fits = _fits_always if thermal is None else _Heat(thermal, checks.positive(rate, "rate", "a step rate in Hz"),
                                                      rows).fits
    for i in range(1, len(targets)):
        here, current = _step(design, states, land, rows, targets[i], here, current, near[i], reach, candidates,
                              max_coils, most, fits=fits)
    last_near = states.nearest(targets[-1], k=candidates)[1]
    for _ in range(MAX_SETTLE_STEPS):  # the rotor lags at the end: walk on while a mask still advances
        before = len(rows)
        here, current = _step(design, states, land, rows, targets[-1], here, current, last_near, reach, candidates,
                              max_coils, most, status=SETTLE, fits=fits)
        if rows[-1][3] != SETTLE:
            del rows[before:]
            break
    plan = _assemble(design, rows)
    plan.planner = "iron"
    return plan


def rest_pose(model, eq, current) -> np.ndarray:
    """Where the rotor rests under the first mask: ``eq``'s end when it is a strict minimum; else (a saddle, on
    which a simulated rotor at rest would not stay) the lowest strict minimum descended to from it turned ±1° about
    x, y and z; ``eq``'s end if none is."""
    if eq.is_minimum:
        return eq.rotation
    from ..statics import equilibrium

    turns = so3.exp(math.radians(1.0) * np.concatenate([np.eye(3), -np.eye(3)]))
    near = equilibrium(model, turns @ eq.rotation, current)
    ok = np.flatnonzero(near.is_minimum)
    return near.rotation[ok[np.argmin(near.energy[ok])]] if len(ok) else eq.rotation


def _fits_always(*masks) -> bool:
    return True


class _Heat:
    """The coils' thermal record along the plan being made: which masks may come next, the plan streamed at
    ``rate`` Hz under ``limits`` (:class:`spherestep.hardware.ThermalLimits`; its guard's rule, as ``check_plan``
    applies it: frame ``i`` held from ``i / rate`` for ``1 / rate``)."""

    def __init__(self, limits, rate: float, rows: list):
        self.guard, self.period, self.rows, self.done = limits.guard(), 1.0 / rate, rows, 0

    def fits(self, *masks) -> bool:
        """Whether the ``masks`` may be the plan's next frames, in that order."""
        import copy

        for i in range(self.done, len(self.rows)):
            self.guard.record(self.rows[i][2], i * self.period)
        self.done = len(self.rows)
        guard = copy.deepcopy(self.guard) if len(masks) > 1 else self.guard
        for n, c in enumerate(masks):
            on, t = np.flatnonzero(c).tolist(), (len(self.rows) + n) * self.period
            if not guard.allows(on, t, self.period):
                return False
            if n + 1 < len(masks):
                guard.record(on, t)
        return True


def _coil_map(c: np.ndarray) -> dict[int, int]:
    return {int(k): int(np.sign(c[k])) for k in np.flatnonzero(c)}


def _step(design, states, land: _Landscape, rows: list, target, here, current, near, reach, candidates, max_coils,
          most, status: str = "ok", fits=_fits_always):
    """Append one step's row(s) towards ``target``; returns the new ``(here, current)`` (module docstring).
    ``fits``: whether masks may come next (the coils' heat, :class:`_Heat`)."""
    masks = _masks(design, states, target, here, current, near, reach, candidates, max_coils, most)
    R, ok = land.land(here, masks)
    gap = so3.distance(R, target, trusted=True)
    stay = float(so3.distance(here, target, trusted=True))
    ahead = _best(np.flatnonzero(ok & (gap < stay - 1e-9)), gap, lambda b: fits(masks[b]))
    b = land.first(here, masks, R, ahead)
    if b >= 0:
        rows.append((target, R[b], _coil_map(masks[b]), status))
        return R[b], masks[b]
    # intermediate masks: a robust landing that does not advance, then one that does from there
    side = np.flatnonzero(ok & (so3.distance(R, here, trusted=True) > land.land_tol))
    for b in _best(side, gap, lambda b: fits(masks[b])):
        if land.first(here, masks, R, np.array([b])) < 0:
            continue
        masks2 = _masks(design, states, target, R[b], masks[b], near, reach, candidates, max_coils, most)
        R2, ok2 = land.land(R[b], masks2)
        gap2 = so3.distance(R2, target, trusted=True)
        ahead2 = _best(np.flatnonzero(ok2 & (gap2 < stay - 1e-9)), gap2,
                       lambda n, first=masks[b], then=masks2: fits(first, then[n]))
        b2 = land.first(R[b], masks2, R2, ahead2)
        if b2 >= 0:
            rows.append((target, R[b], _coil_map(masks[b]), INTERMEDIATE))
            rows.append((target, R2[b2], _coil_map(masks2[b2]), status))
            return R2[b2], masks2[b2]
    # the last resort: every single coil and pair of coils facing a pole, either polarity
    wide = _pairs(design, here)
    R3, ok3 = land.land(here, wide)
    gap3 = so3.distance(R3, target, trusted=True)
    b = land.first(here, wide, R3, _best(np.flatnonzero(ok3 & (gap3 < stay - 1e-9)), gap3, lambda n: fits(wide[n])))
    if b >= 0:
        rows.append((target, R3[b], _coil_map(wide[b]), status))
        return R3[b], wide[b]
    masks, R, ok = np.concatenate([masks, wide]), np.concatenate([R, R3]), np.concatenate([ok, ok3])
    gap = np.concatenate([gap, gap3])
    ahead = np.flatnonzero(ok & (gap < stay - 1e-9))
    ahead = ahead[np.argsort(gap[ahead], kind="stable")][:ROBUST_TRIES]
    nearest = float(states.nearest(target, k=1)[0].ravel()[0])
    blocked = stay > nearest + reach
    rows.append((target, here, _coil_map(current), f"blocked: {_why(land, here, masks, R, ok, ahead)}" if blocked
                 else "hold"))
    return here, current


def _best(found: np.ndarray, gap: np.ndarray, fits) -> np.ndarray:
    """The candidates ``found`` nearest the target first (``gap``), those that ``fits``, the first
    :data:`ROBUST_TRIES`."""
    ordered = found[np.argsort(gap[found], kind="stable")]
    return np.array([b for b in ordered if fits(b)], dtype=np.int64)[:ROBUST_TRIES]


def _why(land: _Landscape, here, masks, R, ok, ahead) -> str:
    """Why no mask advances from ``here``, for the ``blocked`` status: none of the masks' minima is ahead, or the
    nearest advancing minimum's basin holds only a smaller margin (the largest of 1, 0.5, 0.25° tried), or its
    margins hold but the tuned rotor does not settle on it within the dwell."""
    if not len(ahead):
        return (f"none of {len(masks)} masks has a minimum ahead ({int(ok.sum())} have a strict minimum within a "
                f"step, all behind or beside the rotor)")
    b = ahead[:1]
    if land.robust(here, masks[b], R[b])[0]:
        return (f"the nearest advancing minimum ({math.degrees(float(so3.distance(R[b[0]], here))):.1f}° away) keeps "
                f"its margins but the rotor does not settle on it within the dwell")
    kept = 0.0
    for margin in np.radians([1.0, 0.5, 0.25]):
        narrow = _Landscape(land.model, land.reach, float(margin), land.overshoot, land.land_tol, land.stiffness)
        if narrow.robust(here, masks[b], R[b])[0]:
            kept = float(margin)
            break
    return (f"the nearest advancing minimum's basin holds a {math.degrees(kept):.2f}° margin, not "
            f"{math.degrees(land.margin):.2f}°")
