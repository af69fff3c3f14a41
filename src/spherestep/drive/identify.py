"""One calibration run: the sensors, the holds, the torque model and the rotor, into one :class:`Calibration`.

:func:`identify_motor` on the emulated motor (or the torque side alone on a port):

1. **Sensors** (emulated motor only: the wells are visited by starting the rotor in them): the unpowered rotor's
   rests in the detent wells of the design's model (:func:`spherestep.sensing.detent_wells`,
   :func:`~spherestep.drive.wells.well_readings`) make the orientation *absolute*:
   :func:`~spherestep.sensing.calibrate_array_absolute` fits each sensor's offset and the array's turn. Holds of
   commanded orientations cannot: the servo holds where its estimate says, so an estimate turned by ``Q`` holds
   turned by ``Q`` and is self-consistent.
2. **Holds** read through that calibration (:func:`~spherestep.drive.collect_holds`), and the torque model's fit
   (:func:`spherestep.control.calibrate`: tables, per-coil gains and placements, coupling gain), judged on held-out
   holds; an inconsistent fit is diagnosed (:func:`spherestep.control.identify.diagnose`).
   **The array again**: the wells are absolute only as far as the detent model is (misplaced coils, or a detent
   stronger than the cores' coupling, move them by up to 0.19° on the prototype), so the same readings are fitted
   again against the wells of the *calibrated* model (:func:`~spherestep.sensing.refined_wells`), and the pass
   whose references explain the readings better (the smaller residual, same parameters) is saved and used from
   then on (the holds already fitted keep the first).
3. **The rotor**: :func:`spherestep.dynamics.rotor_excitation`'s moves recorded with the servo on the *calibrated*
   model and through the array's calibration (:func:`~spherestep.drive.records.record_moves`), inertia, damping and friction by
   :func:`spherestep.dynamics.fit_rotor` under the calibrated torque (with the currents' lag and the calibrated
   winding's common factor, whose error would otherwise leak into damping and friction), each ± σ.
"""

from __future__ import annotations

from dataclasses import replace

from ..errors import bad_value
from .calibration import Emulated, Port, collect_holds


def identify_motor(design, backend, orientations, *, model=None, limits=None, gains: bool = True,
                   turns: bool = True, sensors: bool = True, rotor: bool = True, progress=None):
    """``(calibration, holds)``: the :class:`~spherestep.magnetics.calibrated.Calibration` of ``design`` (module
    docstring) and the :class:`~spherestep.control.Holds` it fitted, from the
    ``backend`` (:class:`Emulated` or :class:`Port`) at ``orientations`` (as :func:`collect_holds`), the servo on
    ``model``/``limits`` (default the design's own); ``gains``/``turns`` the per-coil terms, ``sensors`` and
    ``rotor`` the stages 1 and 3. ``progress(text, done=None, total=None)``."""
    from ..control import calibrate
    from ..control.identify import diagnose
    from ..dynamics import fit_rotor, rotor_excitation
    from ..magnetics import design_model
    from ..sensing import calibrate_array_absolute, default_array, detent_wells, refined_wells
    from .records import record_moves
    from .wells import well_readings

    if not isinstance(backend, (Emulated, Port)):
        raise bad_value("backend", "spherestep.drive.Emulated(plant) or spherestep.drive.Port(device)",
                        type(backend).__name__)
    emulated = isinstance(backend, Emulated)
    if sensors and not emulated:
        raise bad_value("sensors", "False on a port (the detent wells are visited only on the emulated motor)",
                        sensors)
    own = design_model(design)
    model = own.model if model is None else model
    limits = own.limits if limits is None else limits
    say = progress or (lambda *a: None)
    options = {"plant": backend.plant, "plant_rotor": backend.rotor, "sensor_errors": backend.sensor_errors} \
        if emulated else {}
    array = default_array(design, 8)
    array_cal = None
    if sensors:
        say("sensors: the rotor at rest in the detent wells")
        wells = detent_wells(model)
        got = well_readings(design, wells, model=model, limits=limits, sensors=array, **options,
                            progress=lambda text, *_: say(f"sensors: {text}"))
        array_cal = calibrate_array_absolute(design, array, got.readings, got.references)
    holds = collect_holds(design, backend, orientations, model=model, limits=limits, sensor_calibration=array_cal,
                          progress=progress)
    say("fitting the torque model")
    cal = calibrate(design, model, holds, gains=gains, turns=turns)
    if cal.consistent is False:
        say("the fit does not explain its held-out holds: comparing fits to name what is missing")
        cal = replace(cal, missing=diagnose(design, model, holds, cal, gains=gains, turns=turns))
    first = None
    if array_cal is not None:
        say("sensors: the array again, against the calibrated model's wells")
        first = array_cal
        second = calibrate_array_absolute(design, array, got.readings, refined_wells(cal.model, got.references))
        array_cal = second if second.residual_T < first.residual_T else first  # the wells that explain the readings
    fit = None
    if rotor:
        moves = rotor_excitation(holds.orientations[-1])
        records = record_moves(design, moves, model=cal.model, limits=limits, emulate=emulated,
                               port=None if emulated else backend.device, sensor_calibration=array_cal, **options,
                               progress=lambda text, *_: say(f"rotor: {text}"))
        fit = fit_rotor(cal.model, records, lag=True, winding=True)
    sensed = None if array_cal is None else {**array_cal.to_dict(), "first_pass": first.to_dict(),
                                             "second_pass": second.to_dict(), "kept": "second" if array_cal is second
                                             else "first"}
    return replace(cal, rotor=None if fit is None else fit.to_dict(), sensors=sensed), holds
