"""The emulated loop says how it ran (issue 27 §1): its rate, missed deadlines and host CPU per cycle are in
``move.json`` and in the console summary, whatever the machine's load made of them (the verdict on the rate
itself is test_hardware_servo.py's)."""

import json
import re

import pytest

from spherestep.cli import main


@pytest.mark.slow
def test_move_emulate_reports_rate_missed_deadlines_and_cpu(tmp_path, capsys):
    code = main(["move", "--axis", "1,0.5,2", "--angle", "10", "--emulate", "--out", str(tmp_path)])
    captured = capsys.readouterr()
    assert code in (0, 1), captured.err  # 1: a starved machine ended it outside the tolerance, and said so

    def refuse(name):
        raise AssertionError(f"{name} in move.json")

    d = json.loads((tmp_path / "move.json").read_text(), parse_constant=refuse)["details"]
    assert d["loop_rate_Hz"] == 500 and 0 < d["rate_Hz"] <= 500 * 1.01
    assert isinstance(d["missed"], int) and d["missed"] >= 0 and d["cpu_per_cycle_ms"] > 0
    line = next(x for x in captured.out.splitlines() if x.startswith("loop: "))
    m = re.search(r"at (\d+) Hz \((\d+) deadlines missed(?: \((\d+) woken late by the OS\))?, (\d+) readings? late, "
                  r"([\d.]+) ms CPU per cycle", line)
    assert m, line
    assert (int(m.group(1)), int(m.group(2))) == (round(d["rate_Hz"]), d["missed"])
    assert int(m.group(3) or 0) == d["late_wakeups"] <= d["missed"] and int(m.group(4)) == d["late_readings"]
    assert float(m.group(5)) == pytest.approx(d["cpu_per_cycle_ms"], abs=0.006)


@pytest.mark.realtime
def test_a_fresh_install_compiles_before_the_loop(tmp_path):
    """On an empty numba cache (a fresh install) the first ``move --emulate`` compiled the law's first-order
    ``K``, ``b`` carry in the loop's first period (0.7 s) and the device's watchdog (100 ms) ended the run after 0
    cycles (this test failed so); every first call is now made when the law is built."""
    import os
    import subprocess
    import sys

    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    done = subprocess.run([sys.executable, "-c", "from spherestep.cli import main; main()", "move", "--axis", "1,0.5,2",
                           "--angle", "360", "--emulate", "--json", "--out", str(tmp_path / "move")], env=env,
                          capture_output=True, text=True, timeout=900)
    d = json.loads((tmp_path / "move" / "move.json").read_text())["details"]
    assert d["outcome"] == "done" and d["cycles"] > 100, (d["outcome"], d["message"], done.stderr[-2000:])
