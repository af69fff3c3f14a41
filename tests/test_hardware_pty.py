"""The Serial back end against the emulated device over a real pseudo-terminal, with faults on the line.

Every test ends with the device's outputs all off, by the host (OFF) or, when the link is gone, by the
device's watchdog; failures are one-line LinkErrors after a bounded number of attempts, never a hang.

The checks hold whatever the machine's load: what a stall of either end cannot change — counts of frames,
attempts and their identities, the schedule's lower bounds (a step is never applied early; the watchdog never
trips before its period). The wall-clock promises (the plan's duration, failures within a second) are in
``test_wall_clock_promises``, marked ``realtime`` (the Makefile runs those alone, after the parallel run).
"""

from __future__ import annotations

import os
import signal
import threading
import time

import numpy as np
import pytest

from spherestep.commutation import Plan, Step, default_channel_map
from spherestep.errors import InputError
from spherestep.hardware import CoilDriver, CurrentDevice, Faults, LinkError, NakError, PtyDevice, RelayLink, Serial, \
    coil_masks

from relays import play_relays

I3 = np.eye(3)
WATCHDOG_MS = 200
TIMEOUT = 0.1  # host's wait for an answer; a pty answers in well under a millisecond


def make_plan(n_steps, coil_count=4):
    steps = [Step(index=i, target=I3, achieved=I3, error=0.0, coils={i % coil_count: 1, (i + 1) % coil_count: -1})
             for i in range(n_steps)]
    return Plan(steps=steps, coil_count=coil_count, channel_map=default_channel_map(coil_count))


@pytest.fixture
def device_factory():
    devices = []

    def start(faults=None, channels=8, watchdog_ms=WATCHDOG_MS):
        dev = PtyDevice(faults=faults, channels=channels, watchdog_ms=watchdog_ms).start()
        devices.append(dev)
        return dev

    yield start
    for dev in devices:
        dev.stop()


def host(dev, **kwargs):
    kwargs.setdefault("timeout", TIMEOUT)
    kwargs.setdefault("retries", 2)
    kwargs.setdefault("open_timeout", 0.5)
    return Serial(dev.port, **kwargs)


def enables_driven(dev):
    """Enable masks the device drove, in order, without the zero writes of break-before-make and OFF."""
    return [m for kind, m in dev.device.trace if kind == "enable" and m]


def trip_codes(dev):
    """The device's trips, by code (the relay board trips only on its watchdog)."""
    return [code for code, _, _ in dev.device.trips]


def wait_all_off(dev, seconds=2.0):
    deadline = time.monotonic() + seconds
    while dev.state() != (0, 0) and time.monotonic() < deadline:
        time.sleep(0.005)
    return dev.state()


def one_line(exc):
    text = str(exc)
    assert text and "\n" not in text and "Traceback" not in text
    return text


def test_whole_plan_is_streamed_and_acknowledged(device_factory):
    dev = device_factory()
    plan = make_plan(12)
    serial = host(dev)
    t = time.monotonic()
    report = play_relays(plan, serial, rate=50.0)
    # the schedule, which a stall can only delay: SET i leaves no earlier than i / rate after the start, and
    # the last step is held a whole period
    assert time.monotonic() - t >= 12 / 50
    sent = [when for when, kind, line in serial.transcript.entries if kind == "TX" and ",SET," in line]
    assert len(sent) == 12 and all(when >= t + i / 50 for i, when in enumerate(sent))
    assert report.device.name == "spherestep-emu" and report.device.channels == 8
    assert report.device.watchdog == pytest.approx(WATCHDOG_MS / 1000)
    assert enables_driven(dev) == [s.masks(plan.channel_map)[0] for s in plan.steps]
    assert dev.state() == (0, 0) and dev.device.trips == []
    # HELLO, 12 SET and OFF, each acknowledged once; nothing lost, nothing repeated
    assert serial.stats["acked"] == serial.stats["frames"] == dev.frames == 14
    assert serial.transcript.count("RX", "$") == 14 and serial.transcript.count("TX", "$") == 14
    enabled = 0
    for kind, mask in dev.device.trace:  # break before make held on the line as well
        assert kind == "enable" or enabled == 0
        enabled = mask if kind == "enable" else enabled


def test_keepalives_hold_coils_through_a_long_step(device_factory):
    dev = device_factory()
    serial = host(dev)
    play_relays(make_plan(2), serial, rate=2.0)  # 0.5 s per step, watchdog 0.2 s
    assert dev.device.trips == [] and dev.state() == (0, 0)
    assert serial.transcript.count("TX", "$") - 4 == serial.transcript.count("RX", "$") - 4 >= 2 * 3
    assert [line for line in serial.transcript.lines() if " TX " in line][2].split(",")[1].startswith("PING")


