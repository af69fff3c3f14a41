"""``spherestep move``: drive a turn as a servo, by ramped relay steps or by settled relay steps."""

from __future__ import annotations

import math
from pathlib import Path

import typer

from ..errors import bad_value
from .app import app
from .common import check_axis, console, design_from, number, parse_vector, print_json, usable
from .motor import ANGLE

MODES = ("servo", "ramped", "settled")


def _check_mode(ctx: typer.Context, param: typer.CallbackParam, value):
    if value not in MODES and not ctx.resilient_parsing:
        raise typer.BadParameter(f"must be one of {', '.join(MODES)}; instead received {value!r}")
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
    sensor_noise: float = typer.Option(0.0, "--sensor-noise", callback=number("degrees", 0, 10,
                                                                              what="sensor noise σ"),
                                       help="Servo: orientation sensor noise σ in degrees."),
    out: Path = typer.Option(Path("spherestep-move"), "--out", help="Output folder."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON."),
) -> None:
    """Drive a turn about an axis on the simulated motor (magnets' torque map, 24 V / 100 W supply) and write the
    trajectory (trajectory.csv), coil currents (currents.csv), power (power.csv), a plot (move.png) and a summary
    (move.json).

    Example: [bold]spherestep move --axis 1,0.5,2 --angle 360 --fastest --mode servo --sensor-noise 0.02[/bold]
    """
    from ..dynamics import drive_turn as drive

    if time is not None and fastest:
        raise bad_value("--time", "left out with --fastest (one or the other)", time)
    if time is not None and mode != "servo":
        raise bad_value("--time", "given only with --mode servo (relay modes run at their own pace)", time)
    design = usable(design_from(design_path))
    result = drive(design, parse_vector(axis, "--axis"), math.radians(angle), mode=mode, duration=time,
                   sensor_noise=math.radians(sensor_noise))
    written = result.write(out)
    s = result.summary
    if as_json:
        print_json(s | {"files": [str(p) for p in written]})
        return
    console.print(f"{mode}: {angle:g}° about ({', '.join(f'{a:.3f}' for a in s['axis'])}) in {s['time_s']:.3g} s; "
                  f"final error {s['final_error_deg']:.3g}°, max tracking error {s['max_tracking_error_deg']:.3g}°; "
                  f"power peak {s['peak_power_W']:.3g} W, mean {s['mean_power_W']:.3g} W; "
                  f"wrote {len(written)} files to {out}/")
