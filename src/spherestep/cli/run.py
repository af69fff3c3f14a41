"""``spherestep run PLAN``: stream a commutation plan to the coil controller (or dry-run or simulate it).

The operator's path: every option and the plan are checked before anything is switched; the log (``--log``)
is written line by line as the run goes, so a killed run leaves its evidence; SIGTERM (``timeout``, systemd,
``kill``) is handled like Ctrl-C — every coil off, then exit (130 for SIGINT, 143 for SIGTERM); the last line
always states the final coil state.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import typer

from ..errors import InputError, bad_value
from .app import app
from .common import console, number, print_json, tolerance_option
from .progress import progress
from .signals import Terminated, exit_code, interrupt_of, sigterm_as_interrupt, signal_name, told

LOG_LINE = re.compile(r"^\s*-?\d+\.\d{6} (TX|RX|NOTE) ")  # a line of Transcript.lines()


def check_log(path: Path, force: bool) -> Path:
    """``--log``: a writable file; an existing file that is not a spherestep log is kept unless ``--force``."""
    from ..outputs import output_file

    path = output_file(path, "--log")
    if path.exists() and path.stat().st_size and not force:
        with open(path, "rb") as f:
            first = f.readline(200).decode("utf-8", "replace")
        if not LOG_LINE.match(first):
            raise InputError(f"--log {str(path)!r} exists and is not a spherestep log; give --force to overwrite it, "
                             "or another file name")
    return path


def _design_for(design_path, plan):
    """The design of ``--design`` (default the prototype), refused unless ``plan`` was made for it: its coil count
    and its fingerprint (the coil and magnet numbering, :meth:`Plan.check_design`)."""
    from .common import design_from

    design = design_from(design_path)
    if len(design.stator) != plan.coil_count:
        raise bad_value("--design", f"the design the plan was made for ({plan.coil_count} coils)",
                        f"a design with {len(design.stator)} coils")
    plan.check_design(design)
    return design


def _simulated(design, plan):
    """The simulated relay back end's options for ``plan`` (:func:`spherestep.drive.connect`, kind
    ``"simulated"``): the ``design``'s rotor under its own torque model (:func:`spherestep.magnetics.design_model`:
    iron for the prototype), tuned, starting at rest at the plan's first orientation."""
    from ..dynamics import tune
    from ..magnetics import design_model

    model = design_model(design).model
    tuning = tune(design, model)
    return {"plant": model, "R0": plan.steps[0].achieved, "rotor": tuning.rotor, "dt": tuning.dt}


def _progress(total: int, show: bool):
    """Live progress on stderr (step counter, energised coils) as ``on_step`` for :func:`play`."""
    if not show:
        return None, None
    from rich.console import Console
    from rich.live import Live

    live = Live("", console=Console(stderr=True), transient=True, refresh_per_second=8)

    def on_step(i, step):
        coils = " ".join(f"{k}{'+' if v > 0 else '-'}" for k, v in sorted(step.coils.items())) or "none"
        live.update(f"step {i + 1} of {total}: coils {coils}")

    return live, on_step


