"""Shared parsing and printing for the command modules (light: no NumPy or library import at load time)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import typer
from rich.console import Console

from ..errors import InputError, bad_value

console = Console(width=None if sys.stdout.isatty() else 120, stderr=False)


def number(expected: str, low: float | None = None, high: float | None = None, *, low_open: bool = False,
           nonzero: bool = False, what: str | None = None):
    """A Typer option callback that checks a number while the command line is parsed, before any work: finite,
    in ``[low, high]`` (``(low, …`` with ``low_open``), non-zero if asked. ``expected`` states the quantity with
    its unit and range for the message, "--rate must be <expected>; instead received …" (exit 2); with
    ``what``, ``expected`` is just the unit and the message reads "<what> in <unit>, <range>"."""
    if what is not None:
        bounds = ([f"{'>' if low_open else '≥'} {low:g}"] if low is not None else []) + \
                 ([f"≤ {high:g}"] if high is not None else [])
        expected = f"{what} in {expected}" + (f", {' and '.join(bounds)}" if bounds else "")

    def check(ctx: typer.Context, param: typer.CallbackParam, value):
        if value is None or ctx.resilient_parsing:
            return value
        name = param.opts[0] if param.opts else param.name
        if isinstance(value, float) and not math.isfinite(value):
            raise bad_value(name, f"finite: {expected}", value)
        if (low is not None and (value < low or (low_open and value == low))) or \
                (high is not None and value > high) or (nonzero and value == 0):
            raise bad_value(name, expected, value)
        return value

    return check


TOLERANCE_HELP = ("Success is judged within this many degrees (default the run's own: 0.05° for a servo's end and a "
                  "hold, 0.5° for each relay step against its planned state); a run that misses it exits 1 naming "
                  "the first step or time that missed.")


def tolerance_option():
    """``--tolerance DEG``, the same on every command that moves a rotor (:mod:`spherestep.drive.judgement`, whose
    SERVO_TOLERANCE and RELAY_TOLERANCE the help states; a test holds them equal): degrees, > 0 and ≤ 180; left
    out (None), each run is judged by its own."""
    return typer.Option(None, "--tolerance", callback=number("degrees", 0, 180, low_open=True, what="the tolerance"),
                        help=TOLERANCE_HELP)


def parse_vector(text: str, name: str):
    """Parse ``"X,Y,Z"`` into a non-zero 3-vector; InputError naming ``name`` otherwise."""
    import numpy as np

    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        raise bad_value(name, "three comma-separated numbers like 1,0,0.5", text) from None
    vec = np.array(values)
    if vec.shape != (3,) or not np.all(np.isfinite(vec)) or not np.any(vec):
        raise bad_value(name, "three finite comma-separated numbers, not all zero, like 1,0,0.5", text)
    return vec


def check_axis(ctx: typer.Context, param: typer.CallbackParam, value):
    """Option callback: ``--axis X,Y,Z`` checked while parsing (the string is kept)."""
    if value is not None and not ctx.resilient_parsing:
        try:
            parse_vector(value, param.opts[0])
        except ValueError as exc:
            raise typer.BadParameter(str(exc).split(" ", 1)[1]) from None
    return value


def check_core(ctx: typer.Context, param: typer.CallbackParam, value):
    """Option callback: ``--core air|iron`` (None: the design's own core)."""
    if value is not None and value not in ("air", "iron") and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be air or iron (default: the core the design file states); instead received "
                                 f"{value!r}")
    return value


def input_file(path: Path, name: str) -> Path:
    """``path`` if it is an existing regular file (a FIFO would block the read, a folder or device cannot be
    parsed); InputError naming ``name`` otherwise."""
    if not path.exists():
        raise bad_value(name, "an existing file", str(path))
    if not path.is_file():
        raise bad_value(name, "a regular file (not a folder, pipe or device)", str(path))
    return path


def check_port(port: str, name: str = "--port") -> None:
    """Open and close the serial device ``port`` before any work (nothing driven, nothing written); InputError
    naming the option ``name`` and how to find the right device when it cannot be opened."""
    from ..hardware.serialport import open_port

    try:
        open_port(port, 115200, 0.1).close()
    except InputError as exc:
        error = InputError(f"{name}: {exc}")
        error.field = name
        raise error from None


def check_device(port: str, design, limits, name: str = "--port") -> None:
    """Open the current-mode device on ``port`` (protocol 2's HELLO), check that its supply and coils are the
    design's ``limits`` (:meth:`~spherestep.hardware.DriveInfo.check_drive`) and close it, every coil off — before
    any model or estimator is built, so a board wound or powered otherwise is refused in a second, not after the
    session's set-up; InputError naming ``name`` when the device does not answer as one."""
    from ..drive import connect
    from ..hardware import LinkError

    try:
        with connect(design, "port", port=port, limits=limits):
            pass
    except LinkError as exc:
        raise bad_value(name, "a spherestep coil controller (protocol 2) on that device", f"{port}: {exc}") from None


def design_from(path: Path | None, name: str = "--design"):
    """The design in the file at ``path`` (a regular file), or the built-in prototype."""
    from ..motor import MotorDesign, prototype

    return prototype() if path is None else MotorDesign.load(input_file(path, name))


def usable(design, option: str = "--design", path: Path | None = None):
    """``design`` if it can step; otherwise an InputError naming ``option`` (and the file ``path`` it came from,
    with the file's field names) that says why and what to change
    (:func:`spherestep.motor.diagnosis.unusable_reasons`)."""
    from ..motor.diagnosis import unusable_reasons

    if path is None:
        reasons = unusable_reasons(design)
    else:
        from ..design_file import file_field

        reasons = unusable_reasons(design, lambda name: file_field(name) or name)
    if reasons:
        where = f"{option} {str(path)!r}" if path is not None else f"{option} (design {design.name!r})"
        error = InputError(f"{where}: the design cannot step: {'; '.join(reasons)}")
        error.field = option
        raise error
    return design


def write_json(path: Path, data) -> Path:
    """Write ``data`` as indented JSON to ``path``, atomically; returns the path."""
    from ..atomic import write_text

    return write_text(path, json.dumps(data, indent=1))


def print_json(data) -> None:
    """Write ``data`` as JSON to stdout (for ``--json``)."""
    sys.stdout.write(json.dumps(data, indent=1, default=float) + "\n")
