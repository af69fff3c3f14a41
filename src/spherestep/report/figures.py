"""The report's figures (plotly): the motor in 3-D, the resolution histogram, the commutation animation in the
Fig. 10 view (geometry from :mod:`spherestep.fig10`, the same as the matplotlib figures), the simulated run and the
energy map. Numeric arrays go to the page as float32 typed arrays (half the size)."""

from __future__ import annotations

import base64
import math
from collections.abc import Mapping

import numpy as np
import plotly.graph_objects as go
from plotly.subplots import make_subplots

from .. import so3
from ..errors import bad_value
from ..fig10 import POLARITY_COLOUR, OUTLINE_POINTS, cap_outline, cap_outlines, fig10_step, joined, plane_basis

MAX_FRAMES = 240  # animation frames at most; longer plans are shown on evenly spaced steps
MAX_TRACE_POINTS = 4000  # simulated trajectories are thinned to this many samples
DISC_POINTS = 16  # rim points per magnet disc in 3-D
SPHERE_GRID = (18, 36)  # latitude × longitude cells of the sphere mesh
HISTOGRAM_BINS = 60
COIL_GREY = "#555555"
FONT = "system-ui, -apple-system, 'Segoe UI', Helvetica, Arial, sans-serif"
ANIMATE = {"mode": "immediate", "frame": {"duration": 0, "redraw": True}, "transition": {"duration": 0}}
POLE_NAME = {1: "north out (+1)", -1: "south out (−1)"}


def _f32(a) -> np.ndarray:
    """Float32 copy: plotly encodes arrays as base64 typed arrays, so this halves their size."""
    return np.asarray(a, dtype=np.float32)


def _typed(obj):
    """Numeric numpy arrays, recursively in dicts and lists, as plotly.js typed-array specs (base64)."""
    if isinstance(obj, np.ndarray) and obj.dtype.kind in "fiu":
        if not obj.size:
            return []
        arr = obj.astype(np.float32 if obj.dtype.kind == "f" else np.int32)
        return {"dtype": "f4" if obj.dtype.kind == "f" else "i4", "bdata": base64.b64encode(arr.tobytes()).decode()}
    if isinstance(obj, dict):
        return {key: _typed(value) for key, value in obj.items()}
    if isinstance(obj, list):
        return [_typed(value) for value in obj]
    return obj


