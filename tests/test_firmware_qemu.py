"""The firmware run as firmware: drive.cpp and protocol.cpp built with arm-none-eabi-g++ for QEMU's mps2-an500
(firmware/qemu/board.cpp) and run in qemu-system-arm: the shared vectors through its UART0 with a table for its
pins, the emulated motor behind it with the faults the Python device meets, and the one-line refusals when a tool
is missing or the firmware does not answer."""

from __future__ import annotations

import os
import select
import shutil
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from spherestep.control import Trajectory
from spherestep.errors import InputError
from spherestep.hardware.backend import LinkError
from spherestep.hardware.limits import CurrentLimits
from vectors2 import run_vectors

TOOLS = ("qemu-system-arm", "arm-none-eabi-g++")
pytestmark = [pytest.mark.slow, pytest.mark.skipif(
    any(shutil.which(t) is None for t in TOOLS),
    reason="qemu-system-arm or arm-none-eabi-g++ is not installed (Debian: qemu-system-arm gcc-arm-none-eabi "
           "libnewlib-arm-none-eabi; `make test` installs them as root)")]


class QemuRig:
    """One QEMU per device2 block: the table's currents and counts in the board's exchange, frames on UART0."""

    def __init__(self, coils, sensors, watchdog, period, name, limits):
        from spherestep.hardware.qemu import QemuBoard

        self.board = QemuBoard(realtime=False).start()
        self.board.configure(coils, sensors, watchdog_ms=watchdog, period_us=period, limits=CurrentLimits(**limits),
                             supply=24.0, inductance=18.7e-3, bandwidth=125.0, nominal_ma=1000, field_lsb_nt=8118,
                             name=name)
        self.link = self.board._hold  # the host's end of UART0, raw
        self.ma = np.zeros(coils, dtype=np.int64)
        self.counts, self.stale = np.zeros((sensors, 3), dtype=np.int64), 0
        self.sent, self.read = self.board.received(), self.board.answered()
        self.last = self.board.state()

    def sense(self):
        return self.counts, self.stale

    def meas(self, ma):
        self.ma = np.array(ma)
        self.board.exchange["ma"][:len(ma)] = self.ma  # a reply's currents, before the next step as well

    def field(self, stale, counts):
        self.stale, self.counts = stale, np.array(counts).reshape(-1, 3)

    def tick(self, now):
        self.last = self.board.tick(now, self.sense)

    def step(self, now):
        self.last = self.board.step(now, self.ma, self.sense)

    def send(self, data, now):
        os.write(self.link, data)
        self.sent += len(data)
        deadline = time.monotonic() + 10
        while self.board.received() < self.sent:  # every byte taken, each reply out before the next byte
            assert time.monotonic() < deadline, "the firmware stopped taking bytes"
            self.board.serve(self.sense, 0.001)
        out = b""
        while self.read < self.board.answered():  # the pty passes them on a moment later
            assert select.select([self.link], [], [], 10)[0], "the firmware's answer did not arrive"
            chunk = os.read(self.link, 4096)
            out += chunk
            self.read += len(chunk)
        self.last = self.board.state()
        return [out]

    def duty(self):
        return list(self.last.duty)

    def enabled(self):
        return self.last.enabled

    def trip(self):
        return (self.last.trip or None), self.last.coil


def test_the_firmware_in_qemu_passes_the_shared_vectors():
    """Every line of vectors2.txt (the protocol-2 conformance: handshake, frames, limits, and the trips WDOG,
    CRCS, OVER, OPEN, STUCK, HEAT) against drive.cpp on the Cortex-M7, as the Python device and the host build
    pass it."""
    assert run_vectors(QemuRig, lambda rig: rig.board.stop()) > 150