@app.command()
def run(
    plan: Path = typer.Argument(..., help="Plan file: JSON written by `spherestep plan` or Plan.to_json."),
    port: str = typer.Option(None, "--port", help="Serial device of the coil controller: /dev/ttyUSB0, "
                                                   "/dev/ttyACM0, COM3 (not needed with --dry-run)."),
    rate: float = typer.Option(..., "--rate", callback=number("a positive number of steps per second (Hz), at most 1000", 0, 1000, low_open=True),
                               help="Steps per second (Hz); each step is held for 1/RATE s."),
    dry_run: bool = typer.Option(False, "--dry-run", help="Send nothing; print what would be sent to a "
                                                          "controller with --channels channels."),
    simulate: bool = typer.Option(False, "--simulate", help="Run the plan on the simulated rotor (the design's own torque "
                                                            "model, tuned damping) instead of a device."),
    design_path: Path = typer.Option(None, "--design", help="The design the plan was made for (default the "
                                                            "built-in prototype with --simulate): the plan is refused "
                                                            "unless it names this design's coil numbering."),
    channels: int = typer.Option(None, "--channels", help="With --dry-run: relay channels of the controller it "
                                                           "stands in for, 1..64 (default: as many as the plan "
                                                           "uses; a device reports its own)."),
    log: Path = typer.Option(None, "--log", help="Write every frame sent and received, time-stamped, to FILE as "
                                                 "the run goes (also when it fails or is stopped)."),
    force: bool = typer.Option(False, "--force", help="Let --log overwrite a file that is not a spherestep log."),
    max_on: float = typer.Option(None, "--max-on", callback=number("a positive number of seconds", 0, low_open=True),
                                 help="Longest a coil may stay on without a break (seconds; default 5)."),
    max_duty: float = typer.Option(None, "--max-duty", help="Largest fraction of any duty window a coil may be "
                                                            "on, in (0, 1] (default 0.5)."),
    duty_window: float = typer.Option(None, "--duty-window", callback=number("a positive number of seconds", 0, low_open=True),
                                      help="Length of the sliding window of --max-duty (seconds; default 30)."),
    tolerance: float = tolerance_option(),
    as_json: bool = typer.Option(False, "--json", help="Print the result as JSON."),
) -> None:
    """Stream a commutation plan to the coil controller, one step every 1/RATE seconds.

    The plan is checked against the coils' thermal limits before anything is switched.

    Every coil is switched off after the last step, on any error, on Ctrl-C and on SIGTERM.

    With --simulate each step is judged: exit status 1 when one settles more than --tolerance (default 0.5°) off
    its planned state. A device reports no orientation, so on a port (and in a dry run) the judgement is that
    every frame was acknowledged, and --tolerance is refused there.

    The controller's watchdog switches them off if the host falls silent (protocol: docs/protocol.md).

    Example: [bold]spherestep run plan.json --port /dev/ttyUSB0 --rate 5 --log run.log[/bold]

    Example: [bold]spherestep run plan.json --rate 5 --dry-run --channels 64[/bold]

    Example: [bold]spherestep run plan.json --rate 0.8 --simulate --design examples/designs/relays-iron.yaml[/bold]

    An iron plan holds a coil for several steps: plan it for the rate it will run at (`spherestep plan ... --rate
    0.8`), or the thermal check may refuse it.
    """
    if dry_run and simulate:
        raise bad_value("--dry-run/--simulate", "at most one of the two", "both")
    if port is not None and (dry_run or simulate):  # a port given with them would be silently ignored
        option = "--dry-run" if dry_run else "--simulate"
        raise bad_value("--port", f"left out with {option} (it sends nothing to a device); drop --port or "
                        f"{option}", port)
    if tolerance is not None and not simulate:
        raise bad_value("--tolerance", "given only with --simulate (a device reports no orientation to judge; on a "
                        "port every frame must be acknowledged)", tolerance)
    if simulate:
        port = "simulated"
    if not dry_run and port is None:
        raise bad_value("--port", "the controller's serial device, such as /dev/ttyUSB0 (or give --dry-run)", None)
    if channels is not None and not dry_run:
        raise bad_value("--channels", "given only with --dry-run (a device reports its own channel count)", channels)
    if channels is not None and not 1 <= channels <= 64:
        raise bad_value("--channels", "a channel count 1..64", channels)
    if max_duty is not None and not (0 < max_duty <= 1):
        raise bad_value("--max-duty", "a fraction in (0, 1], such as 0.5", max_duty)
    from ..commutation import Plan
    from ..drive.connect import connect
    from ..hardware import ThermalLimits, Transcript, play

    if log is not None:
        log = check_log(log, force)
    steps = Plan.from_json(plan)
    if simulate:  # refused before anything is built or switched
        from .common import usable

        simulated = usable(_design_for(design_path, steps), "--design", design_path)
    elif design_path is not None:
        _design_for(design_path, steps)  # refused before anything is switched
    given = {"max_on": max_on, "max_duty": max_duty, "window": duty_window}
    limits = ThermalLimits(**{k: v for k, v in given.items() if v is not None})
    limits.check_plan(steps, rate)  # refused before a log is opened or the device touched
    needed = int(steps.channel_map.max()) + 1
    if log is not None:
        log.parent.mkdir(parents=True, exist_ok=True)
    sink = open(log, "w", encoding="utf-8") if log is not None else None  # noqa: SIM115 (closed below)
    transcript = Transcript(sink=sink)
    outcome = "all coils off"
    live, on_step = _progress(len(steps.steps), show=not as_json and sys.stderr.isatty())
    try:
        with sigterm_as_interrupt():
            if dry_run:
                design, options = None, {"channels": needed if channels is None else channels,
                                         "transcript": transcript}
            elif simulate:
                with progress("building the torque model and tuning the rotor", enabled=not as_json):
                    design, options = simulated, _simulated(simulated, steps)
            else:
                design, options = None, {"port": port, "transcript": transcript}
            kind = "dry run" if dry_run else "simulated" if simulate else "relay port"
            with connect(design, kind, channel_map=steps.channel_map, **options) as conn:
                backend = conn.link.backend
                if live is not None:
                    live.start()
                try:  # a simulation in a pipe or a log: plain lines, at most one per 10 s, never 10 s silent (a
                    # port's stream keeps stderr for its one closing line; its --log records every frame as it goes)
                    stage = f"streaming the plan at {rate:g} Hz: step"
                    with progress(stage, enabled=live is None and not as_json and simulate) as say:
                        if live is None:
                            def on_step(i, step, say=say):
                                say(stage, done=i + 1, total=len(steps.steps))
                        report = play(steps, conn.link, rate, limits, on_step=on_step)
                finally:
                    if live is not None:
                        live.stop()
        acknowledged = "all coils off, acknowledged by the device" if not (dry_run or simulate) else outcome
        transcript.add(backend.clock(), "NOTE", f"end: {len(steps.steps)} frames streamed; {acknowledged}")
    except BaseException as exc:
        interrupt = interrupt_of(exc)  # also one inside a compiled call (a SystemError with it as its context)
        why = {Terminated: "stopped by SIGTERM", KeyboardInterrupt: "interrupted by Ctrl-C"}.get(type(interrupt), None)
        transcript.add(transcript.entries[-1][0] if transcript.entries else 0.0, "NOTE",
                       f"{why or 'failed'}: {' '.join(str(interrupt or exc).split()) or type(interrupt or exc).__name__}")
        if sink is not None:
            sink.close()
        if interrupt is not None:  # the coils are off by now (the driver switched them off)
            off = "all coils off, acknowledged by the device" if not (dry_run or simulate) else outcome
            print(f"spherestep: interrupted ({signal_name(interrupt)}): {off}", file=sys.stderr)
            told()
            raise typer.Exit(exit_code(interrupt)) from None
        raise
    if sink is not None:
        sink.close()
    dev = report.device
    frames = f"{report.steps} frames (the start and {report.steps - 1} steps)"
    result = {"plan": str(plan), "frames": report.steps, "steps": report.steps - 1, "rate_hz": rate,
              "elapsed_s": report.elapsed, "max_lag_s": report.max_lag, "device": dev.name,
              "channels": dev.channels, "log": None if log is None else str(log), "final_state": "all coils off"}
    if dry_run:
        result |= {"mode": "dry-run", "sent": [{"t_s": s.t, "enable": hex(s.enable), "polarity": hex(s.polarity),
                                                "coils": {str(k): v for k, v in sorted(s.coils.items())}}
                                               for s in backend.sent]}
    elif simulate:
        import numpy as np

        from .. import so3

        settled = np.array([R for _, R in backend.orientations])
        planned = steps.achieved[:len(settled)]  # play holds every step, the first one included
        from ..drive.judgement import judge, tolerance as judged_within

        err = so3.distance(settled, planned)
        judged = judge(err[1:], judged_within(tolerance, "relay"), f"the plan at {rate:g} steps/s on the simulated "
                       "rotor", times=np.arange(1, len(err)) / rate, first_index=1)  # step k settles at k/rate
        result |= {"mode": "simulated", "tolerance_deg": judged.to_dict()["tolerance_deg"],
                   "settled_within_tolerance": int(judged.checked - judged.failed),
                   "settled_error_median_deg": float(np.degrees(np.median(err[1:]))),
                   "settled_error_max_deg": float(np.degrees(err[1:].max())), "judgement": judged.to_dict()}
    else:
        stats = backend.stats
        result |= {"mode": "serial", "port": port, "protocol": dev.protocol, "acknowledged": stats["acked"],
                   "retransmissions": stats["retransmissions"], "final_state": "all coils off, acknowledged"}
    if as_json:
        print_json(result)
    elif dry_run:
        from rich.table import Table

        table = Table(title=f"dry run of {plan.name}")
        for col in ("t (s)", "enable", "polarity", "coils"):
            table.add_column(col, justify="right" if col == "t (s)" else "left", no_wrap=True)
        for s in backend.sent:
            coils = " ".join(f"{k}{'+' if v > 0 else '-'}" for k, v in sorted(s.coils.items())) or "all off"
            table.add_row(f"{s.t:.3f}", hex(s.enable), hex(s.polarity), coils)
        console.print(table)
        print(f"dry run: {frames} at {rate:g} Hz would take {report.elapsed:.3f} s on a {dev.channels}-channel "
              f"controller{' (the channels the plan uses)' if channels is None else ''}; nothing was sent; "
              "final state all coils off")
    elif simulate:
        print(f"simulated {frames} at {rate:g} Hz ({report.elapsed:.1f} s of rotor time): "
              f"{result['settled_within_tolerance']} of {report.steps - 1} steps settled within "
              f"{result['tolerance_deg']:g}° of the plan (median {result['settled_error_median_deg']:.2f}°, max "
              f"{result['settled_error_max_deg']:.2f}°); final state all coils off")
    else:
        print(f"streamed {frames} at {rate:g} Hz to {port} (device {dev.name!r}, protocol {dev.protocol}, "
              f"{dev.channels} channels) in {report.elapsed:.3f} s: {result['acknowledged']} frames acknowledged, "
              f"{result['retransmissions']} retransmissions, worst step lateness {report.max_lag * 1000:.1f} ms; "
              "final state all coils off, acknowledged")
    if simulate:
        judged.require()
