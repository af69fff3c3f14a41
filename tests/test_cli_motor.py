"""The demo and plan commands, end to end."""

import json

from spherestep.cli import main


def test_demo_writes_plan_figures_and_summary(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["demo", "--out", str(out), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["states"] > 1000 and info["reaches_all"] is True
    assert info["plan"]["error_final_deg"] < info["resolution_p95_deg"]
    for name in ("plan.csv", "plan.json", "commutation_steps.png", "motor_3d.png", "plan_error.png", "summary.json"):
        assert (out / name).stat().st_size > 100
    assert (out / "commutation_steps.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


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
