"""The hardware session's magnetometer estimate on the emulated iron prototype (issue 26 §2), in lockstep.

``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_session_iron.py [--ignore-cores]``: the 360° turn about
(1, 0.5, 2) (:func:`spherestep.drive.session.move_on_hardware`, the drive's fastest, 500 Hz) on the emulated motor
in lockstep (simulated clock), whose magnetometers read the sensing room's ``field_model`` (the cores' field
included); every reading's estimate (the session's ``FieldTracker``) against the emulated rotor at that instant.
``--ignore-cores``: the session's estimator without the cores (``cores=False``). Prints the outcome, the final
error, the host CPU per cycle and the sensor error RMS / worst, with the load.
"""

from __future__ import annotations

import math
import os
import sys
import time

import numpy as np

import spherestep.drive.session as session
from spherestep import so3
from spherestep.hardware import FieldTracker, LockstepLink
from spherestep.motor import prototype


def main() -> None:
    cores = False if "--ignore-cores" in sys.argv else None
    links: list = []
    errors: list = []

    class Link(LockstepLink):  # the lockstep link, remembered so that its motor can be read at each reading
        def __init__(self, motor, **options):
            super().__init__(motor, **options)
            links.append(self)

    class Tracker(FieldTracker):  # the session's tracker, its estimate compared with the rotor it read
        def __call__(self, state, prior=None):
            R = super().__call__(state, prior)
            errors.append(so3.distance(R, links[-1].motor.orientation()))
            return R

    session.FieldTracker = Tracker
    import spherestep.hardware as hardware

    hardware.LockstepLink = Link
    t0 = time.perf_counter()
    s = session.move_on_hardware(prototype(), (1, 0.5, 2), math.radians(360), emulate=True, lockstep=True, cores=cores)
    r = s.report
    e = np.degrees(np.array(errors))
    print(f"cores {'ignored' if cores is False else 'modelled'}: outcome {r.outcome} {r.message}; "
          f"final {math.degrees(s.final_error()):.4f}°; {r.cycles} cycles, host CPU {1e3 * r.cpu_mean:.3f} ms per "
          f"cycle; {time.perf_counter() - t0:.1f} s; load {os.getloadavg()[0]:.1f}")
    if len(e):
        print(f"sensor error vs the emulated rotor: RMS {np.sqrt(np.mean(e ** 2)):.4f}°, worst {e.max():.4f}° "
              f"over {len(e)} readings")


if __name__ == "__main__":
    main()
