"""``spherestep calibrate``: the torque model fitted to the motor's own holds (:mod:`spherestep.control.calibration`)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import typer

from .app import app
from .common import check_port, design_from, number, print_json, tolerance_option, usable
from .progress import progress
from .signals import Terminated, interrupt_of, sigterm_as_interrupt, told

ERROR_KEYS = ("detent", "winding")
OUT_SUFFIXES = (".yaml", ".yml", ".json")  # the suffix of --out decides the format (JSON for .json); others refused


def plant_error(text: str) -> dict:
    """``"detent=1.2,winding=0.85"`` as ``{"detent": 1.2, "winding": 0.85}`` (factors on the model's tables);
    InputError naming ``--plant-error`` otherwise."""
    from ..errors import bad_value

    expected = "factors on the tables, e.g. detent=1.2,winding=0.85 (keys detent, winding; positive numbers)"
    out = {}
    for item in text.split(","):
        key, sep, value = item.strip().partition("=")
        if not sep or key.strip() not in ERROR_KEYS or key.strip() in out:
            raise bad_value("--plant-error", expected, text)
        try:
            factor = float(value)
        except ValueError:
            raise bad_value("--plant-error", expected, text) from None
        if not 0.0 < factor < 100.0:
            raise bad_value("--plant-error", expected, text)
        out[key.strip()] = factor
    return out


def judge_holds(holds, degrees: float | None):
    """Each hold's rest against its target (:mod:`spherestep.drive.judgement`), within ``degrees`` (default the
    hold's 0.05°)."""
    from .. import so3
    from ..drive.judgement import judge, tolerance

    return judge(so3.distance(holds.orientations, holds.targets), tolerance(degrees, "hold"),
                 f"the holds ({holds.backend})", label="hold", first_index=1)


def coils_off(interrupt: BaseException, emulate: bool) -> str:
    """Whether the coils are off after ``interrupt`` stopped the holds: the servo loop switches every coil off when
    it stops (``off_acknowledged`` says whether the device confirmed it); between holds and in the fit none is
    driven."""
    acknowledged = getattr(interrupt, "off_acknowledged", None)
    where = "the emulated motor" if emulate else "the device"
    if acknowledged is None:
        return f"all coils off (none was being driven: stopped between holds or in the fit; {where})"
    if acknowledged:
        return f"all coils off, acknowledged by {where}"
    return (f"all coils off NOT acknowledged by {where}: switch the controller's supply off before touching the "
            "motor")


@app.command()
def calibrate(
    out: Path = typer.Option(..., "--out", help="Where to write the calibration: .yaml/.yml (YAML) or .json (JSON). "
                                                "Name it calibration.yaml beside the design file for "
                                                "design_model(calibration=...)."),
    design_path: Path = typer.Option(None, "--design", help="Design file (iron-cored); default the built-in "
                                                            "prototype."),
    emulate: bool = typer.Option(False, "--emulate", help="Calibrate the emulated motor (a plant built with "
                                                          "--plant-error), on the lockstep link."),
    port: str = typer.Option(None, "--port", help="Calibrate the motor on this coil controller's serial device."),
    orientations: int = typer.Option(60, "--orientations", callback=number("a whole number of holds from 2 to "
                                                                           "200", 2, 200),
                                     help="How many holds (a random walk of 25° moves)."),
    error: str = typer.Option("detent=1.2,winding=0.85", "--plant-error",
                              help="With --emulate: the emulated plant's tables as factors on the model's."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random walk of holds."),
    tolerance: float = tolerance_option(),
    as_json: bool = typer.Option(False, "--json", help="Print the fit as JSON."),
) -> None:
    """Drive the servo to a walk of orientations, record the steady currents and the moves, and fit the iron
    model's detent and winding tables to them (least squares with a smoothness prior); print the fit (residuals,
    scales, the nodes moved and their uncertainty, what the data cannot see) and write it to --out. Each hold is
    judged against its target within --tolerance (default 0.05°) and the line says how many held there and the
    worst: a hold that rests off its target is still data (the fit uses where it rested), so it does not fail the
    command.

    Example: [bold]spherestep calibrate --emulate --plant-error detent=1.2,winding=0.85 --out calibration.yaml[/bold]
    """
    from ..control import calibrate as fit, hold_orientations, torque_error
    from ..drive import Emulated, Port, collect_holds
    from ..errors import bad_value
    from ..magnetics import design_model
    from ..magnetics.mismatch import scaled_model
    from ..outputs import output_file

    if emulate == (port is not None):
        raise bad_value("--emulate/--port", "one of --emulate or --port DEV", "both" if emulate else "neither")
    factors = plant_error(error)
    if not emulate and error != "detent=1.2,winding=0.85":
        raise bad_value("--plant-error", "used only with --emulate", error)
    out = output_file(out, "--out", suffixes=OUT_SUFFIXES)  # before any hold: writable, and its suffix the format
    if port is not None:  # a port that cannot be opened is refused before any work, with nothing written
        check_port(port)
    design = usable(design_from(design_path), path=design_path)
    own = design_model(design)
    if own.core != "iron":
        raise bad_value("--design", "an iron-cored design (the fit is of the iron model's tables)", own.core)
    plant = scaled_model(own.model, **factors) if emulate else None
    backend = Emulated(plant) if emulate else Port(port)
    walk = hold_orientations(int(orientations), seed=seed)
    try:
        with sigterm_as_interrupt() as received, progress("calibrating", enabled=not as_json) as say:
            holds = collect_holds(design, backend, walk, model=own.model, limits=own.limits, progress=say)
            judged = judge_holds(holds, tolerance)  # said, not fatal: the fit uses where each hold rested
            say("fitting the tables")
            cal = fit(design, own.model, holds)
            before = after = None
            if plant is not None:
                say("measuring the torque error against the emulated plant")
                before, after = torque_error(own.model, plant), torque_error(cal.model, plant)
    except BaseException as exc:
        interrupt = interrupt_of(exc)
        if interrupt is None:
            raise
        print(f"spherestep: interrupted ({received.name or 'SIGINT'}): {coils_off(interrupt, emulate)}; nothing "
              "written", file=sys.stderr)
        told()
        raise typer.Exit(143 if isinstance(interrupt, Terminated) or received.name == "SIGTERM" else 130) from None
    path = cal.save(out)
    if as_json:
        print_json({"calibration": cal.to_dict(), "holds": holds.to_dict(), "holds_judged": judged.to_dict(),
                    "file": str(path),
                    "plant_error": factors if emulate else None,
                    "torque_error_before": before, "torque_error_after": after})
        return
    print(cal.summary())
    print(f"holds: {judged.checked - judged.failed} of {judged.checked} within {math.degrees(judged.tolerance):g}° of "
          f"their targets" + (f"; {judged.reason.split(': ', 1)[1]} (the fit uses where each rested)"
                              if not judged.ok else ""))
    if before is not None:
        print(f"torque error against the emulated plant ({error}): {before:.4f} -> {after:.4f} "
              f"({before / after:.1f}x smaller), 200 random orientations and currents")
    print(f"wrote {path}")
