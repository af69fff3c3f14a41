"""The iron model calibrated from the motor's own holds, as a value and as a file: :class:`Calibration`.

The fit that makes one is the control room's :func:`spherestep.control.calibrate` (the regression on the pair
tables' node values, ``spherestep.control.calibration``); the holds it fits are collected by the drive room's
:func:`spherestep.drive.collect_holds`. This module keeps what the torque model needs to be rebuilt from the
file (:meth:`Calibration.load`, read by :func:`spherestep.magnetics.design_model` with ``calibration=``), so the
magnetics room imports neither control nor drive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..errors import bad_value

CALIBRATION_FILE = "calibration.yaml"  # beside the design file
FORCE = "accept_inconsistent=True (CLI: --accept-inconsistent-calibration)"


def torque_text(value: float, digits: int = 3) -> str:
    """A torque for people: N·m from 1 N·m up, mN·m below (``1.09 N·m``, ``44.1 mN·m``; never ``1.09e+03 mN·m``)."""
    return f"{value:.{digits}g} N·m" if abs(value) >= 1.0 else f"{value * 1e3:.{digits}g} mN·m"


@dataclass(frozen=True)
class Moved:
    """A node the fit moved beyond two standard deviations: ``table`` (``"detent"``/``"winding"``), ``angle``
    (rad), ``nominal``, ``fitted`` and ``std`` (N·m)."""

    table: str
    angle: float
    nominal: float
    fitted: float
    std: float

    def to_dict(self, degrees: bool = True) -> dict:
        return {"table": self.table, ("angle_deg" if degrees else "angle_rad"):
                math.degrees(self.angle) if degrees else self.angle,
                "nominal_Nm": self.nominal, "fitted_Nm": self.fitted, "std_Nm": self.std}


@dataclass(frozen=True, eq=False)
class Calibration:
    """A fitted torque model (:func:`spherestep.control.calibrate`): ``model`` the corrected
    :class:`~spherestep.magnetics.IronTorqueMap` (the base model's coupling kept); ``nodes`` (rad); the fitted
    tables ``detent``, ``winding`` and their standard deviations ``detent_std``, ``winding_std`` (N·m), the
    ``nominal_detent``/``nominal_winding`` they started from; the effective scales ``scale_detent``,
    ``scale_winding`` (``θ⁰·θ / θ⁰·θ⁰`` per table: what the global scale and the shape did together) and their
    ``scale_std``; the equations' residual RMS (N·m)
    ``residual_before`` (the base model) and ``residual_after``, ``sigma`` the noise it assumed; ``holds`` and
    ``equations`` counted; ``moved`` the nodes moved beyond 2σ; ``unseen`` what the data cannot see;
    ``coupling`` whether the fitted model has the cores' coupling, ``coupling_gain`` ± ``coupling_std`` its
    gain against the design's coupling (1: as modelled; 0: none); ``backend``; ``label``; per coil ``gains`` ±
    ``gains_std`` and field ``turns (N, 3)`` rad ± ``turns_std`` (:mod:`spherestep.magnetics.percoil`; None: not
    fitted); ``knee`` the windings' saturation knee (per unit; None: linear or not fitted — only a fit asked
    for it fits it); ``judged`` the held-out verdict's figures (N·m), ``missing`` the terms a diagnosis named, ``rotor``
    the rotor's identified terms and ``sensors`` the array's (when identified: ``RotorFit.to_dict``,
    ``ArrayCalibration.to_dict``)."""

    model: object
    nodes: np.ndarray
    detent: np.ndarray
    winding: np.ndarray
    detent_std: np.ndarray
    winding_std: np.ndarray
    nominal_detent: np.ndarray
    nominal_winding: np.ndarray
    scale_detent: float
    scale_winding: float
    scale_std: tuple[float, float]
    residual_before: float
    residual_after: float
    sigma: float
    holds: int
    equations: int
    moved: tuple[Moved, ...]
    unseen: tuple[str, ...]
    coupling: bool
    backend: str
    label: str = "calibrated"
    coupling_gain: float = 1.0
    coupling_std: float = 0.0
    design_fingerprint: str | None = None
    gains: np.ndarray | None = None
    gains_std: np.ndarray | None = None
    turns: np.ndarray | None = None
    turns_std: np.ndarray | None = None
    judged: dict = field(default_factory=dict)
    missing: tuple[str, ...] = ()
    rotor: dict | None = None
    sensors: dict | None = None
    knee: float | None = None

    @property
    def consistent(self) -> bool | None:
        """The held-out verdict (:func:`spherestep.control.identify.verdict`): whether the fitted model explains
        holds and moves it was not fitted on (None: nothing was held out)."""
        return self.judged.get("consistent")

    def dead_coils(self, below: float = 0.2) -> list[int]:
        """Coils whose fitted gain is within ``below`` of 0 (no torque: a dead or disconnected coil)."""
        return [] if self.gains is None else [int(k) for k in np.nonzero(np.abs(self.gains) < below)[0]]

    def reversed_coils(self, below: float = 0.2) -> list[int]:
        """Coils whose fitted gain is below −``below`` (wired the other way round)."""
        return [] if self.gains is None else [int(k) for k in np.nonzero(self.gains < -below)[0]]

    def check_usable(self, accept_inconsistent: bool = False, where: str = "calibration") -> Calibration:
        """``self`` when its verdict is consistent (or ``accept_inconsistent``); InputError naming ``where``
        otherwise: a fit that does not explain its held-out data is not used."""
        if self.consistent is False and not accept_inconsistent:
            why = f" (missing: {', '.join(self.missing)})" if self.missing else ""
            raise bad_value(where, f"a consistent calibration: this fit does not explain its held-out holds{why}; "
                            f"calibrate again, or force it with {FORCE}", "inconsistent")
        return self

    def summary(self) -> str:
        """Lines for people: residuals, scales, parameters moved, what was not seen."""
        j = self.judged
        lines = []
        if self.consistent is False:
            lines.append("INCONSISTENT: the fit does not explain the held-out holds" + (
                f"; missing: {', '.join(self.missing)}" if self.missing else "") + "; not to be used")
        if self.consistent is None:
            lines.append("not judged: no hold held out (fewer than 5 holds)")
        if j.get("held_out_holds"):
            lines.append(f"held out {j['held_out_holds']} holds: residual {torque_text(j['hold_rms'], 2)} against the "
                         f"noise the sensors imply {torque_text(j['hold_noise'], 2)}; moves "
                         f"{torque_text(j['move_rms'], 2)} of {torque_text(j['move_torque'], 2)}: "
                         f"{'consistent' if self.consistent else 'INCONSISTENT'}")
        if self.gains is not None:
            g, sd = self.gains, self.gains_std
            lines.append(f"coil gains {np.min(g):.3f}…{np.max(g):.3f} (± {np.max(sd):.3f} at most); "
                         f"dead: {self.dead_coils() or 'none'}; reversed: {self.reversed_coils() or 'none'}")
        if self.turns is not None and np.any(self.turns):
            ang = np.degrees(np.linalg.norm(self.turns, axis=1))
            top = np.argsort(-ang)[:3]
            lines.append("coil placements: " + ", ".join(f"coil {k} {ang[k]:.2f}° ± {math.degrees(self.turns_std[k]):.2f}°"
                                                          for k in top))
        if self.rotor:
            r = self.rotor
            lines.append(f"rotor: inertia {r['inertia_kg_m2']:.4g} ± {r['inertia_std']:.2g} kg·m², damping "
                         f"{r['damping_N_m_s']:.3g} ± {r['damping_std']:.2g} N·m·s/rad, friction {r['friction_N_m']:.3g} "
                         f"± {r['friction_std']:.2g} N·m (from {r['windows']} windows of moves)")
        if self.sensors:
            a = self.sensors
            off = np.linalg.norm(np.asarray(a["offsets_T"]), axis=1)
            lines.append(f"sensors: the array turned {a['rotation_angle_deg']:.4f}° (± "
                         f"{max(a['rotation_std_deg']):.4f}°), offsets up to {1e6 * off.max():.0f} µT, from "
                         f"{a['references']} rests in the detent wells")
        lines += [f"{self.holds} holds, {self.equations} equations fitted ({self.backend}): residual RMS "
                 f"{torque_text(self.residual_before)} -> {torque_text(self.residual_after)} (noise taken "
                 f"{torque_text(self.sigma, 2)})",
                 f"detent table ×{self.scale_detent:.4f} ± {self.scale_std[0]:.4f}, winding table "
                 f"×{self.scale_winding:.4f} ± {self.scale_std[1]:.4f} (fitted against nominal, θ⁰·θ / θ⁰·θ⁰)",
                 ("no coupling through the cores" if not self.coupling else
                  f"the cores' coupling ×{self.coupling_gain:.4f} ± {self.coupling_std:.4f}" if self.coupling_std > 0
                  else f"the cores' coupling kept as modelled (×{self.coupling_gain:g})"),
                 f"{len(self.moved)} table nodes moved beyond 2σ"]
        for m in self.moved[:8]:
            lines.append(f"  {m.table} at {math.degrees(m.angle):g}°: {m.nominal:+.4g} -> {m.fitted:+.4g} "
                         f"± {m.std:.2g} N·m")
        if len(self.moved) > 8:
            lines.append(f"  ... and {len(self.moved) - 8} more")
        lines += [f"not seen: {u}" for u in self.unseen] or ["every parameter seen by the data"]
        return "\n".join(lines)

    def to_dict(self, degrees: bool = True) -> dict:
        k = 180.0 / math.pi if degrees else 1.0
        return {"label": self.label, "design_fingerprint": self.design_fingerprint, "backend": self.backend,
                "holds": self.holds, "equations": self.equations,
                "coupling": self.coupling, "coupling_gain": self.coupling_gain, "coupling_std": self.coupling_std,
                "consistent": self.consistent,
                ("nodes_deg" if degrees else "nodes_rad"): [float(x * k) for x in self.nodes],
                "detent_Nm": [float(x) for x in self.detent], "winding_Nm": [float(x) for x in self.winding],
                "detent_std_Nm": [float(x) for x in self.detent_std],
                "winding_std_Nm": [float(x) for x in self.winding_std],
                "nominal_detent_Nm": [float(x) for x in self.nominal_detent],
                "nominal_winding_Nm": [float(x) for x in self.nominal_winding],
                "scale_detent": self.scale_detent, "scale_winding": self.scale_winding,
                "scale_std": [float(x) for x in self.scale_std],
                "residual_before_Nm": self.residual_before, "residual_after_Nm": self.residual_after,
                "sigma_Nm": self.sigma, "moved": [m.to_dict(degrees) for m in self.moved],
                "unseen": list(self.unseen),
                "gains": None if self.gains is None else [float(x) for x in self.gains],
                "gains_std": None if self.gains_std is None else [float(x) for x in self.gains_std],
                "turns_deg": None if self.turns is None else np.degrees(self.turns).tolist(),
                "turns_std_deg": None if self.turns_std is None else np.degrees(self.turns_std).tolist(),
                "knee": self.knee, "dead_coils": self.dead_coils(), "reversed_coils": self.reversed_coils(),
                "held_out": {k: (None if isinstance(v, float) and not math.isfinite(v) else v)
                             for k, v in self.judged.items()},
                "missing": list(self.missing), "rotor": self.rotor, "sensors": self.sensors}

    def save(self, path) -> Path:
        """Write the calibration atomically, as JSON when ``path`` ends in ``.json`` and as YAML otherwise
        (``calibration.yaml`` beside the design file is what :func:`spherestep.magnetics.design_model` reads with
        ``calibration=``; :meth:`load` reads both, JSON being YAML); returns the path."""
        import json

        import yaml

        from ..atomic import write_text

        data = self.to_dict(degrees=True)
        if Path(path).suffix.lower() == ".json":
            return write_text(path, json.dumps(data, indent=1) + "\n")

        text = "# spherestep torque calibration (spherestep.control.calibrate); tables in N·m at nodes in degrees\n"
        return write_text(path, text + yaml.safe_dump(data, sort_keys=False))

    @classmethod
    def load(cls, path, design, accept_inconsistent: bool = False) -> Calibration:
        """The calibration saved at ``path`` for ``design`` (its model rebuilt from the tables and the per-coil
        terms; the coupling re-read from the design's own when it had one). InputError naming ``calibration``
        when the file is not one, does not fit the design, or records an inconsistent fit (unless
        ``accept_inconsistent``: :meth:`check_usable`)."""
        import yaml

        from ._ironmap import IronTorqueMap, iron_model

        path = Path(path)
        try:
            data = yaml.safe_load(path.read_text(encoding="utf-8"))
            nodes = np.radians(np.asarray(data["nodes_deg"], dtype=float))
            det = np.asarray(data["detent_Nm"], dtype=float)
            win = np.asarray(data["winding_Nm"], dtype=float)
            arrays = [np.asarray(data[k], dtype=float) for k in ("detent_std_Nm", "winding_std_Nm",
                                                                 "nominal_detent_Nm", "nominal_winding_Nm")]
            moved = tuple(Moved(m["table"], math.radians(m["angle_deg"]), m["nominal_Nm"], m["fitted_Nm"],
                                m["std_Nm"]) for m in data["moved"])
            coil = {k: None if data.get(k) is None else np.asarray(data[k], dtype=float)
                    for k in ("gains", "gains_std", "turns_deg", "turns_std_deg")}
            judged = {k: (math.nan if v is None else v) for k, v in dict(data.get("held_out") or {}).items()}
            knee = None if data.get("knee") is None else float(data["knee"])
        except (OSError, yaml.YAMLError, KeyError, TypeError, ValueError) as exc:
            raise bad_value("calibration", "a calibration file written by spherestep calibrate",
                            f"{path} ({type(exc).__name__}: {exc})") from None
        if not (len(nodes) == len(det) == len(win)) or not np.all(np.diff(nodes) > 0):
            raise bad_value("calibration", "tables with one value per increasing node", str(path))
        if design.coil.core != "iron":
            raise bad_value("calibration", "used with an iron-cored design", design.coil.core)
        from ..motor import check_fingerprint

        check_fingerprint(design, data.get("design_fingerprint"), "calibration.design_fingerprint",
                          f"calibrate again with `spherestep calibrate` ({path})")
        held = data.get("held_out") or {}
        if held.get("consistent") is False and not accept_inconsistent:
            why = f" (missing: {', '.join(data.get('missing') or [])})" if data.get("missing") else ""
            raise bad_value("calibration", f"a consistent calibration: {path} records a fit that does not explain its "
                            f"held-out holds{why}; calibrate again, or force it with {FORCE}", "inconsistent")
        coupling = bool(data.get("coupling", False))
        gain = float(data.get("coupling_gain", 1.0))
        cross = scaled_coupling(iron_model(design, coupling=True).coupling, gain) if coupling else None
        model = IronTorqueMap.from_tables(design, design.coil, nodes, det, win, coupling=cross)
        turns = None if coil["turns_deg"] is None else np.radians(coil["turns_deg"]).reshape(-1, 3)
        if coil["gains"] is not None or turns is not None or knee is not None:
            from .percoil import PerCoil

            model = PerCoil(model, coil["gains"], turns, knee)
        return cls(model, nodes, det, win, *arrays, float(data["scale_detent"]), float(data["scale_winding"]),
                   tuple(float(x) for x in data["scale_std"]), float(data["residual_before_Nm"]),
                   float(data["residual_after_Nm"]), float(data["sigma_Nm"]), int(data["holds"]),
                   int(data["equations"]), moved, tuple(str(u) for u in data["unseen"]), coupling,
                   str(data["backend"]), str(data.get("label", "calibrated")), gain,
                   float(data.get("coupling_std", 0.0)), design.fingerprint, coil["gains"], coil["gains_std"], turns,
                   None if coil["turns_std_deg"] is None else np.radians(coil["turns_std_deg"]), judged,
                   tuple(data.get("missing") or ()), data.get("rotor"), data.get("sensors"), knee)


def calibration_beside(design_path, design=None, accept_inconsistent: bool = False) -> Path | None:
    """The calibration file beside a design file (``calibration.yaml`` in its folder), or None if there is none;
    with ``design``, checked for it first (:meth:`Calibration.load`: a stale or inconsistent file refused, unless
    ``accept_inconsistent`` for the latter)."""
    path = Path(design_path).parent / CALIBRATION_FILE
    if not path.is_file():
        return None
    if design is not None:
        Calibration.load(path, design, accept_inconsistent)
    return path


def scaled_coupling(coupling, gain: float):
    """The cores' coupling (a :class:`~spherestep.magnetics.IronTorqueMap`'s ``coupling``) with its energy, hence
    its torque, ×``gain``: its series' spline coefficients scaled (the same splines otherwise)."""
    import copy

    if gain == 1.0:
        return coupling
    series = []
    for spline in coupling.series:
        out = copy.copy(spline)
        tx, ty, c = spline.tck
        out.tck = (tx, ty, np.asarray(c) * gain)
        series.append(out)
    return replace(coupling, series=tuple(series))