@pytest.mark.parametrize("faults, counter", [
    (Faults(corrupt=frozenset({3})), "naks"),  # a flipped bit: NAK CRC, retransmit
    (Faults(drop=frozenset({2})), "timeouts"),  # half a frame lost: no answer, retransmit, device resyncs on '$'
    (Faults(mute=frozenset({4})), "timeouts"),  # answer lost: retransmit, the SET is obeyed twice (idempotent)
    (Faults(garble_reply=frozenset({5})), "ignored"),  # answer damaged: ignored, timeout, retransmit
    (Faults(delay=((3, 1.5 * TIMEOUT),)), "ignored"),  # answer late: retransmit, take it, ignore the second
])
def test_line_faults_are_retried_and_the_plan_completes(device_factory, faults, counter):
    dev = device_factory(faults)
    plan = make_plan(8)
    serial = host(dev)
    play_relays(plan, serial, rate=25.0)
    # the fault forced a retransmission; a stall longer than the timeout may force more, each accounted for
    stats = serial.stats
    assert stats["retransmissions"] >= 1 and stats[counter] >= 1
    assert stats["acked"] == 10 and stats["frames"] == stats["acked"] + stats["retransmissions"]
    assert serial.transcript.count("NOTE", "retransmitting") == stats["retransmissions"]
    assert enables_driven(dev)[-1] == plan.steps[-1].masks(plan.channel_map)[0]
    assert set(enables_driven(dev)) == {s.masks(plan.channel_map)[0] for s in plan.steps}
    assert dev.state() == (0, 0) and dev.device.trips == []


def test_persistent_corruption_gives_up_after_bounded_retries(device_factory):
    dev = device_factory(Faults(corrupt=frozenset(range(3, 1000))))
    serial = host(dev)
    with pytest.raises(LinkError) as err:
        play_relays(make_plan(8), serial, rate=25.0)
    text = one_line(err.value)
    assert text.startswith(f"no valid answer from the device on {dev.port} to SET after 3 attempts")
    assert "switching the coils off failed too" in text and "watchdog opens every relay within 0.2 s" in text
    assert serial.stats["naks"] == 6  # 3 SET + 3 OFF attempts, all NAK CRC
    assert wait_all_off(dev) == (0, 0) and trip_codes(dev) == ["WDOG"]


def test_no_answer_aborts_and_the_watchdog_switches_off(device_factory):
    dev = device_factory(Faults(silent_after=4))
    serial = host(dev)
    with pytest.raises(LinkError) as err:
        play_relays(make_plan(8), serial, rate=25.0)
    assert "to SET after 3 attempts (3 timeouts" in one_line(err.value)
    # the hung device drove the last step it obeyed until its watchdog opened every relay
    assert len(enables_driven(dev)) == 3
    assert wait_all_off(dev) == (0, 0) and trip_codes(dev) == ["WDOG"]
    assert list(dev.device.trace)[-2:] == [("enable", 0), ("polarity", 0)]


def test_device_vanishing_mid_plan_is_a_clean_abort(device_factory):
    dev = device_factory(Faults(vanish_after=5))
    serial = host(dev)
    with pytest.raises(LinkError) as err:
        play_relays(make_plan(8), serial, rate=25.0)
    text = one_line(err.value)
    assert text.startswith(f"serial link to {dev.port} lost during SET") and "watchdog" in text
    assert wait_all_off(dev) == (0, 0) and trip_codes(dev) == ["WDOG"]


def test_host_falling_silent_trips_the_watchdog_and_is_told(device_factory):
    dev = device_factory()
    plan = make_plan(4)
    with pytest.raises(NakError) as err:
        with CoilDriver(RelayLink(host(dev), plan.channel_map)) as driver:
            sent = time.monotonic()
            driver.apply(plan.steps[0], duration=0.1)
            # a host stuck without keep-alives: the device switches off by itself, never before its period
            assert wait_all_off(dev, seconds=5.0) == (0, 0) and trip_codes(dev) == ["WDOG"]
            assert time.monotonic() - sent >= WATCHDOG_MS / 1000
            driver.apply(plan.steps[1], duration=0.1)
    assert err.value.code == "WDOG"
    assert one_line(err.value).startswith("device refused SET: NAK WDOG (the device's watchdog expired")
    assert dev.state() == (0, 0)


