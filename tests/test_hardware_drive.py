"""Protocol version 2 and the device-side limits: the Python device against the firmware's shared vectors
(the C++ device runs the same file in tests/test_firmware.py), the wire format, and the host-side limits."""

from __future__ import annotations

import math

import numpy as np
import pytest

from spherestep.errors import InputError
from spherestep.hardware.current_device import CurrentDevice
from spherestep.hardware.limits import CurrentLimits, ThermalLimitError, heating_step
from spherestep.hardware.protocol import encode
from spherestep.hardware.protocol2 import MAX_FRAME2, decode_block, encode_block, frame_bytes, parse_state
from vectors2 import run_vectors

class TablePlant:
    """The sense reads what the vectors say; the bridges record what the device drives."""

    def __init__(self, coils: int, sensors: int):
        self.ma = np.zeros(coils, dtype=np.int64)
        self.counts = np.zeros((sensors, 3), dtype=np.int64)
        self.stale = 0
        self.duty = np.zeros(coils)
        self.enabled = False

    def measure(self):
        return self.ma.copy()

    def drive(self, duty, enabled):
        self.duty, self.enabled = np.asarray(duty, dtype=float), enabled

    def sense(self):
        return self.counts.copy(), self.stale


class PythonRig:
    """The Python CurrentDevice on a TablePlant, as tests/vectors2.py drives a rig."""

    def __init__(self, coils, sensors, watchdog, period, name, limits):
        self.plant = TablePlant(coils, sensors)
        self.dev = CurrentDevice(self.plant, coils, sensors, watchdog_ms=watchdog, period_us=period,
                                 limits=CurrentLimits(**limits), supply=24.0, inductance=18.7e-3, bandwidth=125.0,
                                 nominal_ma=1000, field_lsb_nt=8118, name=name)

    def meas(self, ma):
        self.plant.ma = np.array(ma)

    def field(self, stale, counts):
        self.plant.stale, self.plant.counts = stale, np.array(counts).reshape(-1, 3)

    def tick(self, now):
        self.dev.tick(now)

    def step(self, now):
        self.dev.step(now)

    def send(self, data, now):
        return [self.dev.receive(data, now)]

    def duty(self):
        return list(self.plant.duty)

    def enabled(self):
        return self.plant.enabled

    def trip(self):
        return self.dev.tripped, (self.dev.trips[-1][1] if self.dev.trips else -1)


def test_python_device_passes_the_shared_vectors():
    """Every line of firmware/test/vectors2.txt, as firmware/test/test_drive.cpp runs it."""
    assert run_vectors(PythonRig) > 150


def test_blocks_round_trip_signed_16_bit_values():
    values = np.array([0, 1, -1, 500, -1000, 32767, -32767])
    text = encode_block(values)
    assert text == "00000001FFFF01F4FC187FFF8001"
    assert np.array_equal(decode_block(text, 7), values)
    assert decode_block(text.lower(), 7) is not None
    assert decode_block(text[:-1], 7) is None and decode_block("G" * 28, 7) is None
    assert np.array_equal(decode_block(encode_block([40000, -40000]), 2), [32767, -32767])  # clipped


def test_frame_sizes_for_the_prototype_match_encoded_frames():
    """29 coils, 8 sensors: the byte counts docs/protocol.md quotes, checked against real frames."""
    sizes = frame_bytes(29, 8)
    drive = encode(0, "DRIVE", encode_block(np.zeros(29)), encode_block(np.zeros(29)), max_frame=MAX_FRAME2)
    answer = encode(0, "ACK", "DRIVE", "00000000", "0", encode_block(np.zeros(29)), encode_block(np.zeros(24)),
                    max_frame=MAX_FRAME2)
    assert (len(drive), len(answer)) == (sizes["drive"], sizes["answer"]) == (249, 244)  # currents and back-EMF
    assert sizes["round_trip"] == 493
    # 115200 baud, 10 bits per byte: at most 23 round trips a second
    assert 115200 / 10 / sizes["round_trip"] == pytest.approx(23.4, abs=0.1)


def test_state_is_parsed_in_si_units_and_flags_saturation():
    body = ("00001194", "1", encode_block([100, -250]), encode_block([1000, -2, 32767, 0, 0, 0]))
    state = parse_state(body, 2, 2, 8.118e-6)
    assert state.time_us == 4500 and state.stale == 1
    assert np.allclose(state.currents, [0.1, -0.25])
    assert state.field[0, 0] == pytest.approx(8.118e-3)
    assert state.saturated.tolist() == [True, False]


def test_heating_step_is_the_exact_first_order_solution():
    """Held current i for time T in n steps equals one step of T, and tends to (i / i_c)²."""
    lim = CurrentLimits(thermal_time=10.0, continuous_current=1.0)
    h = 0.0
    for _ in range(100):
        h = heating_step(h, 1.5, 0.1, lim)
    assert h == pytest.approx(heating_step(0.0, 1.5, 10.0, lim), rel=1e-12)
    assert h == pytest.approx(2.25 * (1 - math.exp(-1.0)), rel=1e-12)


def test_host_limits_refuse_what_the_device_refuses():
    lim = CurrentLimits()
    lim.check_setpoints([1.0, -1.0, 0.5])  # 54 W
    with pytest.raises(ThermalLimitError, match="max_current"):
        lim.check_setpoints([1.001, 0, 0])
    with pytest.raises(ThermalLimitError, match="max_power"):
        lim.check_setpoints([0.9] * 6)  # 117 W
    with pytest.raises(InputError, match="max_duty"):
        CurrentLimits(max_duty=1.5)


def test_device_rejects_bad_configuration():
    plant = TablePlant(3, 1)
    with pytest.raises(InputError, match="coils"):
        CurrentDevice(plant, 40, 1)
    with pytest.raises(InputError, match="nominal_ma"):
        CurrentDevice(plant, 3, 1, nominal_ma=5000)


def test_drive_sends_the_back_emf_only_to_a_device_that_takes_it():
    """``DRIVE``'s arguments: two blocks (mA, 10 mV) to a device whose handshake has CAP_EMF, the currents alone to
    one without it or when no estimate is given; a bad estimate is refused naming ``emf``."""
    from spherestep.hardware.drive_link import DriveInfo, drive_blocks

    def info(caps):
        return DriveInfo("t", 2, 0, 0.1, 1e-3, 1.0, 100.0, 8e-6, 24.0, 24.0, 18.7e-3, caps)

    assert drive_blocks(info(1), [0.5, -0.2], [15.0, -0.26]) == ("01F4FF38", "05DCFFE6")
    assert drive_blocks(info(0), [0.5, -0.2], [15.0, -0.26]) == ("01F4FF38",)
    assert drive_blocks(info(1), [0.5, -0.2]) == ("01F4FF38",)
    with pytest.raises(ValueError, match="emf"):
        drive_blocks(info(1), [0.5, -0.2], [15.0, float("nan")])
    with pytest.raises(ValueError, match="currents"):
        drive_blocks(info(1), [0.5], [15.0])
