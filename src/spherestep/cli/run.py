"""``spherestep run PLAN``: stream a commutation plan to the coil controller (or dry-run it)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import typer
from rich.table import Table

from ..commutation import Plan
from ..errors import InputError, bad_value
from ..hardware import DryRun, Serial, ThermalLimits, Transcript, play
from .app import app
from .common import console

_DEFAULT = ThermalLimits()


def _simulated(design_path, plan):
    """The :class:`Simulated` back end for ``plan``: the design's rotor under its magnets' torque map, tuned,
    starting at rest at the plan's first orientation."""
    from ..dynamics import tune
    from ..hardware import Simulated
    from ..magnetics import torque_map
    from .motor import design_from

    design = design_from(design_path)
    if len(design.stator) != plan.coil_count:
        raise bad_value("--design", f"the design the plan was made for ({plan.coil_count} coils)",
                        f"a design with {len(design.stator)} coils")
    model = torque_map(design)
    tuning = tune(design, model)
    return Simulated(design, model, plan.steps[0].achieved, rotor=tuning.rotor, dt=tuning.dt)


def _positive(value: float, flag: str, expected: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise bad_value(flag, expected, value)
    return value


def _save_log(transcript: Transcript, path: Path, during_error: bool) -> None:
    """Write the transcript; a failure is an error, or a warning when another error is being reported."""
    try:
        transcript.write(path)
    except OSError as exc:
        if not during_error:
            raise InputError(f"--log {str(path)!r} could not be written ({exc.strerror or exc}); "
                             "give a file in a writable folder") from None
        print(f"spherestep: warning: the log could not be written to {path} ({exc.strerror or exc})", file=sys.stderr)


@app.command()
def run(
    plan: Path = typer.Argument(..., help="Plan file: JSON written by `spherestep plan` or Plan.to_json."),
    port: str = typer.Option(None, "--port", help="Serial device of the coil controller: /dev/ttyUSB0, "
                                                   "/dev/ttyACM0, COM3 (not needed with --dry-run)."),
    rate: float = typer.Option(..., "--rate", help="Steps per second (Hz); each step is held for 1/RATE s."),
    dry_run: bool = typer.Option(False, "--dry-run", help="Send nothing; print what would be sent to a "
                                                          "controller with --channels channels."),
    simulate: bool = typer.Option(False, "--simulate", help="Run the plan on the simulated rotor (magnets' torque "
                                                            "map, tuned damping) instead of a device."),
    design_path: Path = typer.Option(None, "--design", help="With --simulate: the design file (default the "
                                                            "built-in prototype)."),
    channels: int = typer.Option(None, "--channels", help="With --dry-run: relay channels of the controller it "
                                                           "stands in for (default 32; a device reports its own)."),
    log: Path = typer.Option(None, "--log", help="Write every frame sent and received, time-stamped, to FILE "
                                                 "(also when the run fails)."),
    max_on: float = typer.Option(_DEFAULT.max_on, "--max-on", help="Longest a coil may stay on without a break "
                                                                   "(seconds)."),
    max_duty: float = typer.Option(_DEFAULT.max_duty, "--max-duty", help="Largest fraction of any duty window "
                                                                         "a coil may be on, in (0, 1]."),
    duty_window: float = typer.Option(_DEFAULT.window, "--duty-window", help="Length of the sliding window of "
                                                                             "--max-duty (seconds)."),
) -> None:
    """Stream a commutation plan to the coil controller, one step every 1/RATE seconds.

    The plan is checked against the coils' thermal limits before anything is switched.

    Every coil is switched off after the last step, on any error and on Ctrl-C.

    The controller's watchdog switches them off if the host falls silent (protocol: docs/protocol.md).

    Example: [bold]spherestep run plan.json --port /dev/ttyUSB0 --rate 5 --log run.log[/bold]

    Example: [bold]spherestep run plan.json --rate 5 --dry-run --channels 64[/bold]

    Example: [bold]spherestep run plan.json --rate 0.8 --simulate[/bold]
    """
    if dry_run and simulate:
        raise bad_value("--dry-run/--simulate", "at most one of the two", "both")
    if design_path is not None and not simulate:
        raise bad_value("--design", "given only with --simulate", str(design_path))
    if simulate:
        port = port or "simulated"
    if not dry_run and port is None:
        raise bad_value("--port", "the controller's serial device, such as /dev/ttyUSB0 (or give --dry-run)", None)
    if channels is not None and not dry_run:
        raise bad_value("--channels", "given only with --dry-run (a device reports its own channel count)", channels)
    if channels is not None and not 1 <= channels <= 64:
        raise bad_value("--channels", "a channel count 1..64", channels)
    _positive(rate, "--rate", "a positive number of steps per second, such as 5")
    _positive(max_on, "--max-on", "a positive number of seconds")
    _positive(duty_window, "--duty-window", "a positive number of seconds")
    if not (0 < max_duty <= 1):
        raise bad_value("--max-duty", "a fraction in (0, 1], such as 0.5", max_duty)
    if log is not None and log.is_dir():
        raise bad_value("--log", "a file name, not a folder", str(log))
    steps = Plan.from_json(plan)
    limits = ThermalLimits(max_on=max_on, max_duty=max_duty, window=duty_window)
    transcript = Transcript()
    if dry_run:
        backend = DryRun(channels=32 if channels is None else channels, transcript=transcript)
    elif simulate:
        backend = _simulated(design_path, steps)
    else:
        backend = Serial(port, transcript=transcript)
    try:
        report = play(steps, backend, rate, limits)
    except BaseException as exc:
        if log is not None:
            _save_log(transcript, log, during_error=True)
        if isinstance(exc, KeyboardInterrupt):  # the coils are off by now; report it as an interruption
            raise typer.Abort() from None
        raise
    if log is not None:
        _save_log(transcript, log, during_error=False)
    dev = report.device
    if dry_run:
        table = Table(title=f"dry run of {plan.name}")
        for col in ("t (s)", "enable", "polarity", "coils"):
            table.add_column(col, justify="right" if col == "t (s)" else "left", no_wrap=True)
        for s in backend.sent:
            coils = " ".join(f"{k}{'+' if v > 0 else '-'}" for k, v in sorted(s.coils.items())) or "all off"
            table.add_row(f"{s.t:.3f}", hex(s.enable), hex(s.polarity), coils)
        console.print(table)
        print(f"dry run: {report.steps} steps at {rate:g} Hz would take {report.elapsed:.3f} s on a "
              f"{dev.channels}-channel controller; nothing was sent")
        return
    if simulate:
        from .. import so3

        settled = np.array([R for _, R in backend.orientations])
        planned = steps.achieved[:len(settled)]  # play holds every step, the first one included
        err = np.degrees(so3.distance(settled, planned))
        print(f"simulated {report.steps} steps at {rate:g} Hz ({report.elapsed:.1f} s of rotor time): "
              f"{int(np.sum(err <= 0.5))} settled within 0.5° of the plan (median {np.median(err):.2f}°, "
              f"max {err.max():.2f}°); all coils off")
        return
    stats = backend.stats
    print(f"streamed {report.steps} steps at {rate:g} Hz to {port} (device {dev.name!r}, protocol {dev.protocol}, "
          f"{dev.channels} channels) in {report.elapsed:.3f} s: {stats['acked']} frames acknowledged, "
          f"{stats['retransmissions']} retransmissions, worst step lateness {report.max_lag * 1000:.1f} ms; "
          "all coils off")
