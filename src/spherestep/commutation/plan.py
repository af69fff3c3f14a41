"""The commutation plan: per step the coils to energise, with polarity, and where the rotor should land.

A :class:`Plan` is what every planner returns and what the hardware streams. Its file format (JSON,
``"format": "spherestep-plan"``, ``"version": 1``) is documented in ``docs/commutation.md``; CSV holds the
same steps one per row with the relay masks.

Relay channels: coil ``k`` has an *enable* channel and a *polarity* channel (``channel_map[k] = (enable,
polarity)``). A step's ``enable_mask`` has bit ``enable`` set for every energised coil; ``polarity_mask``
has bit ``polarity`` set for every coil driven with polarity −1 (reversed current). Bit ``b`` is ``1 << b``.
"""

from __future__ import annotations

import csv
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..atomic import write_text
from ..errors import InputError, bad_value

FORMAT = "spherestep-plan"
VERSION = 1


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


@dataclass
class Plan:
    """A sequence of :class:`Step` for one design; ``failures`` lists ``(step index, reason)``."""

    steps: list[Step]
    coil_count: int
    channel_map: np.ndarray
    design: str = "design"
    planner: str = "geometric"

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
    def from_dict(cls, data: dict) -> "Plan":
        """Inverse of :meth:`to_dict`; raises InputError naming the field on malformed input."""
        if not isinstance(data, dict) or data.get("format") != FORMAT:
            raise bad_value("plan.format", f'"{FORMAT}"', data.get("format") if isinstance(data, dict) else data)
        if data.get("version") != VERSION:
            raise bad_value("plan.version", str(VERSION), data.get("version"))
        try:
            coil_count = int(data["coil_count"])
            cmap = np.array([[c["enable"], c["polarity"]] for c in data["channel_map"]], dtype=int).reshape(-1, 2)
            steps = []
            for i, s in enumerate(data["steps"]):
                coils = {int(k): int(v) for k, v in s["coils"].items()}
                if any(k < 0 or k >= coil_count for k in coils) or any(v not in (-1, 1) for v in coils.values()):
                    raise bad_value(f"plan.steps[{i}].coils", f"coil indices 0..{coil_count - 1} with polarity ±1",
                                    s["coils"])
                steps.append(Step(
                    index=int(s["index"]),
                    target=np.array(s["target"], dtype=float).reshape(3, 3),
                    achieved=np.array(s["achieved"], dtype=float).reshape(3, 3),
                    error=math.radians(float(s["error_deg"])),
                    coils=coils,
                    held=[(int(a), int(b)) for a, b in s.get("held", [])],
                    next_pole=None if s.get("next_pole") is None else int(s["next_pole"]),
                    status=str(s.get("status", "ok")),
                ))
        except InputError:
            raise
        except (KeyError, TypeError, ValueError) as exc:
            raise InputError(f"plan file is malformed ({type(exc).__name__}: {exc}); "
                             "write it with Plan.to_json or `spherestep plan`") from None
        if cmap.shape[0] != coil_count:
            raise bad_value("plan.channel_map", f"{coil_count} entries (one per coil)", f"{cmap.shape[0]} entries")
        if np.any(cmap < 0) or len(np.unique(cmap)) != cmap.size:
            raise bad_value("plan.channel_map", "distinct non-negative channels for every coil", cmap.tolist())
        return cls(steps=steps, coil_count=coil_count, channel_map=cmap,
                   design=str(data.get("design", "design")), planner=str(data.get("planner", "geometric")))

    @classmethod
    def from_json(cls, path: str | Path) -> "Plan":
        """Read a plan written by :meth:`to_json`."""
        path = Path(path)
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
