"""Protocol 2's handshake reports the supply and the coils (issue 36): the host reads them in SI, refuses the older
9-field answer naming the firmware to flash, and refuses a device whose supply, coils or current limit disagree with
the design's DriveLimits — one line, exit 2 in the CLI, every coil off."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from spherestep.electrics import DriveLimits
from spherestep.hardware import CurrentDevice, LinkError
from spherestep.hardware.drive_link import AGREE, FIRMWARE, DeviceMismatch, DriveInfo, device_info
from spherestep.hardware.protocol import decode, encode
from spherestep.hardware.protocol2 import CAP_EMF, MAX_FRAME2


class Quiet:
    """Bridges that carry nothing: enough for a handshake."""

    def __init__(self, coils):
        self.coils = coils

    def measure(self):
        return np.zeros(self.coils, dtype=np.int64)

    def drive(self, duty, enabled):
        pass

    def sense(self):
        return np.zeros((1, 3), dtype=np.int64), 0


def hello(device: CurrentDevice):
    reply = device.receive(encode(0, "HELLO", 2, max_frame=MAX_FRAME2), 0)
    return decode(reply.strip()[1:], MAX_FRAME2)


def answer(*fields):
    """A well-framed ``ACK,HELLO`` carrying ``fields``."""
    return decode(encode(0, "ACK", "HELLO", *fields, max_frame=MAX_FRAME2).strip()[1:], MAX_FRAME2)


def test_the_device_reports_its_supply_and_coils_in_si():
    """The Python device's answer, read by the host: every field back in SI (the wire's mV, mΩ, µH)."""
    drive = DriveLimits()
    info = device_info(hello(CurrentDevice(Quiet(3), 3, 1)), "test")
    assert (info.coils, info.sensors, info.watchdog, info.period) == (3, 1, 0.1, 1e-3)
    assert info.supply_voltage == 24.0 and info.resistance == 24.0
    assert info.inductance == pytest.approx(drive.inductance, abs=5e-7)  # 18714 µH on the wire
    assert info.max_current == 1.0 and info.max_power == 100.0
    info.check_drive(drive)  # the device's defaults are the drive's own
    assert info.capabilities == CAP_EMF and info.takes_emf and info.name == "spherestep-t41"


def test_a_device_without_capabilities_takes_currents_only():
    """The 12-field answer (firmware before the back-EMF block) is still a device: capabilities 0, so the host
    sends the currents-only DRIVE; a capability field that is not hex is a malformed handshake."""
    info = device_info(answer(2, 29, 8, 100, 1000, 1000, 100, 8118, 24000, 24000, 18700, "t41"), "test")
    assert (info.capabilities, info.takes_emf, info.name, info.coils) == (0, False, "t41", 29)
    with pytest.raises(LinkError, match="capabilities"):
        device_info(answer(2, 29, 8, 100, 1000, 1000, 100, 8118, 24000, 24000, 18700, "Z", "t41"), "test")


def test_the_older_answer_is_refused_naming_the_firmware_to_flash():
    """The answer of the firmware before issue 36 (the sketch's, 9 fields) is refused: an InputError naming the
    firmware; a 12-field answer with a zero resistance is a malformed handshake (LinkError)."""
    old = answer(2, 29, 8, 100, 1000, 1000, 100, 8118, "spherestep-t41")
    with pytest.raises(DeviceMismatch, match="without its supply voltage and coils") as err:
        device_info(old, "/dev/ttyACM0")
    assert FIRMWARE in str(err.value) and "\n" not in str(err.value) and err.value.field == "firmware"
    garbled = answer(2, 29, 8, 100, 1000, 1000, 100, 8118, 24000, 0, 18700, "x")
    with pytest.raises(LinkError, match="supply_mV"):
        device_info(garbled, "/dev/ttyACM0")


def _info(**changes) -> DriveInfo:
    d = DriveLimits()
    base = dict(name="t41", coils=29, sensors=8, watchdog=0.1, period=1e-3, max_current=d.max_current,
                max_power=d.supply_power, field_lsb=8.118e-6, supply_voltage=d.supply_voltage,
                resistance=d.resistance, inductance=18.7e-3)
    return DriveInfo(**{**base, **changes})


@pytest.mark.parametrize("field, value", [("supply_voltage", 12.0), ("resistance", 82.958), ("inductance", 0.6502),
                                          ("max_current", 0.289)])
def test_a_device_that_disagrees_is_refused_naming_the_quantity(field, value):
    drive = DriveLimits()
    _info().check_drive(drive)  # the sketch's typed 18.7 mH against Wheeler's 18.714 mH: within AGREE
    design = getattr(drive, field)
    _info(**{field: design * (1 + 0.9 * AGREE)}).check_drive(drive)  # just inside
    with pytest.raises(DeviceMismatch) as err:
        _info(**{field: value}).check_drive(drive, "the device on /dev/ttyACM0")
    assert err.value.field == field and field in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(DeviceMismatch):
        _info(**{field: design * (1 + 1.1 * AGREE) + 1e-3}).check_drive(drive)  # just outside


@pytest.mark.slow
def test_move_refuses_a_device_with_other_coils_exit_2_every_coil_off(tmp_path):
    """``spherestep move --port`` against an emulated device wound for the default 24 Ω coils while the prototype's
    design has its iron coil (82.96 Ω): one line naming the resistance, exit 2, no output folder, the bridges
    asleep, no current in any coil and none ever driven."""
    from spherestep.drive.connect import emulated_motor
    from spherestep.hardware import MotorPty
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype
    from spherestep.sensing import default_array

    design = prototype()
    motor = emulated_motor(design, torque_map(design), default_array(design, 8), drive=DriveLimits())
    exe = shutil.which("spherestep", path=str(Path(sys.executable).parent))
    out = tmp_path / "o"
    with MotorPty(motor, watchdog_ms=250) as dev:
        run = subprocess.run([exe, "move", "--axis", "1,0,0", "--angle", "10", "--port", dev.port, "--out", str(out)],
                             capture_output=True, text=True, timeout=570)
        time.sleep(0.05)
        truth = dev.truth()
    assert run.returncode == 2, run.stderr
    errors = [line for line in run.stderr.splitlines() if "error" in line]  # the rest: progress lines
    assert len(errors) == 1 and "Traceback" not in run.stderr, run.stderr
    assert "coil resistance of 24 Ω" in errors[0] and "resistance = 82.96 Ω" in errors[0], run.stderr
    # never driven (off_at stays 0: the coils never went from driven to off); the session the refused handshake
    # opened may end later in the watchdog's trip, with every coil already off
    assert not truth.enabled and np.abs(truth.i).max() < 1e-9 and truth.off_at == 0.0
    assert all(code == "WDOG" for code, _, _ in truth.trips), truth.trips
    assert not out.exists() or not any(out.iterdir())
