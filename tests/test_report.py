"""The HTML report without a browser: self-contained, complete, atomic, bounded in size; and its CLI."""

import json
import math
import re
from html.parser import HTMLParser

import numpy as np
import plotly.offline
import pytest

from spherestep import so3
from spherestep.cli import main
from spherestep.commutation import about_axis, plan_geometric
from spherestep.dynamics import Rotor, simulate
from spherestep.errors import InputError
from spherestep.harmonics import so3_grid
from spherestep.motor import DesignMetrics
from spherestep.report import (MAX_FRAMES, build_report, energy_figure, frame_steps, resolution_distances,
                               trajectory_figure, write_report)

AXIS = np.array([1.0, 0.5, 2.0])
PLOTLY_JS = len(plotly.offline.get_plotlyjs())

# metrics of a design without states: the report leaves out what needs them
NO_STATES = DesignMetrics(states=0, samples=0, max_step_rad=0.2, resolution_median_rad=math.inf,
                          resolution_p95_rad=math.inf, resolution_max_rad=math.inf, range_fraction=0.0,
                          state_graph_components=0, reaches_all=False, held_pairs_histogram=(),
                          escape_violations=None)


class Wells:
    """``V(R, c) = −A Σ_jk p_j c_k exp(κ((R u_j)·v_k − 1))`` and its torque: a small analytic rotor model."""

    def __init__(self, design, amplitude=2.0, kappa=16.0):
        self.u, self.p, self.v = design.rotor.centers, design.polarity, design.stator.centers
        self.A, self.k = amplitude, kappa

    def energy(self, R, c):
        t = np.einsum("kij,mj,ni->kmn", R, self.u, self.v)
        return -self.A * np.einsum("m,kn,kmn->k", self.p, c, np.exp(self.k * (t - 1)))

    def torque(self, R, c):
        Ru = np.einsum("kij,mj->kmi", R, self.u)
        w = self.A * self.k * np.exp(self.k * (Ru @ self.v.T - 1)) * self.p[None, :, None] * c[:, None, :]
        return np.cross(Ru, w @ self.v).sum(axis=1)


class Loads(HTMLParser):
    """Every URL the markup would load or link (src, href, srcset, CSS url(...)), and the inline scripts."""

    def __init__(self):
        super().__init__()
        self.urls, self.scripts, self.tags, self._in = [], [], [], None

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self._in = tag
        for name, value in attrs:
            if name in ("src", "href", "srcset", "data", "poster", "action") and value is not None:
                self.urls.append(value)

    def handle_endtag(self, tag):
        self._in = None

    def handle_data(self, data):
        if self._in == "script":
            self.scripts.append(data)
        elif self._in == "style":
            self.urls += re.findall(r"url\(\s*['\"]?([^'\")]+)", data) + re.findall(r"@import\s+['\"]([^'\"]+)", data)


@pytest.fixture(scope="module")
def plan50(proto):
    start = proto.states().rotations[int(proto.states().nearest(np.eye(3))[1].ravel()[0])]
    return plan_geometric(proto, about_axis(AXIS, 2 * math.pi, 50, start=start))


@pytest.fixture(scope="module")
def report50(proto, proto_metrics, plan50, tmp_path_factory):
    path = tmp_path_factory.mktemp("report") / "report.html"
    info = write_report(path, proto, proto_metrics, plan50, axis=AXIS, seed=7)
    return path, info, path.read_text(encoding="utf-8")


def test_report_is_self_contained(report50):
    _, info, text = report50
    page = Loads()
    page.feed(text)
    remote = [u for u in page.urls if re.match(r"\s*(https?:)?//", u, re.I)]
    assert remote == []
    assert all(u.startswith("#section-") for u in page.urls)  # the table of contents only
    assert "link" not in page.tags and "iframe" not in page.tags and "img" not in page.tags
    # plotly.js itself is inline, once, and every figure is drawn by an inline script
    assert sum("plotly.js v" in s for s in page.scripts) == 1
    assert max(len(s) for s in page.scripts) >= PLOTLY_JS
    assert text.count("Plotly.newPlot(") == 3 and info["sections"] == ["motor", "design", "resolution", "commutation"]