def test_the_firmware_answers_hello_with_its_build_and_counts_its_step():
    from spherestep.hardware import DriveLink
    from spherestep.hardware.qemu import CALIBRATION_INSTRUCTIONS, ICOUNT_SHIFT, QemuBoard

    with QemuBoard(realtime=False) as board:
        build = board.configure(29, 8, watchdog_ms=100, period_us=1000, limits=CurrentLimits(), supply=24.0,
                                inductance=18.7e-3, bandwidth=500.0, nominal_ma=1000, field_lsb_nt=8118,
                                name="spherestep-qemu")
        assert build.startswith("drive.cpp on mps2-an500, arm-none-eabi-g++ ")
        # SysTick at 25 MHz (40 ns) against 2^shift ns per instruction: the calibration loop's counts agree
        ticks = int(board.exchange["calibration"])
        assert ticks == pytest.approx(CALIBRATION_INSTRUCTIONS * 2 ** ICOUNT_SHIFT / 40, rel=1e-3)
        counts = np.zeros((8, 3), dtype=np.int64)
        done = threading.Event()
        pins = threading.Thread(target=lambda: [board.serve(lambda: (counts, 0), 0.005) for _ in iter(done.is_set,
                                                                                                   True)])
        pins.start()  # the magnetometers for the replies, while the link waits for them
        with DriveLink(board.port, timeout=0.5) as link:
            try:
                assert link.info.name == "spherestep-qemu" and link.info.coils == 29
                state = link.drive(np.full(29, 0.1))
                assert state.field.shape == (8, 3)
            finally:
                done.set()
                pins.join()
            for k in range(5):  # 100 mA asked and read: the loops run, the bridges drive
                assert board.step(1000 * (k + 1), np.full(29, 100), lambda: (counts, 0)).enabled
        steps, mean, worst = board.step_cost()
        assert steps == 5 and 500 < mean <= worst < 20000, (steps, mean, worst)


def test_a_board_that_does_not_answer_is_one_line(tmp_path):
    from spherestep.hardware.qemu import FIRMWARE, QemuBoard

    silent = tmp_path / "silent.elf"  # a valid image that never reads its UARTs: the firmware of another board
    (tmp_path / "s.c").write_text("void reset(void){for(;;){}}\nextern unsigned __stack_top;\n"
                                  "__attribute__((section(\".vectors\"),used)) void (*const v[2])(void) = "
                                  "{(void (*)(void))&__stack_top, reset};\n")
    subprocess.run(["arm-none-eabi-gcc", "-mcpu=cortex-m7", "-mthumb", "-nostartfiles", "-T",
                    str(FIRMWARE / "qemu" / "mps2_an500.ld"), str(tmp_path / "s.c"), "-o", str(silent)], check=True)
    with QemuBoard(silent, timeout=0.5, realtime=False) as board:
        with pytest.raises(LinkError, match=r"^the firmware in QEMU did not answer 'C' within 0.5 s$"):
            board.configure(3, 1, watchdog_ms=100, period_us=1000, limits=CurrentLimits(), supply=24.0,
                            inductance=18.7e-3, bandwidth=125.0, nominal_ma=1000, field_lsb_nt=8118, name="x")


