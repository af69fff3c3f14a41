"""``spherestep calibrate``: the torque model fitted to the motor's own holds (:mod:`spherestep.control.calibration`)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import typer

from .app import app
from .common import check_device, check_port, design_from, number, print_json, tolerance_option, usable
from .progress import progress
from .signals import Terminated, interrupt_of, sigterm_as_interrupt, told

OUT_SUFFIXES = (".yaml", ".yml", ".json")  # the suffix of --out decides the format (JSON for .json); others refused
DEFAULT_ERROR = "detent=1.2,winding=0.85"
TERMS = ("gains", "placements", "sensors", "rotor")  # what --without may leave out


def without_terms(text: str | None) -> set:
    """``--without gains,placements,sensors,rotor`` as a set; InputError naming ``--without`` otherwise."""
    from ..errors import bad_value

    got = set() if not text else {t.strip() for t in text.split(",")}
    if not got <= set(TERMS):
        raise bad_value("--without", f"a comma-separated list among {', '.join(TERMS)}", text)
    return got


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
    error: str = typer.Option(DEFAULT_ERROR, "--plant-error",
                              help="With --emulate: how the emulated motor differs from its design: detent=F, "
                                   "winding=F, winding-spread=F, dead=I[+J], coil-offset=DEG, misplaced=K, "
                                   "inertia=F, damping=NMS, friction=NM, saturation=F (each winding's torque F tanh(c/F): a "
                                   "term no fit carries, refused by name), sensor-offset=UT, sensor-bias=DEG, "
                                   "seed=N, or 'realistic' (docs/control.md)."),
    without: str = typer.Option(None, "--without", help="Leave out of the run (comma-separated): gains, placements "
                                                        "(the per-coil terms), sensors (the detent wells' "
                                                        "array calibration; never on a port), rotor (its "
                                                        "inertia, damping and friction from moves)."),
    accept: bool = typer.Option(False, "--accept-inconsistent-calibration",
                                help="Write the calibration even when it does not explain its held-out holds (the "
                                     "file records the verdict; loading it then needs the same option)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the random walk of holds."),
    tolerance: float = tolerance_option(),
    as_json: bool = typer.Option(False, "--json", help="Print the fit as JSON."),
) -> None:
    """Identify the motor as built, into one file: the sensor array against the detent wells (emulated motor),
    then the servo driven to a walk of orientations (the steady currents and the moves) and the iron model fitted to
    them — its detent and winding tables, each coil's gain and placement, the cores' coupling (least squares with a
    prior, every parameter with its standard deviation), judged on every fifth hold, held out — then the rotor's
    inertia, damping and friction from moves on the calibrated model. Print the fit and write it to --out; a fit
    that does not explain its held-out holds exits 1 with nothing written and says which term is missing (unless
    --accept-inconsistent-calibration). Each hold is judged against its target within
    --tolerance (default 0.05°) and a line says how many held there and the worst: a hold that rests off its
    target is still data (the fit uses where it rested), so it does not fail the command.

    Example: [bold]spherestep calibrate --emulate --plant-error detent=1.2,winding=0.85 --out calibration.yaml[/bold]
    """
    from ..control import hold_orientations, torque_error
    from ..drive import Emulated, Port
    from ..drive.identify import identify_motor
    from ..drive.plant import PlantError
    from ..errors import ComputationError, bad_value
    from ..magnetics import design_model
    from ..outputs import output_file

    if emulate == (port is not None):
        raise bad_value("--emulate/--port", "one of --emulate or --port DEV", "both" if emulate else "neither")
    plant_error = PlantError.parse(error)
    if not emulate and error != DEFAULT_ERROR:
        raise bad_value("--plant-error", "used only with --emulate", error)
    left_out = without_terms(without)
    if not emulate and "sensors" not in left_out:
        left_out.add("sensors")  # the wells are visited on the emulated motor only
    terms = {"gains": "gains" not in left_out, "turns": "placements" not in left_out,
             "sensors": "sensors" not in left_out, "rotor": "rotor" not in left_out}
    out = output_file(out, "--out", suffixes=OUT_SUFFIXES)  # before any hold: writable, and its suffix the format
    if port is not None:  # a port that cannot be opened is refused before any work, with nothing written
        check_port(port)
    design = usable(design_from(design_path), path=design_path)
    own = design_model(design)
    if own.core != "iron":
        raise bad_value("--design", "an iron-cored design (the fit is of the iron model's tables)", own.core)
    if port is not None:  # its HELLO against the design's drive, before any hold
        check_device(port, design, own.limits)
    plant = plant_error.plant(own.model) if emulate else None
    if emulate:
        from ..sensing import default_array

        backend = Emulated(plant, rotor=plant_error.rotor(design),
                           sensor_errors=plant_error.sensor_errors(default_array(design, 8)))
    else:
        backend = Port(port)
    walk = hold_orientations(int(orientations), seed=seed)
    try:
        with sigterm_as_interrupt() as received, progress("calibrating", enabled=not as_json) as say:
            cal, holds = identify_motor(design, backend, walk, model=own.model, limits=own.limits, progress=say,
                                        **terms)
            judged = judge_holds(holds, tolerance)  # said, not fatal: the fit uses where each hold rested
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
    usable_fit = cal.consistent is not False or accept
    path = cal.save(out) if usable_fit else None
    if as_json:
        print_json({"calibration": cal.to_dict(), "holds": holds.to_dict(), "holds_judged": judged.to_dict(),
                    "file": None if path is None else str(path),
                    "plant_error": plant_error.to_dict() if emulate else None,
                    "torque_error_before": before, "torque_error_after": after})
    else:
        print(cal.summary())
        print(f"holds: {judged.checked - judged.failed} of {judged.checked} within {math.degrees(judged.tolerance):g}° "
              f"of their targets" + (f"; {judged.reason.split(': ', 1)[1]} (the fit uses where each rested)"
                                     if not judged.ok else ""))
        if before is not None:
            print(f"torque error against the emulated plant ({error}): {before:.4f} -> {after:.4f} "
                  f"({before / after:.1f}x smaller), 200 random orientations and currents")
        if path is not None:
            print(f"wrote {path}")
    if not usable_fit:
        raise ComputationError(f"the calibration does not explain its held-out holds (missing: "
                               f"{', '.join(cal.missing) or 'unknown'}); nothing written to {out} (write it anyway "
                               "with --accept-inconsistent-calibration)")
