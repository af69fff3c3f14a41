"""``spherestep move``: drive a turn as a servo, by ramped relay steps or by settled relay steps."""

from __future__ import annotations

import json
import math
from pathlib import Path

import typer


from ..errors import bad_value
from ..outputs import output_folder
from .app import app
from .common import check_axis, console, design_from, number, parse_vector, print_json, usable
from .motor import ANGLE

MODES = ("servo", "ramped", "settled")


def _check_mode(ctx: typer.Context, param: typer.CallbackParam, value):
    if value not in MODES and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be one of {', '.join(MODES)}; instead received {value!r}")
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
                               help="Servo only: the turn's time in seconds (default --fastest)."),
    fastest: bool = typer.Option(False, "--fastest", help="The fastest turn the drive guarantees (the default)."),
    mode: str = typer.Option("servo", "--mode", callback=_check_mode,
                             help="servo (continuous currents), ramped (relay steps at the pull-out rate) or "
                                  "settled (relay steps, each settled)."),
    design_path: Path = typer.Option(None, "--design", help="Design file; default the built-in prototype."),
    sensor: str = typer.Option("ideal", "--sensor", callback=_check_sensor,
                               help="Servo: where the orientation comes from: ideal (the true one, plus "
                                    "--sensor-noise), hall (the stator's magnetometer array and its estimator) or "
                                    "imu (gyro, accelerometer and magnetometer in the rotor)."),
    sensor_noise: float = typer.Option(0.0, "--sensor-noise", callback=number("degrees", 0, 10,
                                                                              what="sensor noise σ"),
                                       help="Servo: orientation sensor noise σ in degrees."),
    out: Path = typer.Option(Path("spherestep-move"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
    port: str = typer.Option(None, "--port", help="Servo on hardware: the coil controller's serial device "
                                                  "(protocol 2, docs/protocol.md), e.g. /dev/ttyACM0."),
    emulate: bool = typer.Option(False, "--emulate", help="Servo on the emulated motor behind a pseudo-terminal."),
    rate: float = typer.Option(200.0, "--rate", callback=number("Hz", 1, 2000, what="the loop rate"),
                               help="With --port/--emulate: the loop rate in Hz."),
) -> None:
    """Drive a turn about an axis on the simulated motor (magnets' torque map, 24 V / 100 W supply) and write the
    trajectory (trajectory.csv), coil currents (currents.csv), power (power.csv), a plot (move.png) and a summary
    (move.json).

    Example: [bold]spherestep move --axis 1,0.5,2 --angle 360 --fastest --mode servo --sensor-noise 0.02[/bold]

    With --port DEV (or --emulate) the servo runs on the coil controller over its serial link (or on the emulated
    motor behind a pseudo-terminal) with live status, its log streamed to OUT/servo-log.csv and a summary in
    OUT/servo.json; exit status 1 when a fault ended the run (every coil is off either way).
    Example: [bold]spherestep move --axis 1,0.5,2 --angle 360 --time 2.4 --emulate[/bold]
    """
    from ..dynamics import drive_turn as drive

    if time is not None and fastest:
        raise bad_value("--time", "left out with --fastest (one or the other)", time)
    if time is not None and mode != "servo":
        raise bad_value("--time", "given only with --mode servo (relay modes run at their own pace)", time)
    if port is not None or emulate:
        if mode != "servo":
            raise bad_value("--mode", "servo with --port/--emulate (relay plans run with spherestep run)", mode)
        if port is not None and emulate:
            raise bad_value("--port", "left out with --emulate (one or the other)", port)
    out = output_folder(out, "--out")  # before the work: a bad location costs nothing
    design = usable(design_from(design_path))
    if port is not None or emulate:
        return _on_hardware(design, axis, angle, time, port, emulate, rate, out, as_json)
    if sensor != "ideal" and mode != "servo":
        raise bad_value("--sensor", "ideal unless --mode servo (relay modes run open loop)", sensor)
    if sensor != "ideal" and sensor_noise:
        raise bad_value("--sensor-noise", "left out with --sensor hall or imu (their noise is the part's own)",
                        sensor_noise)
    result = drive(design, parse_vector(axis, "--axis"), math.radians(angle), mode=mode, duration=time,
                   sensor_noise=math.radians(sensor_noise), sensor=sensor)
    written = result.write(out)
    s = result.summary
    if as_json:
        print_json(s | {"files": [str(p) for p in written]})
        return
    console.print(f"{mode}: {angle:g}° about ({', '.join(f'{a:.3f}' for a in s['axis'])}) in {s['time_s']:.3g} s; "
                  f"final error {s['final_error_deg']:.3g}°, max tracking error {s['max_tracking_error_deg']:.3g}°; "
                  f"power peak {s['peak_power_W']:.3g} W, mean {s['mean_power_W']:.3g} W; "
                  f"wrote {len(written)} files to {out}/")


def _on_hardware(design, axis, angle, time, port, emulate, rate, out, as_json) -> None:
    """The servo on a controller or the emulated motor: live status, streamed log, summary (docs/protocol.md)."""
    import numpy as np

    from .. import so3
    from ..atomic import write_text
    from ..hardware.session import move_on_hardware

    out.mkdir(parents=True, exist_ok=True)
    shown = [-1.0]

    def status(t, R, w, currents):
        if t - shown[0] >= 0.25 and not as_json:
            shown[0] = t
            console.print(f"  t {t:6.2f} s   turned {math.degrees(float(np.linalg.norm(so3.log(R)))):7.2f}°   "
                          f"|ω| {float(np.linalg.norm(w)):5.2f} rad/s   max |i| {float(np.abs(currents).max()):.3f} A")

    session = move_on_hardware(design, parse_vector(axis, "--axis"), math.radians(angle), duration=time, port=port,
                               emulate=emulate, rate=rate, log=out / "servo-log.csv", status=status)
    summary = session.report.to_dict()
    if session.final is not None:
        summary["emulated_final_error_deg"] = math.degrees(session.final_error())
    write_text(out / "servo.json", json.dumps(summary, indent=2) + "\n")
    if as_json:
        print_json(summary)
    else:
        console.print(f"servo on {'the emulated motor' if emulate else port}: {summary['outcome']} after "
                      f"{summary['cycles']} cycles at {summary['rate_Hz']:.0f} Hz ({summary['missed']} deadlines "
                      f"missed); all off {'acknowledged' if summary['off_acknowledged'] else 'NOT acknowledged'}"
                      + (f"; final error {summary['emulated_final_error_deg']:.3g}°" if session.final is not None
                         else "") + (f"; {summary['message']}" if summary["message"] else ""))
    if session.report.outcome != "done":
        raise typer.Exit(1)
