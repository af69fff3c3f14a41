"""The commutation plan: per step the coils to energise, with polarity, and where the rotor should land.

A :class:`Plan` is what every planner returns and what the hardware streams. Its file format (JSON,
``"format": "spherestep-plan"``, ``"version": 2``) is documented in ``docs/commutation.md``; CSV holds the
same steps one per row with the relay masks. Version 2 records the design's fingerprint (its coil and magnet
numbering, :attr:`~spherestep.motor.MotorDesign.fingerprint`); version 1 plans, whose coil indices may have been
numbered by the planning machine's CPU (issue 35), are refused with a line saying to plan again.

Relay channels: coil ``k`` has an *enable* channel and a *polarity* channel (``channel_map[k] = (enable,
polarity)``). A step's ``enable_mask`` has bit ``enable`` set for every energised coil; ``polarity_mask``
has bit ``polarity`` set for every coil driven with polarity −1 (reversed current). Bit ``b`` is ``1 << b``.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from .. import checks, so3
from ..atomic import write_text
from ..channels import as_channel_map
from ..errors import bad_value

FORMAT = "spherestep-plan"
VERSION = 2
AGAIN = "plan the turn again with `spherestep plan` (or commutation.turn)"


def coil_masks(coils: dict[int, int], channel_map: np.ndarray) -> tuple[int, int]:
    """``(enable_mask, polarity_mask)`` of a coil → ±1 map for the ``(N, 2)`` channel map (module docstring)."""
    enable = polarity = 0
    for coil, sign in coils.items():
        enable |= 1 << int(channel_map[coil, 0])
        if sign < 0:
            polarity |= 1 << int(channel_map[coil, 1])
    return enable, polarity


@dataclass
class Step:
    """One commutation step.

    ``target``/``achieved``: desired ``R_i`` and the stepper state ``R̃_i`` (3×3); ``error``: Park distance
    between them (radians); ``coils``: stator index → polarity ±1 (energised coils); ``held``: (rotor pole,
    stator coil) pairs that hold ``R̃_i``; ``next_pole``: the rotor pole to be attracted next (hatched in
    Fig. 10), or None; ``status``: ``"ok"`` (moved), ``"hold"`` (stays: the previous state is still the
    best) or ``"blocked: <why>"`` (no reachable state).
    """

    index: int
    target: np.ndarray
    achieved: np.ndarray
    error: float
    coils: dict[int, int]
    held: list[tuple[int, int]] = field(default_factory=list)
    next_pole: int | None = None
    status: str = "ok"

    def masks(self, channel_map: np.ndarray) -> tuple[int, int]:
        """``(enable_mask, polarity_mask)`` of this step for the given ``(N, 2)`` channel map."""
        return coil_masks(self.coils, channel_map)


@dataclass(frozen=True)
class PlanSummary:
    """Counts and errors of a plan (angles in radians; :meth:`to_dict` gives degrees).

    ``steps`` counts the moves asked for (``len(plan.steps) − 1``: step 0 is the start, which a driver also
    holds, so it streams ``steps + 1`` frames); ``moves`` the steps whose state differs from the previous one;
    ``error_*``: Park distance between target and achieved state (median, max, final); ``target_step_max``: the
    largest desired step ``D(R_{i−1}, R_i)``; ``warnings``: what makes the plan untrustworthy although it exists
    (a desired step beyond the design's max step, blocked steps, detours).
    """

    steps: int
    moves: int
    settle_steps: int
    holds: int
    detours: int
    blocked: int
    error_median: float
    error_max: float
    error_final: float
    target_step_max: float
    max_coils_per_step: int
    warnings: tuple[str, ...] = ()

    def to_dict(self, degrees: bool = True) -> dict:
        """JSON-ready dict; angles as ``…_deg`` in degrees (or ``…_rad`` with ``degrees=False``)."""
        out = asdict(self)
        for key in ("error_median", "error_max", "error_final", "target_step_max"):
            value = out.pop(key)
            out[f"{key}_deg" if degrees else f"{key}_rad"] = math.degrees(value) if degrees else value
        out["warnings"] = list(self.warnings)
        return out

    def line(self) -> str:
        """One line for people: counts, errors (degrees) and warnings."""
        text = (f"{self.steps} steps: {self.moves} moves, {self.holds} holds, {self.detours} detours, "
                f"{self.blocked} blocked; error max {math.degrees(self.error_max):.2f}°, final "
                f"{math.degrees(self.error_final):.2f}°")
        return text + "".join(f"; WARNING: {w}" for w in self.warnings)


@dataclass
class Plan:
    """A sequence of :class:`Step` for one design; ``failures`` lists ``(step index, reason)``."""

    steps: list[Step]
    coil_count: int
    channel_map: np.ndarray
    design: str = "design"
    planner: str = "geometric"
    design_fingerprint: str | None = None

    def check_design(self, design) -> None:
        """Refuse to drive ``design`` with a plan made for another motor or numbering (InputError naming
        ``plan.design_fingerprint``)."""
        from ..motor import check_fingerprint

        check_fingerprint(design, self.design_fingerprint, "plan.design_fingerprint", AGAIN)

    @property
    def achieved(self) -> np.ndarray:
        """``(n+1, 3, 3)`` achieved orientations ``R̃_i``."""
        return np.array([s.achieved for s in self.steps])

    @property
    def targets(self) -> np.ndarray:
        """``(n+1, 3, 3)`` desired orientations ``R_i``."""
        return np.array([s.target for s in self.steps])

    @property
    def errors(self) -> np.ndarray:
        """Park distance (radians) between target and achieved, per step."""
        return np.array([s.error for s in self.steps])

    @property
    def failures(self) -> list[tuple[int, str]]:
        """Steps at which the planner could not move as the target required (status ``blocked: …``)."""
        return [(s.index, s.status) for s in self.steps if s.status.startswith("blocked")]

    def summary(self, max_step: float | None = None) -> PlanSummary:
        """Counts, errors and warnings of this plan (:class:`PlanSummary`); with the design's ``max_step``
        (radians) a desired step longer than it is a warning."""
        err = self.errors
        achieved, targets = self.achieved, self.targets
        target_step = float(np.max(so3.distance(targets[:-1], targets[1:]))) if len(targets) > 1 else 0.0
        detours = sum(s.status.startswith("detour") for s in self.steps)
        blocked = len(self.failures)
        warnings = []
        if max_step is not None and target_step > max_step + 1e-9:
            warnings.append(f"a desired step of {math.degrees(target_step):.2f}° exceeds the design's max step "
                            f"{math.degrees(max_step):.2f}°; use more steps")
        if blocked:
            warnings.append(f"{blocked} steps blocked")
        if detours:
            warnings.append(f"{detours} detours (the target's nearest states were out of reach)")
        return PlanSummary(
            steps=len(self.steps) - 1,
            moves=int(np.sum(so3.distance(achieved[:-1], achieved[1:]) > 0)),
            settle_steps=sum(s.status.startswith("settle") for s in self.steps),
            holds=sum(s.status == "hold" for s in self.steps), detours=detours, blocked=blocked,
            error_median=float(np.median(err)), error_max=float(err.max()), error_final=float(err[-1]),
            target_step_max=target_step, max_coils_per_step=max(len(s.coils) for s in self.steps),
            warnings=tuple(warnings))

    def to_dict(self) -> dict:
        """The JSON-ready form (see the module docstring)."""
        steps = []
        for s in self.steps:
            enable, polarity = s.masks(self.channel_map)
            steps.append(
                {
                    "index": s.index,
                    "coils": {str(k): int(v) for k, v in sorted(s.coils.items())},
                    "enable_mask": hex(enable),
                    "polarity_mask": hex(polarity),
                    "held": [[int(a), int(b)] for a, b in s.held],
                    "next_pole": s.next_pole,
                    "error_deg": math.degrees(s.error),
                    "target": np.round(s.target, 15).tolist(),
                    "achieved": np.round(s.achieved, 15).tolist(),
                    "status": s.status,
                }
            )
        return {
            "format": FORMAT,
            "version": VERSION,
            "design": self.design,
            "design_fingerprint": self.design_fingerprint,
            "planner": self.planner,
            "coil_count": self.coil_count,
            "channel_map": [{"coil": k, "enable": int(e), "polarity": int(p)}
                            for k, (e, p) in enumerate(self.channel_map)],
            "steps": steps,
        }

    def to_json(self, path: str | Path | None = None) -> str:
        """Serialise to JSON; write it atomically to ``path`` when given."""
        text = json.dumps(self.to_dict(), indent=1)
        if path is not None:
            write_text(path, text)
        return text

    def to_csv(self, path: str | Path | None = None) -> str:
        """One row per step: index, status, error (deg), coils (``k:+1;…``), masks (hex), next pole."""
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(["step", "status", "error_deg", "coils", "enable_mask", "polarity_mask", "held", "next_pole"])
        for s in self.steps:
            enable, polarity = s.masks(self.channel_map)
            writer.writerow([
                s.index, s.status, f"{math.degrees(s.error):.6f}",
                ";".join(f"{k}:{v:+d}" for k, v in sorted(s.coils.items())),
                hex(enable), hex(polarity),
                ";".join(f"{a}-{b}" for a, b in s.held),
                "" if s.next_pole is None else s.next_pole,
            ])
        text = buf.getvalue()
        if path is not None:
            write_text(path, text)
        return text

    @classmethod
    def from_dict(cls, data: dict) -> Plan:
        """Inverse of :meth:`to_dict`; raises InputError naming the field (``plan.steps[3].target`` …) on
        malformed input, and refuses relay masks that disagree with the step's coils and the channel map."""
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise bad_value("plan.format", f'"{FORMAT}"', data.get("format") if isinstance(data, dict) else data)
        if data.get("version") != VERSION:
            raise bad_value("plan.version", f"{VERSION} (a version 1 plan names coils in a numbering that could "
                            f"depend on the planning machine's CPU: {AGAIN})", data.get("version"))
        for key in ("coil_count", "channel_map", "steps", "design_fingerprint"):
            if key not in data:
                raise bad_value(f"plan.{key}", "present (write plans with Plan.to_json or `spherestep plan`)",
                                "nothing")
        fingerprint = _fingerprint(data["design_fingerprint"])
        coil_count = checks.count(data["coil_count"], "plan.coil_count", 1, 4096,
                                  expected="a whole number of coils 1..4096")
        cmap = _channel_map(data["channel_map"], coil_count)
        raw = data["steps"]
        if not isinstance(raw, list) or not raw:
            raise bad_value("plan.steps", "a non-empty list of steps", raw if not isinstance(raw, list) else [])
        steps = [_step(s, f"plan.steps[{i}]", coil_count, cmap) for i, s in enumerate(raw)]
        return cls(steps=steps, coil_count=coil_count, channel_map=cmap,
                   design=str(data.get("design", "design")), planner=str(data.get("planner", "geometric")),
                   design_fingerprint=fingerprint)

    @classmethod
    def from_json(cls, path: str | Path) -> Plan:
        """Read a plan written by :meth:`to_json`."""
        path = Path(path)
        if path.exists() and not path.is_file():  # a folder, or a FIFO that would block the read
            raise bad_value("plan", "a regular JSON plan file (not a folder, pipe or device)", str(path))
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise bad_value("plan", "an existing plan file (JSON from `spherestep plan`)", str(path)) from None
        except (OSError, UnicodeDecodeError) as exc:
            raise bad_value("plan", "a readable UTF-8 JSON plan file", f"{path} ({exc})") from None
        try:
            data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise bad_value("plan", "a JSON plan file", f"{path} (line {exc.lineno}: {exc.msg})") from None
        return cls.from_dict(data)


def _fingerprint(value) -> str | None:
    """A plan's recorded design fingerprint: ``"sha256:…"`` or null (a plan made without a design)."""
    if value is None:
        return None
    if not isinstance(value, str) or not value.startswith("sha256:"):
        raise bad_value("plan.design_fingerprint", 'null or "sha256:" and hex digits (MotorDesign.fingerprint)', value)
    return value


def _channel_map(entries, coil_count: int) -> np.ndarray:
    """The ``(N, 2)`` channel map of a plan file's ``channel_map`` list; InputError naming the entry."""
    if not isinstance(entries, list) or len(entries) != coil_count:
        raise bad_value("plan.channel_map", f"a list of {coil_count} entries (one per coil)",
                        f"{len(entries)} entries" if isinstance(entries, list) else entries)
    rows = []
    for k, entry in enumerate(entries):
        name = f"plan.channel_map[{k}]"
        if not isinstance(entry, dict) or entry.get("coil", k) != k:
            raise bad_value(name, f'{{"coil": {k}, "enable": E, "polarity": P}}', entry)
        for role in ("enable", "polarity"):
            checks.count(entry.get(role), f"{name}.{role}", 0, expected="a relay channel number ≥ 0")
        rows.append((entry["enable"], entry["polarity"]))
    return as_channel_map(np.array(rows, dtype=int).reshape(-1, 2), coil_count, "plan.channel_map")


def _matrix(value, name: str) -> np.ndarray:
    try:
        m = np.array(value, dtype=float)
    except (TypeError, ValueError):
        m = None
    if m is None or m.shape != (3, 3) or not np.all(np.isfinite(m)):
        raise bad_value(name, "a 3×3 rotation matrix (a list of three rows of three numbers)", value)
    return so3.as_rotations(m, name)


def _step(s, name: str, coil_count: int, cmap: np.ndarray) -> Step:
    """One step of a plan file; InputError naming the field, also when its masks disagree with its coils."""
    if not isinstance(s, dict):
        raise bad_value(name, "an object with index, coils, masks, target and achieved", s)
    for key in ("index", "coils", "target", "achieved", "error_deg"):
        if key not in s:
            raise bad_value(f"{name}.{key}", "present", "nothing")
    coils = s["coils"]
    try:
        coils = {int(k): v for k, v in coils.items()}
    except (AttributeError, TypeError, ValueError):
        raise bad_value(f"{name}.coils", 'an object of coil number → polarity, like {"3": 1, "7": -1}',
                        coils) from None
    expected = f"coil numbers 0..{coil_count - 1} with polarity +1 or -1"
    coils = {checks.count(k, f"{name}.coils", 0, coil_count - 1, expected=expected):
             checks.sign(v, f"{name}.coils", expected) for k, v in coils.items()}
    enable, polarity = coil_masks(coils, cmap)
    for key, expected in (("enable_mask", enable), ("polarity_mask", polarity)):
        if key in s:
            try:
                given = int(str(s[key]), 0)
            except ValueError:
                raise bad_value(f"{name}.{key}", "a hexadecimal mask like 0x1a", s[key]) from None
            if given != expected:
                raise bad_value(f"{name}.{key}", f"{hex(expected)}, the mask of the step's coils under the "
                                "plan's channel_map (the file disagrees with itself: re-plan it)", s[key])
    index = checks.count(s["index"], f"{name}.index", 0, expected="a whole number ≥ 0")
    error = checks.non_negative(s["error_deg"], f"{name}.error_deg", "a finite angle ≥ 0 in degrees")
    held = s.get("held", [])
    if not isinstance(held, list) or not all(isinstance(p, list) and len(p) == 2 and
                                             all(isinstance(x, int) for x in p) for p in held):
        raise bad_value(f"{name}.held", "a list of [pole, coil] pairs", held)
    next_pole = s.get("next_pole")
    if next_pole is not None:
        next_pole = checks.count(next_pole, f"{name}.next_pole", 0, expected="a pole number or null")
    return Step(index=index, target=_matrix(s["target"], f"{name}.target"),
                achieved=_matrix(s["achieved"], f"{name}.achieved"), error=math.radians(error), coils=coils,
                held=[(a, b) for a, b in held], next_pole=next_pole, status=str(s.get("status", "ok")))
