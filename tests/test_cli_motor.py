"""The demo and plan commands, end to end."""

import json

from spherestep.cli import main


def test_demo_writes_plan_figures_simulation_and_report(tmp_path, capsys):
    """The main job, quietly: summary, plan, figures, the simulated run and the HTML report."""
    out = tmp_path / "out"
    assert main(["demo", "--out", str(out), "--quiet"]) == 0
    assert capsys.readouterr().out == ""
    info = json.loads((out / "summary.json").read_text())
    assert info["states"] > 1000 and info["reaches_all"] is True
    assert info["plan"]["error_final_deg"] < info["resolution_p95_deg"]
    sim = info["simulation"]
    assert sim["steps"] == info["plan"]["steps"] and sim["final_error_to_target_deg"] < info["resolution_p95_deg"]
    for name in ("plan.csv", "plan.json", "commutation_steps.png", "motor_3d.png", "plan_error.png", "summary.json",
                 "trajectory.csv", "simulation.png", "report.html"):
        assert (out / name).stat().st_size > 100
    assert (out / "commutation_steps.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = (out / "report.html").read_text()
    # motor 3-D, histogram, commutation slider, simulated run
    assert f"<b>{info['plan']['steps']} steps</b>" in text and text.count("Plotly.newPlot(") == 4


def test_plan_command_and_bad_input(tmp_path, capsys):
    assert main(["plan", "--axis", "0,1,1", "--angle", "60", "--steps", "8", "--out", str(tmp_path), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["steps"] == 8
    for args in (["plan", "--axis", "1,2", "--angle", "10"], ["plan", "--axis", "0,0,0", "--angle", "10"],
                 ["plan", "--axis", "1,0,0", "--angle", "nan"], ["plan", "--axis", "1,0,0"],
                 ["plan", "--axis", "1,0,0", "--angle", "10", "--steps", "0"], ["nonsense"]):
        assert main(args + ["--out", str(tmp_path / "x")]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err and err.startswith("spherestep: error:")
    assert not (tmp_path / "x").exists()
