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
    from spherestep.demo import DEMO_FILES

    for name in DEMO_FILES:
        assert (out / name).stat().st_size > 100
    assert (out / "commutation_steps.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the three drives: relays settled and ramped, the servo; the servo within the targets
    modes = {m["mode"]: m for m in info["drives"]["modes"]}
    assert set(modes) == {"settled", "ramped", "servo"}
    assert modes["servo"]["time_s"] <= 2.0 and modes["servo"]["final_error_deg"] <= 0.05
    assert modes["servo"]["mean_power_W"] <= 100.0
    assert modes["servo"]["time_s"] < modes["ramped"]["time_s"] < modes["settled"]["time_s"]
    assert info["drives"]["bang_bang_bound_s"] <= modes["servo"]["time_s"]
    assert json.loads((out / "drives.json").read_text()) == info["drives"] | {"iron": info["iron_drives"]}
    # on the iron-cored model the servo turns the rotor within the supply; the relay drives are simulated and
    # counted (the paper's plan as settled and ramped steps, and a relay plan made on the iron model)
    iron = info["iron_drives"]
    assert iron["servo"]["final_error_deg"] <= 0.1 and iron["servo"]["peak_power_W"] <= 100.0
    assert 0 <= iron["potential_plan"]["moves"] <= iron["potential_plan"]["steps"]
    settled = iron["settled"]["details"]
    assert 0 <= settled["steps_settled_on_plan"] <= settled["steps"] == info["plan"]["steps"]
    assert settled["executed"] == (settled["steps_settled_on_plan"] == settled["steps"])
    assert [r for r, _ in iron["ramped"]["details"]["tried"]][:3] == [2.0, 5.0, 14.0]
    # capability of both cores, and what the iron changes
    assert info["capability"]["available_torque_N_m"]["50"] > 0
    assert info["iron"]["unpowered_minima"] > 0 and info["iron"]["detent_peak_Nm"] < 0
    text = (out / "report.html").read_text()
    # motor 3-D, histogram, commutation slider, simulated run, capability map, servo run
    assert f"<b>{info['plan']['steps']} steps</b>" in text and text.count("Plotly.newPlot(") == 6
    for anchor in ("capability", "iron", "drives", "servo"):
        assert f'id="section-{anchor}"' in text


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