def _rgba(colour: str, alpha: float) -> str:
    r, g, b = (int(colour[i:i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r},{g},{b},{alpha})"


def _rings(centers, radius: float, points: int, scale: float = 1.0) -> np.ndarray:
    """Outlines of the caps about ``centers`` as one ``(K·(points+2) − 1, 3)`` polyline, NaN between rings."""
    return joined(cap_outlines(centers, radius, points) * scale)


def _disc_mesh(centers, radius: float, scale: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices ``(K·(DISC_POINTS+1), 3)`` and triangles of flat-ish discs (a fan) on the caps."""
    centers = np.asarray(centers, dtype=float).reshape(-1, 3)
    rim = np.stack([cap_outline(c, radius, DISC_POINTS) for c in centers]) * scale
    verts = np.concatenate([centers[:, None, :] * scale, rim], axis=1).reshape(-1, 3)
    base = (DISC_POINTS + 1) * np.arange(len(centers))[:, None]
    a = np.arange(DISC_POINTS)
    tri = np.stack([np.zeros_like(a), 1 + a, 1 + (a + 1) % DISC_POINTS], axis=1)
    return verts, (base[:, :, None] + tri[None]).reshape(-1, 3)


def _sphere_mesh(radius: float = 1.0) -> go.Mesh3d:
    nt, npz = SPHERE_GRID
    t, p = np.meshgrid(np.linspace(0, np.pi, nt + 1), np.linspace(0, 2 * np.pi, npz, endpoint=False), indexing="ij")
    verts = radius * np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1).reshape(-1, 3)
    r, c = np.meshgrid(np.arange(nt), np.arange(npz), indexing="ij")
    a, b = r * npz + c, r * npz + (c + 1) % npz
    tri = np.concatenate([np.stack([a, a + npz, b], -1), np.stack([b, a + npz, b + npz], -1)]).reshape(-1, 3)
    return go.Mesh3d(x=_f32(verts[:, 0]), y=_f32(verts[:, 1]), z=_f32(verts[:, 2]), i=tri[:, 0], j=tri[:, 1],
                     k=tri[:, 2], color="#e6e2da", flatshading=False, hoverinfo="skip", name="rotor",
                     lighting={"ambient": 0.7, "diffuse": 0.5, "specular": 0.05}, showlegend=False)


def _xyz(points) -> dict:
    p = _f32(np.asarray(points).reshape(-1, 3))
    return {"x": p[:, 0], "y": p[:, 1], "z": p[:, 2]}


def _scene(up, eye) -> dict:
    axis = {"visible": False, "range": [-1.3, 1.3]}
    return {"xaxis": axis, "yaxis": axis, "zaxis": axis, "aspectmode": "cube",
            "camera": {"up": dict(zip("xyz", map(float, up))), "eye": dict(zip("xyz", map(float, eye)))}}


def _view(design, toward=None, tilt: float = 70.0, distance: float = 1.45) -> tuple[np.ndarray, np.ndarray]:
    """Camera ``(up, eye)`` with the stator below (up is −stator_axis): the eye ``tilt`` degrees from straight
    below the stator, on the side ``toward`` leans to (a unit vector, e.g. the rotation axis) when given."""
    s = design.stator_axis
    side = plane_basis(s)[0] if toward is None else np.asarray(toward) - (np.asarray(toward) @ s) * s
    if np.linalg.norm(side) < 1e-6:
        side = plane_basis(s)[0]
    side = side / np.linalg.norm(side)
    t = math.radians(tilt)
    return -s, distance * (math.cos(t) * s + math.sin(t) * side)


def _turn_angles(rotations, start, basis) -> np.ndarray:
    """How far (degrees, unwrapped) the rotor marker ``startᵀ e1`` has turned about ``basis[2]`` at each ``R``."""
    tips = np.asarray(rotations) @ (np.asarray(start).T @ basis[0])
    return np.degrees(np.unwrap(np.arctan2(tips @ basis[1], tips @ basis[0])))


def _infer_axis(rotations) -> np.ndarray:
    """Mean direction of the steps ``R_{i+1} R_iᵀ`` (fixed frame) of a sequence of rotations."""
    R = np.asarray(rotations)
    total = so3.log(R[1:] @ np.swapaxes(R[:-1], -1, -2)).sum(axis=0) if len(R) > 1 else np.zeros(3)
    norm = np.linalg.norm(total)
    return total / norm if norm > 1e-12 else np.array([0.0, 0.0, 1.0])


def _field(obj, name, default=None):
    return obj.get(name, default) if isinstance(obj, Mapping) else getattr(obj, name, default)


def _layout(**kw) -> dict:
    base = {"template": "none", "font": {"family": FONT, "size": 12}, "paper_bgcolor": "white",
            "margin": {"l": 10, "r": 10, "t": 40, "b": 10}}
    return base | kw


def motor_figure(design, R=None) -> go.Figure:
    """3-D view: the sphere, the rotor's magnets at orientation ``R`` (discs coloured by polarity) and the
    stator's coils (rings at the coil faces, slightly outside the sphere)."""
    R = np.eye(3) if R is None else np.asarray(R, dtype=float)
    fig = go.Figure([_sphere_mesh(0.995)])
    poles = design.rotor.centers @ R.T
    for sign in (1, -1):
        idx = np.flatnonzero(design.polarity == sign)
        if not len(idx):
            continue
        verts, tri = _disc_mesh(poles[idx], design.magnet_angle, 1.004)
        text = np.repeat([f"pole {j}: {POLE_NAME[sign]}" for j in idx], DISC_POINTS + 1)
        fig.add_trace(go.Mesh3d(**_xyz(verts), i=tri[:, 0], j=tri[:, 1], k=tri[:, 2], color=POLARITY_COLOUR[sign],
                                name=f"magnet, {POLE_NAME[sign]}", showlegend=True, hovertext=text,
                                hoverinfo="text", lighting={"ambient": 0.6, "diffuse": 0.6}))
    scale = 1.0 + design.air_gap / design.radius + 0.02
    coils = design.stator.centers
    ring = _rings(coils, design.coil_angle, 32, scale)
    text = np.repeat([f"coil {k}" + (" (failed)" if k in design.failed_coils else "") for k in range(len(coils))], 34)
    fig.add_trace(go.Scatter3d(**_xyz(ring), mode="lines", line={"color": COIL_GREY, "width": 5},
                               name="stator coil", hovertext=text[:len(ring)], hoverinfo="text"))
    up, eye = _view(design)
    fig.update_layout(_layout(scene=_scene(up, eye), height=600,
                              title={"text": f"{design.name}: {len(design.rotor)} magnets, {len(coils)} coils",
                                     "x": 0.02},
                              legend={"x": 0.01, "y": 0.02, "bgcolor": "rgba(255,255,255,0.7)"}))
    return fig


def resolution_distances(design, samples: int, seed) -> np.ndarray:
    """Park distances (radians) from ``samples`` uniformly random orientations (``seed``) to the nearest state."""
    dist, _ = design.states().nearest(so3.random(samples, seed))
    return dist[:, 0]


def resolution_figure(design, distances) -> go.Figure:
    """Histogram (degrees) of the distances to the nearest state, with the median, 95% and max step marked."""
    deg = np.degrees(distances)
    top = max(float(deg.max()), math.degrees(design.max_step)) * 1.02
    counts, edges = np.histogram(deg, bins=HISTOGRAM_BINS, range=(0.0, top))
    fig = go.Figure(go.Bar(x=_f32(0.5 * (edges[1:] + edges[:-1])), y=counts, width=float(edges[1] - edges[0]),
                           marker={"color": "#7a8fa6", "line": {"width": 0}}, name="orientations",
                           hovertemplate="%{x:.2f}°: %{y}<extra></extra>"))
    marks = [("median", float(np.median(deg)), "#222"), ("95%", float(np.quantile(deg, 0.95)), "#222"),
             ("max step", math.degrees(design.max_step), "#c0392b")]
    for name, x, colour in marks:
        fig.add_vline(x=x, line={"color": colour, "dash": "dash", "width": 1.5},
                      annotation={"text": f"{name} {x:.2f}°", "font": {"color": colour},
                                  "bgcolor": "rgba(255,255,255,0.85)"},
                      annotation_position="top right")
    fig.update_layout(_layout(height=360, bargap=0, margin={"l": 60, "r": 20, "t": 40, "b": 50},
                              title={"text": f"Distance from {len(deg)} random orientations to the nearest stepper "
                                             "state", "x": 0.02},
                              xaxis={"title": {"text": "Park distance to the nearest state (°)"}, "showgrid": True,
                                     "gridcolor": "#eee", "zeroline": False},
                              yaxis={"title": {"text": "orientations"}, "showgrid": True, "gridcolor": "#eee"}))
    return fig


def frame_steps(count: int, limit: int = MAX_FRAMES) -> np.ndarray:
    """Indices of the plan steps shown in the animation: all of them, or ``limit`` evenly spaced ones
    including the first and the last."""
    if count <= limit:
        return np.arange(count)
    return np.unique(np.round(np.linspace(0, count - 1, limit)).astype(int))


def commutation_figure(design, plan, axis) -> dict:
    """The plan animated with a step slider: the Fig. 10 view (left) and a 3-D view (right); see the module.

    Returned as a figure dict with ``frames`` (one per shown step, see :func:`frame_steps`)."""
    basis = plane_basis(axis)
    start = plan.steps[0].achieved
    marker_body = start.T @ basis[0]
    targets = _turn_angles(plan.targets, start, basis)
    turned = _turn_angles(plan.achieved, start, basis)
    coil_scale = 1.0 + design.air_gap / design.radius + 0.02
    u, pol, coils = design.rotor.centers, design.polarity, design.stator.centers

    def xy(rings):
        line = _f32(joined(rings))
        return {"x": line[:, 0], "y": line[:, 1]}

    def step_traces(i):
        view = fig10_step(design, plan, i, axis, OUTLINE_POINTS, marker_length=1.18)
        step = plan.steps[i]
        R = step.achieved
        poles = u @ R.T
        held = [j for j, _ in step.held]
        nxt = step.next_pole
        colour = POLARITY_COLOUR[view.next_polarity] if view.next_polarity else "black"
        out = [xy(view.energised[1]), xy(view.energised[-1]), xy(view.held[1]), xy(view.held[-1]),
               xy(view.next_pole) | {"line": {"color": colour, "width": 1.5},
                                     "fillpattern": {"shape": "/", "fgcolor": colour, "bgcolor": "white", "size": 6,
                                                     "solidity": 0.4}},
               {"x": _f32(view.marker[:, 0]), "y": _f32(view.marker[:, 1])}]
        at = _f32([p for _, p in view.labels]).reshape(-1, 2)
        out.append({"x": at[:, 0], "y": at[:, 1], "text": [str(k) for k, _ in view.labels]})
        # 3-D
        for sign in (1, -1):
            out.append(_xyz(poles[pol == sign] * 1.01))
        for sign in (1, -1):
            out.append(_xyz(_rings(coils[[k for k, s in sorted(step.coils.items()) if s == sign]],
                                   design.coil_angle, 32, coil_scale)))
        out.append(_xyz(poles[held] * 1.02) | {"marker": {"color": [POLARITY_COLOUR[int(pol[j])] for j in held],
                                                           "size": 11, "line": {"color": "black", "width": 2}}})
        out.append(_xyz(poles[[] if nxt is None else [nxt]] * 1.02) | {"marker": {"color": colour, "size": 12,
                                                                                   "symbol": "diamond-open"}})
        out.append(_xyz(np.array([np.zeros(3), 1.25 * (R @ marker_body)])))
        return out

    n = len(plan.steps) - 1
    fig = make_subplots(rows=1, cols=2, specs=[[{"type": "xy"}, {"type": "scene"}]], column_widths=[0.5, 0.5],
                        horizontal_spacing=0.02)
    t = np.linspace(0, 2 * np.pi, 129)
    static2d = [
        go.Scatter(x=_f32(np.cos(t)), y=_f32(np.sin(t)), mode="lines", line={"color": "#cccccc", "width": 1},
                   hoverinfo="skip"),
        go.Scatter(**xy(fig10_step(design, plan, 0, axis, OUTLINE_POINTS).coils), mode="lines",
                   line={"color": COIL_GREY, "width": 1}, hoverinfo="skip"),
        go.Scatter(x=_f32([0, 1.18]), y=_f32([0, 0]), mode="lines", line={"color": "#888", "width": 1, "dash": "dot"},
                   hoverinfo="skip"),
    ]
    first = step_traces(0)
    anim2d = [go.Scatter(mode="lines", fill="toself", fillcolor=_rgba(POLARITY_COLOUR[s], 0.25),
                         line={"color": COIL_GREY, "width": 1}, hoverinfo="skip", **first[c])
              for c, s in enumerate((1, -1))]
    anim2d += [go.Scatter(mode="lines", fill="toself", fillcolor=POLARITY_COLOUR[s],
                          line={"color": "black", "width": 1}, hoverinfo="skip", **first[2 + c])
               for c, s in enumerate((1, -1))]
    anim2d += [go.Scatter(mode="lines", fill="toself", fillcolor="white", hoverinfo="skip", **first[4]),
               go.Scatter(mode="lines+markers", line={"color": "black", "width": 2.5},
                          marker={"size": [6, 0], "color": "black"}, hoverinfo="skip", **first[5]),
               go.Scatter(mode="text", textfont={"size": 10, "color": "#111"}, hoverinfo="skip", **first[6])]
    up, eye = _view(design, axis, tilt=35.0, distance=1.55)
    static3d = [
        _sphere_mesh(0.99),
        go.Scatter3d(**_xyz(_rings(coils, design.coil_angle, 32, coil_scale)), mode="lines",
                     line={"color": "#999999", "width": 3}, hoverinfo="skip"),
        go.Scatter3d(**_xyz(np.array([-1.3 * np.asarray(axis), 1.3 * np.asarray(axis)])), mode="lines",
                     line={"color": "#333", "width": 2, "dash": "dash"}, hoverinfo="skip"),
    ]
    anim3d = [go.Scatter3d(mode="markers", marker={"size": 3.5, "color": POLARITY_COLOUR[s]}, hoverinfo="skip",
                           **first[7 + c]) for c, s in enumerate((1, -1))]
    anim3d += [go.Scatter3d(mode="lines", line={"color": POLARITY_COLOUR[s], "width": 7}, hoverinfo="skip",
                            **first[9 + c]) for c, s in enumerate((1, -1))]
    anim3d += [go.Scatter3d(mode="markers", hoverinfo="skip", **first[11]),
               go.Scatter3d(mode="markers", hoverinfo="skip", **first[12]),
               go.Scatter3d(mode="lines", line={"color": "black", "width": 6}, hoverinfo="skip", **first[13])]
    for tr in static2d + anim2d:
        fig.add_trace(tr, row=1, col=1)
    for tr in static3d + anim3d:
        fig.add_trace(tr, row=1, col=2)
    nstat2, nanim2, nstat3 = len(static2d), len(anim2d), len(static3d)
    animated = list(range(nstat2, nstat2 + nanim2)) + list(range(nstat2 + nanim2 + nstat3, len(fig.data)))

    def title(i):
        s = plan.steps[i]
        return (f"step {i} of {n} ({s.status}): error {math.degrees(s.error):.2f}°, turned {turned[i]:.1f}° "
                f"(target {targets[i]:.1f}°), coils {', '.join(f'{k}:{v:+d}' for k, v in sorted(s.coils.items()))}")

    shown = frame_steps(len(plan.steps))
    frames = [{"name": str(i), "data": _typed(step_traces(i) if i else first), "traces": animated,
               "layout": {"title": {"text": title(i)}}} for i in shown]
    lim = [-1.3, 1.3]
    fig.update_layout(_layout(
        height=620, showlegend=False, title={"text": title(0), "x": 0.02, "font": {"size": 13}},
        margin={"l": 10, "r": 10, "t": 40, "b": 10},
        xaxis={"range": lim, "visible": False, "scaleanchor": "y", "constrain": "domain"},
        yaxis={"range": lim, "visible": False, "domain": [0.14, 1.0]},
        scene=_scene(up, eye) | {"domain": {"x": [0.51, 1.0], "y": [0.14, 1.0]}},
        sliders=[{"active": 0, "x": 0.08, "len": 0.92, "y": 0.1, "pad": {"t": 0, "b": 0},
                  "currentvalue": {"prefix": "step ", "font": {"size": 12}},
                  "steps": [{"label": str(i), "method": "animate", "args": [[str(i)], ANIMATE]} for i in shown]}],
        updatemenus=[{"type": "buttons", "direction": "left", "x": 0.0, "y": 0.1, "xanchor": "left", "yanchor": "top",
                      "pad": {"t": 30}, "showactive": False,
                      "buttons": [{"label": "▶", "method": "animate",
                                   "args": [None, {"frame": {"duration": 350, "redraw": True}, "fromcurrent": True,
                                                   "transition": {"duration": 0}}]},
                                  {"label": "❚❚", "method": "animate", "args": [[None], ANIMATE]}]}],
    ))
    out = fig.to_dict()
    out["frames"] = frames
    return out


def trajectory_figure(simulation, axis, targets=None) -> go.Figure:
    """Simulated rotation angle about ``axis`` over time against the plan (desired ``R_i`` when ``targets``
    are given, and the planned states ``R̃_i``), and the distance to the planned state (degrees)."""
    times = np.asarray(simulation.times, dtype=float)
    planned = np.asarray(simulation.planned)
    n = len(planned) - 1
    basis = plane_basis(axis)
    start = planned[0]
    keep = np.unique(np.linspace(0, len(times) - 1, min(len(times), MAX_TRACE_POINTS)).round().astype(int))
    t = times[keep]
    orientations = np.asarray(simulation.orientations)[keep]
    dwell = times[-1] / n if n else 1.0
    step_of = np.clip(np.ceil(t / dwell - 1e-9), 0, n).astype(int)
    step_t = np.concatenate([[0.0], dwell * np.arange(n + 1)])  # step i holds over ((i − 1)·dwell, i·dwell]
    fig = make_subplots(rows=2, cols=1, shared_xaxes=True, row_heights=[0.68, 0.32], vertical_spacing=0.06)
    if targets is not None:
        tgt = _turn_angles(targets, start, basis)
        fig.add_trace(go.Scatter(x=_f32(step_t), y=_f32(np.append(tgt, tgt[-1])), mode="lines",
                                 line={"shape": "hv", "color": "#999", "width": 2, "dash": "dot"},
                                 name="desired Rᵢ (plan target)"), row=1, col=1)
    plan_angle = _turn_angles(planned, start, basis)
    fig.add_trace(go.Scatter(x=_f32(step_t), y=_f32(np.append(plan_angle, plan_angle[-1])), mode="lines",
                             line={"shape": "hv", "color": "#2c6fbb", "width": 2}, name="planned state R̃ᵢ"),
                  row=1, col=1)
    fig.add_trace(go.Scatter(x=_f32(t), y=_f32(_turn_angles(orientations, start, basis)), mode="lines",
                             line={"color": "#c0392b", "width": 1.5}, name="simulated"), row=1, col=1)
    err = np.degrees(so3.distance(orientations, planned[step_of]))
    fig.add_trace(go.Scatter(x=_f32(t), y=_f32(err), mode="lines", line={"color": "#c0392b", "width": 1},
                             name="distance to the planned state", showlegend=False), row=2, col=1)
    fig.add_hline(y=math.degrees(simulation.tolerance), line={"color": "#555", "dash": "dash", "width": 1},
                  annotation={"text": f"tolerance {math.degrees(simulation.tolerance):.2f}°"}, row=2, col=1)
    fig.update_layout(_layout(height=520, margin={"l": 70, "r": 20, "t": 40, "b": 50},
                              title={"text": "Simulated run: rotation about the commutation axis", "x": 0.02},
                              legend={"x": 0.01, "y": 0.99, "bgcolor": "rgba(255,255,255,0.8)"}))
    fig.update_xaxes(showgrid=True, gridcolor="#eee", zeroline=False)
    fig.update_yaxes(showgrid=True, gridcolor="#eee", zeroline=False)
    fig.update_yaxes(title_text="turned (°)", row=1, col=1)
    fig.update_yaxes(title_text="from plan (°)", row=2, col=1)
    fig.update_xaxes(title_text="time (s)", row=2, col=1)
    return fig


def _euler_energy_map(grid, values) -> dict:
    """An ``energy_grid`` result ``(SO3Grid, V (α, β, γ))`` as a map over ``(α, β)`` minimised over ``γ``."""
    values = np.asarray(values, dtype=float)
    shape = (len(grid.alpha), len(grid.beta), len(grid.gamma))
    if values.shape != shape:
        raise bad_value("energy_map", f"(grid, V) with V of the grid's shape {shape} over (α, β, γ)",
                        f"V of shape {values.shape}")
    return {"x": np.degrees(grid.alpha), "y": np.degrees(grid.beta), "energy": values.min(axis=2).T,
            "x_label": "α (ZXZ Euler angle, °)", "y_label": "β (°)",
            "title": "Energy over the SO(3) grid, lowest over γ for each (α, β)"}


def energy_figure(energy_map) -> go.Figure:
    """Heat map of ``energy_map``: either ``(grid, V)`` as returned by ``MotorPotential.energy_grid`` (shown
    over the Euler angles ``α, β``, lowest over ``γ``), or a mapping or object with ``energy (ny, nx)`` and
    optionally ``x (nx,)``, ``y (ny,)``, ``x_label``, ``y_label``, ``title`` and ``unit``."""
    if isinstance(energy_map, tuple) and len(energy_map) == 2 and hasattr(energy_map[0], "gamma"):
        energy_map = _euler_energy_map(*energy_map)
    raw = _field(energy_map, "energy")
    energy = None if raw is None else np.asarray(raw, dtype=float)
    if energy is None or energy.ndim != 2 or min(energy.shape) < 2:
        raise bad_value("energy_map", "(grid, V) from energy_grid, or a mapping or object with a 2-D 'energy' "
                        "grid (ny, nx)", None if energy is None else f"shape {energy.shape}")
    x = np.asarray(_field(energy_map, "x", np.arange(energy.shape[1])), dtype=float)
    y = np.asarray(_field(energy_map, "y", np.arange(energy.shape[0])), dtype=float)
    if x.shape != (energy.shape[1],) or y.shape != (energy.shape[0],):
        raise bad_value("energy_map", f"x of length {energy.shape[1]} and y of length {energy.shape[0]} "
                        "(columns and rows of energy)", f"x {x.shape}, y {y.shape}")
    unit = _field(energy_map, "unit")
    fig = go.Figure(go.Heatmap(x=_f32(x), y=_f32(y), z=_f32(energy), colorscale="Viridis",
                               colorbar={"title": {"text": "energy" + (f" ({unit})" if unit else "")}},
                               hovertemplate="%{x:.3g}, %{y:.3g}: %{z:.4g}<extra></extra>"))
    fig.update_layout(_layout(height=460, margin={"l": 70, "r": 20, "t": 40, "b": 50},
                              title={"text": str(_field(energy_map, "title", "Energy map")), "x": 0.02},
                              xaxis={"title": {"text": str(_field(energy_map, "x_label", "x"))}},
                              yaxis={"title": {"text": str(_field(energy_map, "y_label", "y"))}}))
    return fig




def capability_figure(capability) -> go.Figure:
    """The torque capability over SO(3) (a :class:`~spherestep.control.Capability`): the torque available in
    every direction and the smallest singular value of ``K(R)``, both against the sampled orientations' rotation
    angle, with their distribution; N·m."""
    angle = np.degrees(so3.angle(capability.rotations))
    order = np.argsort(capability.radius)
    fig = make_subplots(rows=1, cols=2, column_widths=[0.62, 0.38], horizontal_spacing=0.09,
                        subplot_titles=("per sampled orientation", "fraction of SO(3) with at least"))
    fig.add_trace(go.Scatter(x=_f32(angle), y=_f32(capability.radius), mode="markers", name="available in every "
                             "direction (N·m)", marker={"size": 4, "color": "#2c6fbb"}), row=1, col=1)
    fig.add_trace(go.Scatter(x=_f32(angle), y=_f32(capability.singular_values[:, 2]), mode="markers",
                             name="σ_min of K(R) (N·m per unit current)", marker={"size": 4, "color": "#c0392b"}),
                  row=1, col=1)
    torque = capability.radius[order]
    fig.add_trace(go.Scatter(x=_f32(torque), y=_f32(1.0 - np.arange(len(torque)) / len(torque)), mode="lines",
                             line={"shape": "hv", "color": "#2c6fbb"}, showlegend=False), row=1, col=2)
    fig.update_xaxes(title_text="rotation angle of the sample (°)", row=1, col=1)
    fig.update_xaxes(title_text="torque available in every direction (N·m)", row=1, col=2)
    fig.update_yaxes(title_text="N·m", row=1, col=1)
    fig.update_yaxes(title_text="fraction of samples", range=[0, 1.02], row=1, col=2)
    fig.update_layout(_layout(height=420, margin={"l": 60, "r": 20, "t": 60, "b": 50},
                              legend={"x": 0.01, "y": -0.25, "orientation": "h"}))
    return fig


def servo_figure(run) -> go.Figure:
    """A driven servo run (a :class:`~spherestep.drive.DriveResult`): tracking error and the loop's sensor error
    (°), coil currents (A) over time, and the electrical power drawn from the supply (W)."""
    keep = np.unique(np.linspace(0, len(run.times) - 1, min(len(run.times), MAX_TRACE_POINTS)).round().astype(int))
    t = _f32(run.times[keep])
    fig = make_subplots(rows=3, cols=1, shared_xaxes=True, row_heights=[0.36, 0.4, 0.24], vertical_spacing=0.05)
    fig.add_trace(go.Scatter(x=t, y=_f32(np.degrees(run.tracking_error[keep])), mode="lines", name="rotor − trajectory",
                             line={"color": "#c0392b", "width": 1.2}), row=1, col=1)
    fig.add_trace(go.Scatter(x=t, y=_f32(np.degrees(run.sensor_error[keep])),
                             mode="lines", name="sensor − rotor", line={"color": "#888", "width": 1}), row=1, col=1)
    for k in range(run.currents.shape[1]):
        fig.add_trace(go.Scatter(x=t, y=_f32(run.currents[keep, k]), mode="lines", name=f"coil {k}",
                                 line={"width": 0.8}, showlegend=False, hovertemplate=f"coil {k}: %{{y:.3f}} A"),
                      row=2, col=1)
    fig.add_trace(go.Scatter(x=t, y=_f32(run.power[keep]), mode="lines", name="supply power",
                             line={"color": "#2c6fbb", "width": 1.2}), row=3, col=1)
    fig.update_yaxes(title_text="error (°)", row=1, col=1)
    fig.update_yaxes(title_text="current (A)", row=2, col=1)
    fig.update_yaxes(title_text="power (W)", row=3, col=1)
    fig.update_xaxes(title_text="time (s)", row=3, col=1)
    fig.update_layout(_layout(height=620, margin={"l": 70, "r": 20, "t": 40, "b": 50},
                              title={"text": "Servo run: tracking error, coil currents, supply power", "x": 0.02},
                              legend={"x": 0.7, "y": 0.99, "bgcolor": "rgba(255,255,255,0.8)"}))
    return fig
