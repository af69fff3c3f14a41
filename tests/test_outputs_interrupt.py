"""An output set is complete or absent (issue 27 §3): Ctrl-C removes what it wrote, a full disk leaves no empty
folder that the command created, and a folder that was there before stays."""

import errno

import pytest

from spherestep.atomic import write_text
from spherestep.errors import ComputationError
from spherestep.outputs import Outputs


def test_interrupt_removes_the_files_and_the_folder_it_created(tmp_path):
    out = tmp_path / "new"
    with pytest.raises(KeyboardInterrupt):
        with Outputs(out, ["a.csv", "b.csv", "c.json"]):
            write_text(out / "a.csv", "1\n")
            write_text(out / "b.csv", "2\n")
            raise KeyboardInterrupt
    assert not out.exists()


def test_interrupt_keeps_a_folder_that_existed_and_files_not_of_the_set(tmp_path):
    out = tmp_path / "old"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    with pytest.raises(KeyboardInterrupt):
        with Outputs(out, ["a.csv"]):
            write_text(out / "a.csv", "1\n")
            raise KeyboardInterrupt
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt"]


def test_full_disk_leaves_no_empty_folder_and_says_how_many(tmp_path):
    out = tmp_path / "new"
    with pytest.raises(ComputationError, match=r"the disk is full.*0 of 2 files written"):
        with Outputs(out, ["a.csv", "b.csv"]):
            out.mkdir()
            raise OSError(errno.ENOSPC, "No space left on device")
    assert not out.exists()


def test_a_failure_after_a_swallowed_signal_removes_the_set_too(tmp_path):
    """A Ctrl-C during numba's first compile is swallowed by llvmlite's callback and the compile then fails with
    an unrelated error ("no compiled object yet"): with the signal recorded (spherestep.cli.signals records every
    one), that failure removes the set like the interrupt itself; without a signal it leaves the files it wrote."""
    from spherestep.interrupts import note_signal

    out = tmp_path / "new"
    note_signal("SIGINT")
    try:
        with pytest.raises(RuntimeError):
            with Outputs(out, ["a.csv", "b.csv"]):
                write_text(out / "a.csv", "1\n")
                raise RuntimeError("no compiled object yet")
    finally:
        note_signal(None)
    assert not out.exists()
    with pytest.raises(RuntimeError):
        with Outputs(out, ["a.csv", "b.csv"]):
            write_text(out / "a.csv", "1\n")
            raise RuntimeError("a failure of its own")
    assert (out / "a.csv").exists()


def test_an_interrupt_python_could_not_propagate_is_raised_again(monkeypatch, capsys, request):
    """llvmlite's callback during numba's first compile swallows a Ctrl-C (Python hands it to
    ``sys.unraisablehook``): the CLI's hook delivers the signal to the main thread again, so the command stops
    instead of running on (a fresh install's ``calibrate`` did), and prints no 'Exception ignored' traceback."""
    import signal
    import sys
    import time

    from spherestep.cli import main
    from spherestep.cli.signals import sigterm_as_interrupt

    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)  # restored after the test
    # Ctrl-C's default handler, as a command started from a terminal has it (make test may run with SIGINT
    # ignored by inheritance: a background job of a non-interactive shell)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    request.addfinalizer(lambda: signal.signal(signal.SIGINT, previous))
    main(["packings"])  # any command: main installs the CLI's hook
    capsys.readouterr()

    class Swallowed:
        def __del__(self):
            raise KeyboardInterrupt

    with sigterm_as_interrupt() as received:
        with pytest.raises(KeyboardInterrupt):
            Swallowed()  # dropped at once: its __del__'s interrupt cannot propagate
            deadline = time.monotonic() + 2.0
            while time.monotonic() < deadline:  # the signal comes back at a bytecode boundary
                pass
    assert received.name == "SIGINT"
    assert "Exception ignored" not in capsys.readouterr().err
