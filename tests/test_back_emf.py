"""Back-EMF end to end (issue 36 §3, issue 38 §1): the emulated coils feel the turning rotor, the host sends each
coil's estimate in ``DRIVE``, the device feeds it forward and expects it (its line-for-line C++ twin and the
vectors: tests/test_firmware.py, test_hardware_drive.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherestep import so3
from spherestep.electrics import DriveLimits
from spherestep.hardware import current_device
from spherestep.hardware.drive_link import DriveInfo, drive_blocks


def _info(caps: int) -> DriveInfo:
    return DriveInfo("t", 2, 0, 0.1, 1e-3, 1.0, 100.0, 8e-6, 24.0, 24.0, 18.7e-3, caps)


def test_drive_sends_the_back_emf_only_to_a_device_that_takes_it():
    """Two blocks (mA, 10 mV) to a device with CAP_EMF, the currents alone otherwise; a bad estimate is refused
    naming ``emf``."""
    assert drive_blocks(_info(1), [0.5, -0.2], [15.0, -0.26]) == ("01F4FF38", "05DCFFE6")
    assert drive_blocks(_info(0), [0.5, -0.2], [15.0, -0.26]) == ("01F4FF38",)
    assert drive_blocks(_info(1), [0.5, -0.2]) == ("01F4FF38",)
    with pytest.raises(ValueError, match="emf"):
        drive_blocks(_info(1), [0.5, -0.2], [15.0, math.nan])


def test_emulated_coil_settles_at_its_law_with_the_back_emf():
    """A spinning air-core rotor: over a 2 ms rotor step a coil held at duty d goes from ``i₀`` towards
    ``i∞ = (d V − e)/R`` as ``i∞ + (i₀ − i∞) e^{−h R/L}``, with ``e = K_k·ω / I_n`` of the rotor step before (ω at
    its end, K at its middle: the emulator's K lags half a step) from the torque model evaluated directly (not the
    motor's cache), within 3 % of ``e/R`` + 1 mA; e is volts, so a coil that ignored it would miss by far more."""
    from spherestep.drive.connect import emulated_motor
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype
    from spherestep.sensing import default_array

    design = prototype()
    model, drive = torque_map(design), DriveLimits()
    motor = emulated_motor(design, model, default_array(design, 8), drive=drive)
    motor.w = np.array([0.0, 0.0, 5.0])  # rad/s: volts of back-EMF on the air-core coils, 0.6° per rotor step
    duty = np.full(len(design.stator), 0.5)
    motor.drive(duty, True)
    motor.advance_to(0.016)
    mid = so3.exp(0.001 * motor.w) @ motor.R  # the middle of the next rotor step, where the motor takes its K
    motor.advance_to(0.018)  # that step ends here: the coils' next 2 ms see ω now and K at its middle
    K = model.torque_matrix(mid)
    e = drive.back_emf(motor.w @ K)
    i0 = motor.i.copy()
    motor.advance_to(0.02)
    assert np.abs(e).max() > 1.0, e
    settled = (duty * drive.supply_voltage - e) / drive.resistance  # i∞, reached from i0 with the coil's L/R
    expected = settled + (i0 - settled) * math.exp(-0.002 * drive.resistance / drive.inductance)
    assert np.allclose(motor.i, expected, atol=1e-3 + 0.03 * np.abs(e).max() / drive.resistance), \
        np.abs(motor.i - expected).max()
    assert np.abs(e).max() / drive.resistance > 0.1  # the EMF matters here: 100 mA against a 3.5 mA tolerance


def test_fastest_iron_turn_in_lockstep_ends_well_with_the_host_estimate(monkeypatch):
    """The demo's fastest iron turn (360° about (1, 0.5, 2)) at 500 Hz in lockstep, the emulated coils with their
    back-EMF: no trip (before the host sent it: NAK STUCK after 23 cycles), and the estimate the device was sent
    follows the emulated coils' true back-EMF (the observer's ω and the law's K against the rotor's ω and the
    plant's K): peak above 10 V, RMS error under 15 % of the RMS."""
    from spherestep.drive.hardware import drive_on_hardware
    from spherestep.drive.turn import Turn, choose_model
    from spherestep.motor import prototype

    pairs = []
    step = current_device.CurrentDevice.step

    def recording(self, now_us):
        step(self, now_us)
        if self.driving and self.session and hasattr(self.bridges, "emf"):
            pairs.append((self.emf.copy(), self.bridges.emf.copy()))

    monkeypatch.setattr(current_device.CurrentDevice, "step", recording)
    design = prototype()
    job = Turn(design, (1.0, 0.5, 2.0), 2 * math.pi, choose_model(design), math.radians(0.05))
    r = drive_on_hardware(job, duration=None, port=None, emulate=True, rate=500.0, lockstep=True)
    assert r.details.outcome == "done", r.details.message
    sent, true = (np.array(x) for x in zip(*pairs))
    assert np.abs(true).max() > 10.0
    rms = math.sqrt(np.mean(true ** 2))
    assert math.sqrt(np.mean((sent - true) ** 2)) < 0.15 * rms, (math.sqrt(np.mean((sent - true) ** 2)), rms)
    assert math.degrees(r.max_tracking_error) < 1.0 and math.degrees(r.final_error) < 0.05