def test_report_has_every_step_and_stays_small(report50, plan50):
    path, info, text = report50
    assert info["plan_steps"] == 50 and info["frames"] == 51 == len(plan50.steps)
    assert "<b>50 steps</b>" in text
    assert [int(i) for i in re.findall(r'<tr id="step-(\d+)"', text)] == list(range(51))
    frames, _ = json.JSONDecoder().raw_decode(text, text.index("Plotly.addFrames('commutation', ") + 32)
    assert [f["name"] for f in frames] == [str(i) for i in range(51)]
    assert text.count('"method":"animate"') == 51 + 2  # a slider step per plan step, play and pause
    # the table's target turn: the plan asks for 360°/50 per step about the axis
    targets = [float(m) for m in re.findall(r'<tr id="step-\d+"[^>]*><td class=num>\d+</td><td>[^<]*</td>'
                                            r'<td class=num>(-?[\d.]+)</td>', text)]
    assert np.allclose(targets, np.linspace(0, 360, 51), atol=0.006)
    # everything but plotly.js: under 1 MB for 50 steps (plotly.js is ~4.7 MB)
    assert info["bytes"] == path.stat().st_size
    assert info["bytes"] - PLOTLY_JS < 1_000_000, info["bytes"] - PLOTLY_JS


@pytest.mark.slow
def test_long_plans_are_animated_on_evenly_spaced_steps(proto):
    assert list(frame_steps(51)) == list(range(51))
    shown = frame_steps(10_001)
    assert len(shown) == MAX_FRAMES and shown[0] == 0 and shown[-1] == 10_000
    assert np.all(np.diff(shown) >= 41) and np.all(np.diff(shown) <= 42)
    start = proto.states().rotations[0]
    plan = plan_geometric(proto, about_axis(AXIS, 8 * math.pi, 2 * MAX_FRAMES, start=start))
    text, info = build_report(proto, NO_STATES, plan, axis=AXIS)
    assert info["frames"] == MAX_FRAMES and f"{MAX_FRAMES} evenly spaced steps of {2 * MAX_FRAMES + 1}" in text
    assert len(text) - PLOTLY_JS < 3_500_000


def test_histogram_draws_the_metrics_samples(proto, proto_metrics):
    dist = resolution_distances(proto, 20_000, 7)
    assert np.median(dist) == proto_metrics.resolution_median_rad
    assert np.quantile(dist, 0.95) == proto_metrics.resolution_p95_rad


def test_simulation_and_energy_map_sections(proto, tmp_path):
    start = proto.states().rotations[0]
    plan = plan_geometric(proto, about_axis(AXIS, math.radians(40), 5, start=start))
    model = Wells(proto)
    sim = simulate(proto, plan, model, dwell=0.8, rotor=Rotor.from_design(proto, damping=0.6), dt=1e-3, record_every=20)
    a = np.radians(np.linspace(-20, 20, 21))
    rotations = so3.exp(np.stack([*np.meshgrid(a, a, indexing="ij"), np.zeros((21, 21))], -1)) @ plan.steps[1].achieved
    c = np.zeros(len(proto.stator))
    for k, sign in plan.steps[1].coils.items():
        c[k] = sign
    energy = model.energy(rotations.reshape(-1, 3, 3), np.broadcast_to(c, (21 * 21, len(c)))).reshape(21, 21).T
    grid = {"x": np.degrees(a), "y": np.degrees(a), "energy": energy, "x_label": "about x (°)", "title": "well"}
    info = write_report(tmp_path / "r.html", proto, NO_STATES, plan, sim, grid)
    assert info["sections"] == ["motor", "design", "commutation", "simulation", "energy"]
    text = (tmp_path / "r.html").read_text()
    assert "Energy map" in text and "Simulated run" in text and '"text":"well"' in text
    # the trajectory: the planned angle ends at the plan's last state, the simulation settles near it
    fig = trajectory_figure(sim, AXIS / np.linalg.norm(AXIS), plan.targets)
    desired, planned, simulated = fig.data[0], fig.data[1], fig.data[2]
    assert desired.y[-1] == pytest.approx(40.0, abs=1e-4)
    assert abs(simulated.y[-1] - planned.y[-1]) < 3.0
    assert len(simulated.x) == len(sim.times) and simulated.x[-1] == pytest.approx(sim.times[-1])
    with pytest.raises(InputError, match="energy_map"):
        build_report(proto, NO_STATES, energy_map={"energy": np.zeros(5)})
    with pytest.raises(InputError, match="energy_map"):
        build_report(proto, NO_STATES, energy_map={"energy": np.zeros((3, 4)), "x": np.arange(3)})


