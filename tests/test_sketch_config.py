"""The sketch's coil constants come from the design: the shipped header is the prototype's export, and the HELLO
the host-built sketch answers with (firmware/test/test_drive_sketch.cpp) passes the host's check against the
prototype's drive, while the old hand-written 24-ohm constants are refused."""

import re
from pathlib import Path

import pytest

from spherestep.export import firmware_header
from spherestep.hardware.drive_link import DeviceMismatch, device_info
from spherestep.hardware.protocol import decode, encode
from spherestep.hardware.protocol2 import MAX_FRAME2
from spherestep.magnetics import design_model
from spherestep.motor import prototype

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"


def test_the_shipped_header_is_the_prototypes_export():
    assert (FIRMWARE / "spherestep_drive" / "spherestep_config.h").read_text() == firmware_header(prototype())


def test_the_header_states_the_designs_drive_exactly():
    drive = design_model(prototype()).limits
    text = firmware_header(prototype())
    limits = [float(x) for x in re.search(r"LIMITS = \{([^}]*)\}", text).group(1).split(",")]
    assert limits == [drive.max_current, 0.95, drive.supply_power, drive.nominal_current, 60.0, drive.resistance, 1.25]
    assert float(re.search(r"SUPPLY_V = ([^;]*);", text).group(1)) == drive.supply_voltage
    assert float(re.search(r"INDUCTANCE_H = ([^;]*);", text).group(1)) == drive.inductance
    assert int(re.search(r"NOMINAL_MA = ([^;]*);", text).group(1)) == round(1000 * drive.nominal_current)
    assert f"fingerprint: {prototype().fingerprint}" in text


def _hello(fields: str):
    return device_info(decode(encode(0, "ACK", *fields.split(","), max_frame=MAX_FRAME2)[1:-1], MAX_FRAME2), "sketch")


def test_the_sketchs_hello_passes_the_hosts_check_for_the_prototype():
    source = (FIRMWARE / "test" / "test_drive_sketch.cpp").read_text()
    fields = re.search(r'frame\("00,ACK,(HELLO,2,[^"]*)"\)', source).group(1)
    info = _hello(fields)
    info.check_drive(design_model(prototype()).limits)  # raises DeviceMismatch if the sketch's coils differ
    with pytest.raises(DeviceMismatch, match="coil resistance"):  # the sketch's former hand-written 24-ohm winding
        _hello("HELLO,2,29,8,100,1000,1000,100,8118,24000,24000,18700,spherestep-t41").check_drive(
            design_model(prototype()).limits)
