"""What the iron cores change for a motor: detent, stepper states, polarity, saturation, power (air against iron).

:func:`iron_summary` measures, on the design's torque models (air core: :class:`TorqueMap`; iron core:
:class:`IronTorqueMap`), with :mod:`spherestep.statics`:

* unpowered: equilibria with every coil off from ``starts`` Haar-random orientations (``seed``); how many are
  minima, and their holding torque (:func:`spherestep.statics.holding_torque`);
* stepper states: from a sample of geometric states with their coils on (each held pole's coil at the pole's
  polarity), the equilibrium of each model: is it a minimum, how far it is from the geometric state, its holding
  torque;
* polarity: the pair torque with the coil driven against the pole (``p c = −1``) near the axis: negative means
  the iron still pulls the pole in (the paper's polarity switching then only weakens the attraction);
* saturation: the mean ``|B|`` in the centre pole's face layer (method of moments, linear iron) over the sampled
  states' energised coils with their nearest poles where the rotor rests on the iron model (the equilibria, not
  the geometric states: there the poles sit degrees off the axes), and with a pole on the axis, against the
  material's knee;
* power per coil at nominal current against the supply.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, replace

import numpy as np

from .. import so3
from ..errors import bad_value
from ..motor.coil import CoilSpec, air_coil, iron_coil
from ..statics import TorqueModel, equilibrium, holding_torque
from . import _iron
from ._ironmap import iron_model
from ._statics import state_currents


@dataclass(frozen=True)
class IronSummary:
    """Measured effects of iron cores (SI; angles in radians, ``to_dict(degrees=True)`` converts)."""

    design: str
    electrics: dict
    detent_peak_Nm: float
    detent_peak_angle: float
    linear_peak_Nm: float
    air_peak_Nm: float
    unpowered_starts: int
    unpowered_minima: int
    unpowered_holding_median_Nm: float
    unpowered_holding_min_Nm: float
    states_sampled: int
    air_states_minima: int
    iron_states_minima: int
    air_offset_median: float
    iron_offset_median: float
    iron_offset_max: float
    air_holding_median_Nm: float
    iron_holding_median_Nm: float
    wrong_polarity_torque_Nm: tuple[float, ...]
    wrong_polarity_angles: tuple[float, ...]
    wrong_polarity_attracts: bool
    max_core_B_T: float
    max_core_B_off_T: float
    knee_T: float
    saturated: bool

    def to_dict(self, degrees: bool = True) -> dict:
        d = asdict(self)
        if degrees:
            for k in ("detent_peak_angle", "air_offset_median", "iron_offset_median", "iron_offset_max"):
                d[k.replace("angle", "angle_deg") if "angle" in k else k + "_deg"] = math.degrees(d.pop(k))
            d["wrong_polarity_angles_deg"] = [math.degrees(a) for a in d.pop("wrong_polarity_angles")]
        return d

    def figure(self, design, coil: CoilSpec | None = None):
        """Matplotlib figure: pair torques of air and iron (detent, linear, wrong polarity) against ``α``; ``coil``
        as for :func:`iron_summary`."""
        import matplotlib.pyplot as plt
        model = iron_model(design, _iron_cored(design, coil))
        air = iron_model(design, air_coil(design.coil_ampere_turns))
        a = np.radians(np.linspace(0.0, 40.0, 401))
        fig, ax = plt.subplots(figsize=(7, 4))
        ax.plot(np.degrees(a), air.pair(a), label=f"air core, +1 ({design.coil_ampere_turns:.0f} A-turns)")
        ax.plot(np.degrees(a), model.detent.pair(a), label="iron: detent (coil off)")
        ax.plot(np.degrees(a), model.detent.pair(a) + model.linear.pair(a), label="iron: coil aiding the pole")
        ax.plot(np.degrees(a), model.detent.pair(a) - model.linear.pair(a), label="iron: coil against the pole")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_xlabel("α, pole from coil axis (°)")
        ax.set_ylabel("torque about the centre (N·m; < 0 pulls in)")
        ax.set_title(f"{self.design}: one pole, one coil")
        ax.legend(fontsize=8)
        fig.tight_layout()
        return fig


FLUX_ALPHA_DEG = np.arange(0.0, 31.0, 2.0)
FLUX_FILE = "iron_core_flux.csv"


FACE_LAYER = 2e-3  # m: depth of the pole's face layer whose mean |B| is compared with the knee


def core_flux_density(design, coil: CoilSpec, alpha, pc, level: int = _iron.IRON_LEVEL) -> np.ndarray:
    """Flux density (T) in the core with one pole at ``alpha`` (rad, ``(K,)``) from the axis and the coil at ``pc``
    (pole polarity × current, ``(K,)``), linear iron (MoM): the volume-weighted mean ``|B|`` of the centre pole's
    cells within ``FACE_LAYER`` of the face (where the magnet's flux enters; single cells of the coarse mesh at the
    magnet's rim reach several times more and are not a physical peak), shape ``(K,)``. For the prototype's coil
    the stored grid (``spherestep/data/iron_core_flux.csv``, 2° × pc ∈ {−1, 0, 1}) is interpolated."""
    import magpylib as magpy
    from importlib import resources

    from ..motor import prototype
    from ._ironmap import _key, read_table
    path = resources.files("spherestep.data") / FLUX_FILE
    if _key(design, coil, level) == _key(prototype(), iron_coil(), _iron.IRON_LEVEL) and path.is_file():
        from scipy.interpolate import RegularGridInterpolator
        arr = read_table(path)
        grid = arr[:, 2].reshape(len(FLUX_ALPHA_DEG), 3)
        f = RegularGridInterpolator((FLUX_ALPHA_DEG, [-1.0, 0.0, 1.0]), grid)
        a = np.clip(np.degrees(np.atleast_1d(alpha)), 0.0, FLUX_ALPHA_DEG[-1])
        return f(np.c_[a, np.clip(np.atleast_1d(pc), -1.0, 1.0)])
    geom = _iron.CoreGeometry.of(design, coil)
    solver = _iron.core_solver(geom, level)
    a = np.atleast_1d(np.asarray(alpha, dtype=float))
    face = design.radius + design.air_gap
    w = np.stack([np.sin(a), np.zeros_like(a), np.cos(a)], axis=1)
    centres = (_iron.magnet_face_radius(design) - 0.5 * design.magnet_length) * w - [0.0, 0.0, face]
    magnet = _iron.rotor_magnet(design, centres, w)
    B_src = magpy.getB(magnet, solver.centroids, squeeze=False).reshape(len(a), -1, 3)
    B_src = B_src + np.asarray(pc, dtype=float).reshape(-1, 1, 1) * magpy.getB(solver.loops[0], solver.centroids,
                                                                                  sumup=True)[None]
    B = solver.flux_density(solver.polarization(B_src))
    r = np.hypot(solver.centroids[:, 0], solver.centroids[:, 1])
    layer = (r < geom.r_p) & (solver.centroids[:, 2] < FACE_LAYER)
    vol = np.array([c.volume for c in solver.cells])[layer]
    return (B[:, layer] * vol).sum(axis=1) / vol.sum()


def _iron_cored(design, coil: CoilSpec | None = None) -> CoilSpec:
    """The iron-cored coil to measure: ``coil`` (which must have an iron core), else ``design.coil`` on an iron
    core (itself when it has one; an air coil's winding, supply and material otherwise)."""
    if coil is None:
        return design.coil if design.coil.core == "iron" else replace(design.coil, core="iron")
    if not isinstance(coil, CoilSpec) or coil.core != "iron":
        raise bad_value("coil", "an iron-cored spherestep.motor.coil.CoilSpec (the summary sets iron against air)",
                        getattr(coil, "core", type(coil).__name__))
    return coil


def iron_summary(design, coil: CoilSpec | None = None, *, states: int = 12, starts: int = 12, seed: int = 0,
                 level: int = _iron.IRON_LEVEL, model: TorqueModel | None = None, stride: int = 1) -> IronSummary:
    """Measure what iron cores change for ``design`` (see the module docstring) with the coils built as ``coil``
    (an iron core); default ``design.coil``, on an iron core if it has none (its winding, supply and material).
    ``model``: the whole motor's iron model for the unpowered and stepper-state equilibria and the rest poses of the
    saturation check (default: the pairwise ``iron_model(design, coil, level)``; e.g. the coupled one,
    ``design_model(design).model``); the one-pole pair torques (detent, winding, polarity) are the pair tables'.
    ``stride``: the holding torques' coarse grid (:func:`spherestep.statics.holding_torque`; 1: every point)."""
    coil = _iron_cored(design, coil)
    rng = np.random.default_rng(seed)
    pair = iron_model(design, coil, level)
    if model is None:
        model = pair
    elif not isinstance(model, TorqueModel) or model.coil_count != len(design.stator):
        raise bad_value("model", f"a spherestep.statics.TorqueModel of the design's {len(design.stator)} coils",
                        f"{model.coil_count} coils" if isinstance(model, TorqueModel) else type(model).__name__)
    air = iron_model(design, air_coil(design.coil_ampere_turns))
    N = model.coil_count
    a = np.radians(np.linspace(0.0, 60.0, 1201))
    det = pair.detent.pair(a)
    lin = pair.linear.pair(a)
    # unpowered
    R0 = so3.random(starts, rng)
    off = np.zeros((starts, N))
    eq0 = equilibrium(model, R0, off, gtol=1e-9, max_step=math.radians(2.0))
    mins = np.flatnonzero(eq0.is_minimum)
    hold0 = holding_torque(model, eq0.rotation[mins], off[mins], stride=stride).torque if len(mins) else np.zeros(0)
    # stepper states
    st = design.states()
    idx = np.sort(rng.choice(len(st), min(states, len(st)), replace=False))
    c = np.array([state_currents(design, i) for i in idx])
    out = {}
    for name, m in (("air", air), ("iron", model)):
        eq = equilibrium(m, st.rotations[idx], c, gtol=1e-9, max_step=math.radians(2.0))
        ok = eq.is_minimum
        offs = so3.distance(eq.rotation, st.rotations[idx])
        hold = holding_torque(m, eq.rotation[ok], c[ok], stride=stride).torque if ok.any() else np.zeros(0)
        out[name] = (int(ok.sum()), offs[ok], hold)
        rest = eq.rotation  # the last: the iron model's rest poses
    # polarity
    probe = np.radians([2.0, 4.0, 6.0, 8.0])
    wrong = pair.detent.pair(probe) - pair.linear.pair(probe)
    # saturation: every energised coil of the sampled states with its nearest pole at rest, and the pole on the axis
    W = np.einsum("kab,mb->kma", rest, design.rotor.centers)
    alphas, pcs = [0.0, 0.0], [1.0, 0.0]
    for n in range(len(idx)):
        for k in np.flatnonzero(c[n]):
            cos = W[n] @ design.stator.centers[k]
            j = int(np.argmax(cos))
            alphas.append(float(np.arccos(np.clip(cos[j], -1, 1))))
            pcs.append(float(design.polarity[j] * c[n, k]))
    B = core_flux_density(design, coil, alphas, pcs, level)
    knee = coil.material.knee
    el = coil.electrics(design.coil_diameter, design.coil_length)
    return IronSummary(
        design=design.name, electrics=el,
        detent_peak_Nm=float(np.min(det)), detent_peak_angle=float(a[np.argmin(det)]),
        linear_peak_Nm=float(np.min(lin)), air_peak_Nm=float(np.min(air.pair(a))),
        unpowered_starts=starts, unpowered_minima=int(len(mins)),
        unpowered_holding_median_Nm=float(np.median(hold0)) if len(hold0) else 0.0,
        unpowered_holding_min_Nm=float(np.min(hold0)) if len(hold0) else 0.0,
        states_sampled=int(len(idx)), air_states_minima=out["air"][0], iron_states_minima=out["iron"][0],
        air_offset_median=float(np.median(out["air"][1])) if out["air"][0] else math.nan,
        iron_offset_median=float(np.median(out["iron"][1])) if out["iron"][0] else math.nan,
        iron_offset_max=float(np.max(out["iron"][1])) if out["iron"][0] else math.nan,
        air_holding_median_Nm=float(np.median(out["air"][2])) if out["air"][0] else 0.0,
        iron_holding_median_Nm=float(np.median(out["iron"][2])) if out["iron"][0] else 0.0,
        wrong_polarity_torque_Nm=tuple(float(v) for v in wrong), wrong_polarity_angles=tuple(float(v) for v in probe),
        wrong_polarity_attracts=bool(np.all(wrong < 0)),
        max_core_B_T=float(B.max()), max_core_B_off_T=float(B[1]), knee_T=float(knee), saturated=bool(B.max() > knee))