def test_missing_tools_are_named_with_how_to_install_them(monkeypatch, tmp_path):
    from spherestep.hardware import qemu

    monkeypatch.setattr(qemu.shutil, "which", lambda tool: None if tool == "qemu-system-arm" else "/usr/bin/x")
    with pytest.raises(InputError, match="needs qemu-system-arm, which is not installed .*apt-get install"):
        qemu.require_tools()
    out = tmp_path / "out"
    env = {**os.environ, "PATH": str(tmp_path)}  # neither tool on the path
    run = subprocess.run([sys.executable, "-c", "from spherestep.cli import main; main()", "move", "--axis", "1,0,0",
                          "--angle", "10", "--emulate", "--firmware", "qemu", "--out", str(out)],
                         capture_output=True, text=True, env=env, timeout=120)
    assert run.returncode == 2 and not out.exists(), run.stderr
    assert run.stderr.count("\n") == 1 and "arm-none-eabi-g++ and qemu-system-arm" in run.stderr, run.stderr
    run = subprocess.run([sys.executable, "-c", "from spherestep.cli import main; main()", "move", "--axis", "1,0,0",
                          "--angle", "10", "--firmware", "qemu", "--out", str(out)], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 2 and "--firmware" in run.stderr and not out.exists(), run.stderr


FAULT_AT = 0.4  # s of device time
RATE = 60.0  # Hz: a DRIVE, with its back-EMF estimate, every 16.7 ms, within the 20 ms it stays fresh


@pytest.fixture(scope="module")
def rig():
    from spherestep.control import DriveLimits
    from spherestep.magnetics import torque_map
    from spherestep.motor import prototype
    from spherestep.sensing import default_array

    design = prototype()
    return {"design": design, "model": torque_map(design), "sensors": default_array(design, 8),
            "drive": DriveLimits()}


def session(rig, duration, **options):
    """A hold of the start pose at 60 Hz (RATE) on the air model with the firmware in QEMU (a 29-coil DRIVE takes 3-15
    ms through QEMU's UART on this machine), watchdog 250 ms as in tests/test_hardware_servo.py."""
    from spherestep.drive import servo_session

    options.setdefault("watchdog_ms", 250)
    options.setdefault("max_late", 0.2)
    return servo_session(rig["design"], Trajectory.hold(np.eye(3)), duration, emulate=True, sensors=rig["sensors"],
                         model=rig["model"], drive=rig["drive"], rate=RATE, firmware="qemu", **options)


@pytest.fixture
def biased(monkeypatch):
    """0.3 A more on coil 0 than the law asks (the servo holds against it): the coil faults meet a coil that
    carries current (tests/test_hardware_servo.py's law)."""
    from spherestep.drive import session as module
    from test_hardware_servo import with_bias

    monkeypatch.setattr(module, "ServoLaw", with_bias())


@pytest.mark.parametrize("fault, codes", [
    ("open_coil", {"OPEN"}), ("stuck_coil", {"STUCK", "OVER"}), ("frozen_reading", {"STUCK"}),
    ("sensor_stops", {"SENSOR"}), ("sensor_garbage", {"SENSOR"})])
def test_the_motors_faults_end_with_every_coil_off_as_on_the_python_device(rig, biased, fault, codes):
    from spherestep.hardware.motor_emulator import MotorFaults

    index = {"sensor_stops": 3, "sensor_garbage": 5}.get(fault, 0)
    s = session(rig, 1.5, faults=MotorFaults(**{fault: (index, FAULT_AT)}))
    assert s.report.outcome in codes, s.report.to_dict()
    assert FAULT_AT - 1e-9 <= s.final.off_at <= FAULT_AT + s.watchdog, (s.final.off_at, s.final.trips)
    assert not s.final.enabled and np.abs(s.final.i).max() < 1e-3
    if codes != {"SENSOR"}:  # the device's own trip, on the coil the fault struck
        assert s.final.trips and s.final.trips[0][0] in codes and s.final.trips[0][1] == 0, s.final.trips


def test_a_host_that_falls_silent_is_stopped_by_the_firmwares_watchdog(rig, monkeypatch):
    """Link loss: the host stalls 0.6 s mid-hold; the firmware's watchdog (250 ms) switches every coil off."""
    from spherestep.drive import session as module

    class Silent(module.ServoLaw):
        def step(self, t, measurement=None, measured_at=None):
            if t > FAULT_AT and not getattr(self, "stalled", False):
                self.stalled = True
                time.sleep(0.6)
            return super().step(t, measurement, measured_at)

    monkeypatch.setattr(module, "ServoLaw", Silent)
    s = session(rig, 1.5, max_late=1.0)
    assert s.report.outcome == "WDOG", s.report.to_dict()
    assert [t[0] for t in s.final.trips] == ["WDOG"] and not s.final.enabled and np.abs(s.final.i).max() < 1e-3


def tty_raw(fd: int) -> None:
    import tty

    tty.setraw(fd)


def raw_session(server, fault: str) -> tuple[list[bytes], object]:
    """One device-level fault over the raw line, the emulated motor behind ``server`` (a MotorPty or a
    QemuMotor, started): ``heat`` (150 mA held on coil 0 against a 0.1 A rating with a 50 ms thermal time),
    ``over`` (100 mA on coil 0, whose bridge shorts at 0.3 s: 1 A against a 0.2 A limit), ``crcs`` (eight
    damaged frames in a row). Returns the replies and the truth 0.2 s after the last."""
    from spherestep.hardware.protocol import encode
    from spherestep.hardware.protocol2 import MAX_FRAME2, encode_block

    fd = os.open(server.port, os.O_RDWR | os.O_NOCTTY)
    tty_raw(fd)
    replies: list[bytes] = []
    buffer = b""

    def ask(frame: bytes) -> bytes:
        nonlocal buffer
        os.write(fd, frame)
        deadline = time.monotonic() + 2.0
        while b"\n" not in buffer:
            assert time.monotonic() < deadline, f"no answer to {frame!r}"
            if select.select([fd], [], [], 0.05)[0]:
                buffer += os.read(fd, 4096)
        line, _, buffer = buffer.partition(b"\n")
        replies.append(line)
        return line

    try:
        assert b",ACK,HELLO,2," in ask(encode(0, "HELLO", 2, max_frame=MAX_FRAME2))
        block = np.zeros(29)
        block[0] = 150.0 if fault == "heat" else 100.0
        if fault == "crcs":
            ask(encode(1, "DRIVE", encode_block(block), max_frame=MAX_FRAME2))
            for _ in range(8):
                ask(b"$02,PING*0000\n")  # a damaged frame: the CRC does not match
            ask(encode(3, "READ", max_frame=MAX_FRAME2))
        else:
            for k in range(200):  # every 10 ms for up to 2 s, until the device refuses
                if b",NAK," in ask(encode(k % 256, "DRIVE", encode_block(block), max_frame=MAX_FRAME2)):
                    break
                time.sleep(0.01)
        time.sleep(0.2)
        return replies, server.truth()
    finally:
        os.close(fd)


@pytest.mark.parametrize("fault, code, coil", [("heat", "HEAT", 0), ("over", "OVER", 0), ("crcs", "CRCS", -1)])
def test_heat_over_current_and_a_crc_storm_end_alike_on_the_python_device_and_the_firmware(rig, fault, code, coil):
    """The same line, motor and fault against both devices: the same trip, the same coil, every coil off."""
    from dataclasses import replace

    from spherestep.drive.connect import emulated_motor
    from spherestep.hardware import MotorPty
    from spherestep.hardware.motor_emulator import MotorFaults
    from spherestep.hardware.qemu import QemuMotor

    limits = CurrentLimits.from_drive(rig["drive"])
    options = {"watchdog_ms": 500}
    faults = None
    if fault == "heat":
        options["limits"] = replace(limits, continuous_current=0.1, thermal_time=0.05)
    elif fault == "over":
        options["limits"], options["nominal_ma"] = replace(limits, max_current=0.2), 100
        faults = MotorFaults(stuck_coil=(0, 0.3))
    outcomes = []
    for server in (MotorPty, QemuMotor):
        motor = emulated_motor(rig["design"], rig["model"], rig["sensors"], drive=rig["drive"], period=1e-3,
                               faults=faults)
        with server(motor, **options) as dev:
            replies, truth = raw_session(dev, fault)
        assert replies[-1].split(b"*")[0].endswith(b",NAK," + code.encode()), (server.__name__, replies[-3:])
        assert [t[:2] for t in truth.trips] == [(code, coil)], (server.__name__, truth.trips)
        assert not truth.enabled and np.abs(truth.i).max() < 1e-3, server.__name__
        outcomes.append((truth.trips[0][:2], replies[-1].split(b"*")[0].split(b",", 1)[1]))  # when: the clock's
    assert outcomes[0] == outcomes[1]