def test_plan_wider_than_the_device_is_refused_before_anything_is_switched(device_factory):
    dev = device_factory(channels=8)
    with pytest.raises(InputError, match="channel map uses relay channel 11, but device 'spherestep-emu' has 8"):
        play_relays(make_plan(4, coil_count=6), host(dev), rate=25.0)
    assert dev.frames == 1 and enables_driven(dev) == []


def test_ctrl_c_mid_plan_switches_everything_off(device_factory):
    dev = device_factory()
    serial = host(dev)
    # as a terminal delivers it: a test run as a background job of a non-interactive shell inherits SIGINT ignored
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.15, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            play_relays(make_plan(100), serial, rate=25.0)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    assert dev.state() == (0, 0) and dev.device.trips == []  # switched off by the host, not the watchdog
    assert serial.transcript.entries[-2][2].split(",")[1].startswith("OFF")


def test_handshake_without_a_device_times_out(device_factory):
    dev = PtyDevice(channels=8)  # a pseudo-terminal nobody answers on
    try:
        with pytest.raises(LinkError, match="to HELLO after 4 attempts"):
            Serial(dev.port, timeout=0.05, open_timeout=0.2).open()
    finally:
        dev.stop()


def test_bad_port_is_an_input_error():
    with pytest.raises(InputError) as err:
        Serial("/dev/spherestep-no-such-port").open()
    assert one_line(err.value) == ("port '/dev/spherestep-no-such-port' could not be opened (No such file or "
                                   "directory); give the serial device of the coil controller, such as "
                                   "/dev/ttyUSB0, /dev/ttyACM0 or COM3 (python -m serial.tools.list_ports lists "
                                   "them)")


def test_masks_sent_are_those_of_the_plan_convention(device_factory):
    dev = device_factory(channels=32)
    plan = make_plan(6, coil_count=16)
    serial = host(dev)
    play_relays(plan, serial, rate=50.0)
    sets = [line.split(",")[2:4] for _, kind, line in serial.transcript.entries if kind == "TX" and ",SET," in line]
    assert [(int(e, 16), int(p.split("*")[0], 16)) for e, p in sets] == \
        [coil_masks(s.coils, plan.channel_map) for s in plan.steps]


@pytest.mark.realtime
def test_wall_clock_promises(device_factory):
    """What the tests above leave to the wall clock, judged alone (marker ``realtime``): the 12-step plan at
    50 Hz takes 0.24 s (± 0.1 s), and each failure — persistent corruption, a silent device, a vanishing one, no
    device at the handshake — is reported within a second (attempts × the 0.1 s timeout, and the OFF)."""
    dev = device_factory()
    t = time.monotonic()
    play_relays(make_plan(12), host(dev), rate=50.0)
    assert time.monotonic() - t == pytest.approx(12 / 50, abs=0.1)
    for faults in (Faults(corrupt=frozenset(range(3, 1000))), Faults(silent_after=4), Faults(vanish_after=5)):
        dev = device_factory(faults)
        t = time.monotonic()
        with pytest.raises(LinkError):
            play_relays(make_plan(8), host(dev), rate=25.0)
        assert time.monotonic() - t < 1.0, faults
    nobody = PtyDevice(channels=8)
    try:
        t = time.monotonic()
        with pytest.raises(LinkError):
            Serial(nobody.port, timeout=0.05, open_timeout=0.2).open()
        assert time.monotonic() - t < 1.0
    finally:
        nobody.stop()


def test_one_server_refuses_what_it_cannot_run():
    """A device with bridges is served only with the emulated motor that they are (nothing else moves their
    currents); the truth is a motor's; the relay board is served by default, in a thread, its state read live."""
    class Bridges:
        def drive(self, duty, enabled):
            pass

    with pytest.raises(InputError, match="^motor must be the device's bridges"):
        PtyDevice(CurrentDevice(Bridges(), 3, 0))
    with PtyDevice(channels=8, watchdog_ms=300, name="board") as dev:
        assert dev.device.channels == 8 and dev.device.name == "board" and dev.motor is None
        with pytest.raises(InputError, match="^motor must be an emulated motor"):
            dev.truth()
        with CoilDriver(RelayLink(host(dev), default_channel_map(4))) as driver:
            assert (driver.info.name, driver.info.channels) == ("board", 8)
            driver.apply({0: 1, 1: -1}, duration=0.05)
            assert dev.state() == (0b11, 0b10 << 4)
    assert dev.state() == (0, 0) and dev.device.trips == []
