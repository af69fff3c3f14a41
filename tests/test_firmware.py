"""The reference firmware, built with the host's g++ and run: its protocol core against the shared vectors
(the same ones the Python emulator passes) and the sketch itself against a recording Arduino stand-in."""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import pytest

FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"
GXX = shutil.which("g++")

pytestmark = pytest.mark.skipif(GXX is None, reason="g++ is not installed: the firmware harness cannot be built")


def build_and_run(tmp_path: Path, source: str, *args: str, extra: tuple[str, ...] = ()) -> tuple[int, str]:
    exe = tmp_path / Path(source).stem
    build = subprocess.run(
        [GXX, "-std=c++11", "-Wall", "-Wextra", "-Werror", "-pedantic", "-I", str(FIRMWARE / "spherestep"),
         "-I", str(FIRMWARE / "test" / "arduino"), "-I", str(FIRMWARE / "spherestep_drive"),
         str(FIRMWARE / "test" / source),
         str(FIRMWARE / "spherestep" / "protocol.cpp"), *(str(FIRMWARE / "spherestep" / e) for e in extra),
         "-o", str(exe)],
        capture_output=True, text=True, timeout=120)
    assert build.returncode == 0, build.stderr
    run = subprocess.run([str(exe), *args], capture_output=True, text=True, timeout=60)
    return run.returncode, run.stdout


def test_protocol_core_passes_the_vectors(tmp_path):
    code, out = build_and_run(tmp_path, "test_protocol.cpp", str(FIRMWARE / "test" / "vectors.txt"))
    assert code == 0, out
    passed, failed = map(int, re.search(r"^(\d+) passed, (\d+) failed$", out, re.M).groups())
    assert failed == 0 and passed >= 130, out


def test_current_device_passes_the_vectors(tmp_path):
    """drive.cpp (protocol version 2, PI loops, limits) against vectors2.txt, which the Python CurrentDevice
    also passes (tests/test_hardware_drive.py)."""
    code, out = build_and_run(tmp_path, "test_drive.cpp", str(FIRMWARE / "test" / "vectors2.txt"),
                              extra=("drive.cpp",))
    assert code == 0, out
    passed, failed = map(int, re.search(r"^(\d+) passed, (\d+) failed$", out, re.M).groups())
    assert failed == 0 and passed >= 130, out


def test_sketch_runs_on_the_host(tmp_path):
    code, out = build_and_run(tmp_path, "test_sketch.cpp")
    assert code == 0, out
    assert re.search(r"^10 passed, 0 failed$", out, re.M), out


def test_teensy_sketch_runs_on_the_host_against_a_recording_board(tmp_path):
    """spherestep_drive.ino itself with drive.cpp, against the Arduino stand-ins (SPI, Wire, pins, PWM, micros,
    Serial) and a recording board: the pin map (29 distinct PWM pins of the Teensy 4.1 at 20 kHz, none on SPI or
    I2C), the 74HC595 direction word, |duty| on the EN pins, the sign of the IPROPI reads (a magnitude, signed by
    the direction driven), the magnetometers' stale flags, and a trip putting the bridges to sleep before the supply
    relay opens (firmware/test/test_drive_sketch.cpp)."""
    code, out = build_and_run(tmp_path, "test_drive_sketch.cpp", extra=("drive.cpp",))
    assert code == 0, out
    assert re.search(r"^44 passed, 0 failed$", out, re.M), out


TEENSY41 = ["-mcpu=cortex-m7", "-mthumb", "-mfloat-abi=hard", "-mfpu=fpv5-d16", "-O2", "-std=gnu++17",
            "-fno-exceptions", "-fno-rtti", "-fno-threadsafe-statics", "-Wall", "-Wextra", "-Werror"]


@pytest.mark.skipif(shutil.which("arm-none-eabi-g++") is None,
                    reason="arm-none-eabi-g++ is not installed (Debian: gcc-arm-none-eabi libnewlib-arm-none-eabi "
                           "libstdc++-arm-none-eabi-newlib; `make test` installs them as root)")
def test_firmware_cross_compiles_for_the_teensy_41(tmp_path):
    """The current-mode board the README names: the protocol core, the device core (drive.cpp: PI loops,
    limits, trips) and the sketch (spherestep_drive.ino, against the Arduino stand-ins' declarations of SPI, Wire,
    pins and Serial: Teensyduino's core is not packaged for Debian or PyPI, so nothing is linked) build for the
    Teensy 4.1's i.MX RT1062 (Cortex-M7, hard float) with Teensyduino's code-generation flags, no exceptions, no
    RTTI. (The relay sketch targets the Mega: below.)"""
    sources = (("spherestep/protocol.cpp", []), ("spherestep/drive.cpp", []),
               ("spherestep_drive/spherestep_drive.ino", ["-x", "c++"]))
    for source, lang in sources:
        build = subprocess.run(["arm-none-eabi-g++", *TEENSY41, "-I", str(FIRMWARE / "spherestep"), "-I",
                                str(FIRMWARE / "test" / "arduino"), *lang, "-c", str(FIRMWARE / source),
                                "-o", str(tmp_path / f"{Path(source).name}.o")], capture_output=True, text=True,
                               timeout=120)
        assert build.returncode == 0, build.stderr
        size = subprocess.run(["arm-none-eabi-size", str(tmp_path / f"{Path(source).name}.o")], capture_output=True,
                              text=True)
        text = int(size.stdout.splitlines()[1].split()[0])
        assert 0 < text < 64_000, size.stdout  # code that fits the board's tightly coupled memory with room to spare


@pytest.mark.skipif(shutil.which("avr-g++") is None,
                    reason="avr-g++ is not installed (Debian: gcc-avr avr-libc; `make test` installs them as root)")
def test_firmware_cross_compiles_for_the_mega(tmp_path):
    """protocol.cpp and the sketch build for the ATmega2560 with the flags of the Arduino IDE (no STL, no heap)."""
    flags = ["-mmcu=atmega2560", "-Os", "-std=gnu++11", "-fno-exceptions", "-fno-threadsafe-statics", "-Wall",
             "-Wextra", "-Werror", "-I", str(FIRMWARE / "spherestep"), "-I", str(FIRMWARE / "test" / "arduino")]
    for source, lang in (("protocol.cpp", []), ("spherestep.ino", ["-x", "c++"])):
        build = subprocess.run(["avr-g++", *flags, *lang, "-c", str(FIRMWARE / "spherestep" / source),
                                "-o", str(tmp_path / f"{source}.o")], capture_output=True, text=True, timeout=120)
        assert build.returncode == 0, build.stderr