def test_report_is_written_atomically(proto, tmp_path):
    path = tmp_path / "report.html"
    path.write_text("old report")
    old = path.open("rb")
    with pytest.raises(InputError):
        write_report(path, proto, NO_STATES, energy_map={"energy": None})
    assert path.read_text() == "old report" and sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]
    write_report(path, proto, NO_STATES)
    # the new file replaced the old one by rename: a reader of the old file still sees all of it
    assert old.read() == b"old report"
    old.close()
    assert path.read_text().endswith("</html>\n") and sorted(p.name for p in tmp_path.iterdir()) == ["report.html"]


@pytest.mark.slow
def test_cli_report(tmp_path, capsys):
    design = tmp_path / "motor.yaml"
    assert main(["design", "new", str(design)]) == 0
    capsys.readouterr()
    out = tmp_path / "sub" / "r.html"
    assert main(["report", str(design), "-o", str(out), "--axis", "0,1,1", "--angle", "30", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["path"] == str(out) and out.stat().st_size == info["bytes"]
    assert info["plan_steps"] >= 2 and info["frames"] == info["plan_steps"] + 1
    assert np.allclose(info["axis"], np.array([0, 1, 1]) / math.sqrt(2)) and info["angle_deg"] == 30
    assert f"<b>{info['plan_steps']} steps</b>" in out.read_text()


@pytest.mark.parametrize("args", [
    ["missing.yaml"], ["--axis", "1,2"], ["--axis", "0,0,0"], ["--angle", "nan"], ["--angle", "0"], ["-o", "."],
    ["--bogus"],
])
def test_cli_report_bad_input(args, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["report"] + args) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("spherestep: error:") and "Traceback" not in err
    assert not (tmp_path / "report.html").exists()


def test_energy_map_from_an_euler_grid(proto):
    grid = so3_grid(6)
    c = np.zeros(len(proto.stator))
    c[[0, 1]] = 1, -1
    rotations = grid.rotations()
    values = Wells(proto).energy(rotations.reshape(-1, 3, 3), np.broadcast_to(c, (rotations[..., 0, 0].size, len(c))))
    values = values.reshape(rotations.shape[:3])
    heat = energy_figure((grid, values)).data[0]
    assert np.allclose(heat.x, np.degrees(grid.alpha)) and np.allclose(heat.y, np.degrees(grid.beta))
    assert np.allclose(heat.z, values.min(axis=2).T, rtol=1e-6)  # lowest over γ, rows β
    with pytest.raises(InputError, match="energy_map"):
        energy_figure((grid, values[:, :, :3]))


@pytest.mark.slow
def test_extra_sections_are_appended_in_order(proto, tmp_path):
    import plotly.graph_objects as go

    from spherestep.errors import InputError
    from spherestep.report import Section

    extra = (Section("servo", "Servo run", note="a note", figure=go.Figure(go.Scatter(x=[0, 1], y=[1, 2]))),
             Section("iron", "Iron", html="<p>table</p>"))
    metrics = proto.metrics(samples=500, seed=0)
    info = write_report(tmp_path / "r.html", proto, metrics=metrics, sections=extra)
    assert info["sections"][-2:] == ["servo", "iron"]
    text = (tmp_path / "r.html").read_text()
    assert 'id="section-servo"' in text and "<p>table</p>" in text and 'id="servo"' in text
    with pytest.raises(InputError, match="^sections must be"):
        write_report(tmp_path / "s.html", proto, metrics=metrics, sections=("nope",))
    assert not (tmp_path / "s.html").exists()
