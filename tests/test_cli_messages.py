"""Messages worded with the field's own name and unit (issue 40 §7): the design file's ``tolerance`` (not the
library's ``tol``) whichever command refuses it, ``--samples`` without "a number of orientations in orientations",
the calibration's residuals in a readable unit, ``design show`` keeping a long file name whole."""

from __future__ import annotations

import pytest

from spherestep.cli import main
from spherestep.magnetics.calibrated import torque_text
from spherestep.gallery import entry

TEXT = entry("jhu-as-built").path.read_text()


@pytest.fixture
def tol20(tmp_path):
    lines = [line for line in TEXT.splitlines() if not line.lstrip().startswith("tolerance")]
    path = tmp_path / "tol20.yaml"
    path.write_text("\n".join(lines) + "\ntolerance: 20 deg\n")
    return path


@pytest.mark.parametrize("argv", [["capability", "--samples", "10"], ["sense", "--samples", "1"],
                                  ["move", "--axis", "0,0,1", "--angle", "5"], ["forces"]])
def test_design_file_fields_keep_their_names(tol20, tmp_path, capsys, argv):
    assert main([*argv, "--design", str(tol20), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--design" in err and str(tol20) in err
    assert "tolerance 20°" in err and "make tolerance smaller than 11.6°" in err and "tol " not in err


def test_samples_message_says_it_once(tmp_path, capsys):
    assert main(["capability", "--samples", "0", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "--samples must be a whole number of orientations from 1 to 200000; instead received 0" in err
    assert "orientations in orientations" not in err


@pytest.mark.parametrize("value, text", [(1.0928, "1.09 N·m"), (0.044076, "44.1 mN·m"), (12.34, "12.3 N·m"),
                                         (0.0336, "33.6 mN·m"), (2.5e-5, "0.025 mN·m")])
def test_torque_text(value, text):
    assert torque_text(value) == text


def test_design_show_keeps_a_long_file_name_whole(tmp_path, capsys):
    path = tmp_path / ("a-design-file-with-a-name-long-enough-to-be-wrapped-by-the-table-title-" * 2 + "end.yaml")
    path.write_text(TEXT)
    assert main(["design", "show", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"jhu-as-built ({path})" in out.splitlines()[0]
