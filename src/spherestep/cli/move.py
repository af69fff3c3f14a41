"""``spherestep move``: drive a turn as a servo, by ramped relay steps or by settled relay steps."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import typer


from ..errors import bad_value
from ..outputs import output_folder
from .app import app
from .common import (check_axis, check_core, check_device, check_port, console, design_from, number, parse_vector, print_json,
                     tolerance_option, usable)
from .motor import ANGLE
from .signals import exit_code, interrupt_for, sigterm_as_interrupt, told

MODES = ("servo", "ramped", "settled")


def _check_mode(ctx: typer.Context, param: typer.CallbackParam, value):
    if value not in MODES and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be one of {', '.join(MODES)}; instead received {value!r}")
    return value


def _check_firmware(ctx: typer.Context, param: typer.CallbackParam, value):
    if value not in ("python", "qemu") and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be python or qemu; instead received {value!r}")
    return value


def _check_end(ctx: typer.Context, param: typer.CallbackParam, value):
    if value not in (None, "hold", "park") and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be hold or park; instead received {value!r}")
    return value


def _check_sensor(ctx: typer.Context, param: typer.CallbackParam, value):
    if value not in ("ideal", "hall", "imu") and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be ideal, hall or imu; instead received {value!r}")
    return value


@app.command()
def move(
    axis: str = typer.Option(..., "--axis", callback=check_axis, help="Rotation axis X,Y,Z in the fixed (stator) "
                                                                      "frame."),
    angle: float = typer.Option(..., "--angle", callback=ANGLE, help="Rotation angle in degrees."),
    time: float = typer.Option(None, "--time", callback=number("s", 0, 3600, low_open=True, what="the turn's time"),
                               help="Servo only: the turn's time in seconds (a triangle profile), at least the bang-bang "
                                    "bound and short of nothing the supply cannot give against the back-EMF (refused "
                                    "naming the shortest time it can; default --fastest)."),
    fastest: bool = typer.Option(False, "--fastest", help="The fastest turn the drive guarantees (the default)."),
    mode: str = typer.Option("servo", "--mode", callback=_check_mode,
                             help="servo (continuous currents), ramped (relay steps at the pull-out rate) or "
                                  "settled (relay steps, each settled)."),
    design_path: Path = typer.Option(None, "--design", help="Design file; default the built-in prototype."),
    core: str = typer.Option(None, "--core", callback=check_core,
                             help="air or iron: the coils' core (default the one the design states: iron for the "
                                  "prototype), the same winding either way."),
    sensor: str = typer.Option("ideal", "--sensor", callback=_check_sensor,
                               help="Simulated servo: where the orientation comes from: ideal (the true one, plus "
                                    "--sensor-noise), hall (the stator's magnetometer array and its estimator) or "
                                    "imu (gyro, accelerometer and magnetometer in the rotor)."),
    sensor_noise: float = typer.Option(None, "--sensor-noise", callback=number("degrees", 0, 10,
                                                                               what="sensor noise σ"),
                                       help="Simulated servo with --sensor ideal: orientation noise σ in degrees "
                                            "(default 0)."),
    tolerance: float = tolerance_option(),
    out: Path = typer.Option(Path("spherestep-move"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    port: str = typer.Option(None, "--port", help="Servo on hardware: the coil controller's serial device "
                                                  "(protocol 2, docs/protocol.md), e.g. /dev/ttyACM0."),
    emulate: bool = typer.Option(False, "--emulate", help="Servo on the emulated motor behind a pseudo-terminal."),
    rate: float = typer.Option(None, "--rate", callback=number("Hz", 1, 2000, what="the loop rate"),
                               help="With --port/--emulate: the loop rate in Hz (default 500; 100 with --firmware "
                                    "qemu)."),
    end: str = typer.Option(None, "--end", callback=_check_end,
                            help="With --port/--emulate: how the move ends before every coil goes off: hold (the "
                                 "default: the servo holds the turn's end for --hold s, the final error is where it "
                                 "holds the rotor; then the coils go off and the predicted unpowered rest, the "
                                 "detent well the rotor falls into, is reported, not judged) or park (it moves on "
                                 "into the detent well nearest the turn's end, holds it, switches off and watches "
                                 "the rotor up to 1 s: the final error is where it rests against the predicted "
                                 "well)."),
    hold: float = typer.Option(None, "--hold", callback=number("s", 0, 3600, low_open=True, what="the hold"),
                               help="With --port/--emulate: seconds the servo holds the end before the coils go "
                                    "off (default 0.5). Ctrl-C during the hold ends the run with every coil off "
                                    "and nothing written."),
    firmware: str = typer.Option("python", "--firmware", callback=_check_firmware,
                                 help="With --emulate: the device behind the line: python (the emulator's) or qemu "
                                      "(firmware/spherestep's drive.cpp built for and run in QEMU's mps2-an500; "
                                      "needs qemu-system-arm and gcc-arm-none-eabi)."),
    plant_error: str = typer.Option(None, "--plant-error",
                                    help="With --emulate: the emulated motor as built (the grammar of spherestep "
                                         "calibrate's --plant-error, e.g. realistic or winding-spread=0.2,dead=4)."),
    calibration: Path = typer.Option(None, "--calibration", help="Drive on the model of this calibration file "
                                                                 "(spherestep calibrate) instead of the design's."),
    accept: bool = typer.Option(False, "--accept-inconsistent-calibration",
                                help="Use --calibration even though it records a fit that does not explain its "
                                     "held-out holds."),
) -> None:
    """Drive a turn about an axis on the simulated motor (the design's own model: the iron-cored coils of the
    prototype, their winding's limits, 24 V / 100 W supply) and write the trajectory (trajectory.csv), coil currents
    (currents.csv), power (power.csv), a plot (move.png) and a summary (move.json), which say the model used.
    Exit status 1 (after writing the files) when the run did not arrive within --tolerance of the turn's end
    (default 0.05° for the servo; relay steps within 0.5° of their plan).

    Example: [bold]spherestep move --axis 1,0.5,2 --angle 360 --fastest --mode servo --sensor-noise 0.02[/bold]

    With --port DEV (or --emulate) the servo runs on the coil controller over its serial link (or on the emulated
    motor behind a pseudo-terminal) with live status, its log streamed to OUT/servo-log.csv; exit status 1 when a
    fault ended the run (every coil is off either way) or it missed the tolerance.
    Example: [bold]spherestep move --axis 1,0.5,2 --angle 360 --emulate[/bold] (the fastest turn the planner finds
    within the supply, back-EMF included; a --time the supply cannot follow is refused, naming the shortest it can)
    With --emulate --firmware qemu the device is the firmware itself, run in QEMU.
    """

    from .. import checks
    from ..drive import DriveResult, check_options, choose_model, drive_turn
    from ..drive.turn import check_duration
    from ..errors import ComputationError, InputError
    from ..outputs import Outputs
    from .progress import progress

    backend = "port" if port is not None else "emulated" if emulate else "simulated"
    if time is not None and fastest:
        raise bad_value("--time", "left out with --fastest (one or the other)", time)
    if time is not None and mode != "servo":
        raise bad_value("--time", "given only with --mode servo (relay modes run at their own pace)", time)
    if port is not None and emulate:
        raise bad_value("--port", "left out with --emulate (one or the other)", port)
    if firmware != "python" and not emulate:
        raise bad_value("--firmware", "python (left out) unless --emulate (the firmware in QEMU drives the emulated "
                        "motor)", firmware)
    if firmware == "qemu":  # the tools, before any work: one line saying what to install
        from ..hardware.qemu import require_tools

        require_tools()
    if hold is not None and backend == "simulated":
        raise bad_value("--hold", "given only with --emulate or --port (the simulated servo's coils never go off); "
                        "drop --hold", hold)
    if end is not None and backend == "simulated":
        raise bad_value("--end", "given only with --emulate or --port (the simulated servo's coils never go off); "
                        "drop --end", end)
    if backend != "simulated" and mode != "servo":
        raise bad_value("--mode", "servo with --port/--emulate (relay plans run with spherestep run)", mode)
    if rate is not None and backend == "simulated":
        raise bad_value("--rate", "given only with --emulate or --port (the simulated servo runs at 1 kHz); drop "
                        "--rate", rate)
    if sensor != "ideal" and backend != "simulated":
        raise bad_value("--sensor", "ideal (left out) with --emulate/--port (the loop reads the stator's "
                        "magnetometer array)", sensor)
    if sensor_noise is not None and backend != "simulated":
        raise bad_value("--sensor-noise", "left out with --emulate/--port (the noise is the magnetometers' own)",
                        sensor_noise)
    if sensor != "ideal" and mode != "servo":
        raise bad_value("--sensor", "ideal unless --mode servo (relay modes run open loop)", sensor)
    if sensor_noise is not None and mode != "servo":
        raise bad_value("--sensor-noise", "given only with --mode servo (relay modes run open loop)", sensor_noise)
    if sensor != "ideal" and sensor_noise is not None:
        raise bad_value("--sensor-noise", "left out with --sensor hall or imu (their noise is the part's own)",
                        sensor_noise)
    try:
        axis_vec = checks.axis(parse_vector(axis, "--axis"), "--axis")
    except InputError:  # say it with the text the user typed
        raise bad_value("--axis", "a non-zero 3-vector X,Y,Z (not all components zero or below 1e-150)", axis) \
            from None
    if plant_error is not None and not emulate:
        raise bad_value("--plant-error", "given only with --emulate (the emulated motor as built)", plant_error)
    if accept and calibration is None:
        raise bad_value("--accept-inconsistent-calibration", "given only with --calibration FILE", accept)
    from ..drive.plant import PlantError

    error = None if plant_error is None else PlantError.parse(plant_error)
    noise = math.radians(sensor_noise or 0.0)
    check_options(mode, backend, duration=time, sensor=sensor, sensor_noise=noise, port=port, rate=rate)
    if port is not None:  # a port that cannot be opened is refused before any work, with nothing written
        check_port(port)
    out = output_folder(out, "--out")  # before the work: a bad location costs nothing
    design = usable(design_from(design_path), path=design_path)
    from ..magnetics import design_model

    if calibration is not None and not calibration.is_file():
        raise bad_value("--calibration", "an existing calibration file (spherestep calibrate --out)", str(calibration))
    # a stale or inconsistent file: refused in one line naming the calibration and the option that forces it
    own = design_model(design, core, calibration=calibration, accept_inconsistent=accept)
    if port is not None:  # its HELLO against the design's drive, before the session builds anything
        check_device(port, design, own.limits)
    if time is not None:  # before the progress starts: a refusal is one line
        check_duration(design, axis_vec, math.radians(angle), choose_model(design, own), time, "--time",
                       start=None)
    result = received = None
    with progress("driving the turn", enabled=not as_json) as say:
        names = DriveResult.FILES + (("servo-log.csv",) if backend != "simulated" else ())
        files = Outputs(out, names)
        try:
            with files, sigterm_as_interrupt() as received:
                out.mkdir(parents=True, exist_ok=True)
                result = drive_turn(design, axis_vec, math.radians(angle), mode=mode, backend=backend,
                                    model=own, duration=time, sensor=sensor, sensor_noise=noise,
                                    port=port, rate=rate, tolerance=None if tolerance is None else math.radians(tolerance),
                                    log=out / "servo-log.csv" if backend != "simulated" else None, progress=say,
                                    firmware=firmware, end=end or "hold", hold=hold, plant_error=error)
                if backend != "simulated" and result.details.outcome == "INTERRUPT":  # the loop caught it, coils off
                    raise interrupt_for(received.name)
                written = result.write(out)
        except KeyboardInterrupt as exc:  # the files removed (Outputs); say whether the device confirmed all off
            if backend == "simulated" or received is None or received.name is None or result is None:
                raise  # before the loop drove a coil (or a simulation): the CLI's own line
            d = result.details
            off = "all coils off, acknowledged by the device" if d.off_acknowledged else \
                f"all off NOT acknowledged; {d.message.rpartition('OFF was not acknowledged: ')[2]}"
            print(f"spherestep: interrupted ({received.name}): {off}", file=sys.stderr)
            told()
            raise typer.Exit(exit_code(exc)) from None
    if backend != "simulated":
        written.append(out / "servo-log.csv")
    if as_json:
        print_json(result.to_dict() | {"files": [str(p) for p in written]})
    else:
        console.print(result.summary_line() + f"; wrote {len(written)} files to {out}/")
        if backend != "simulated":
            d = result.details
            console.print(f"loop: {d.outcome} after {d.cycles} cycles at {d.rate:.0f} Hz ({d.missed} deadlines "
                          f"missed{f' ({d.late_wakeups} woken late by the OS)' if d.late_wakeups else ''}, "
                          f"{d.late_readings} reading{'' if d.late_readings == 1 else 's'} late, {1e3 * d.cpu_mean:.2f} ms CPU per cycle, "
                          f"worst {1e3 * d.cpu_max:.2f}"
                          f"{'' if d.realtime else ', no real-time scheduling'}"
                          f"{f', slowed {d.slowed}× to {d.time_scale:g} of the pace' if d.slowed else ''}); "
                          f"all off {'acknowledged' if d.off_acknowledged else 'NOT acknowledged'}"
                          + (f"; {d.message}" if d.message else ""))
            console.print(_end_line(d))
    if not result.ok:
        raise ComputationError(result.verdict())


def _end_line(d) -> str:
    """The console line on the move's end: what the servo held, and what switching off meant (hold: the predicted
    unpowered rest, reported; park: where the rotor rested with the coils off, judged)."""
    import math

    deg = math.degrees
    held = "" if d.held_error is None else f", {deg(d.held_error):.3g}° off it at the loop's end"
    if d.end == "hold":
        line = f"end: hold, the servo held the turn's end {d.hold:g} s{held}; coils off"
        if d.rest_offset is not None:
            line += (f": released, the rotor's predicted unpowered rest is {deg(d.rest_offset):.3g}° from the "
                     f"target (reported, not judged)")
        if d.drift_after_off is not None:
            line += f"; it moved {deg(d.drift_after_off):.3g}° in the first 0.15 s"
        return line
    line = f"end: park, the servo held the detent well {deg(d.rest_offset):.3g}° from the target {d.hold:g} s{held}"
    if d.at_rest is None:
        return line + "; the rotor was not watched after the coils went off"
    rest = "came to rest" if d.at_rest else "had not come to rest"
    return (line + f"; with the coils off the rotor {rest} within {d.rest_after:.2g} s, "
            f"{deg(d.drift_after_off):.3g}° from where the loop left it (swing {deg(d.swing):.2g}°)")
