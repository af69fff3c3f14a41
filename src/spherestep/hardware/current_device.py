"""The coil controller in Python, the one device the pseudo-terminal serves: the counterpart of
``firmware/spherestep/drive.cpp`` (H-bridges, protocol 1 and 2) and, as :meth:`CurrentDevice.relay_board`, of
``firmware/spherestep/protocol.cpp`` (relays, protocol 1 only).

:class:`CurrentDevice` speaks protocol version 2 (:mod:`~spherestep.hardware.protocol2`) and, for relay
plans, version 1 (``SET`` masks become ± the nominal current, coil ``k`` on enable bit ``k`` and polarity bit
``N + k``). Each control period (:meth:`CurrentDevice.step`) it reads the coil currents, runs one PI current
loop per coil and writes the PWM duties to a :class:`Bridges` plant, and checks the limits of
:class:`~spherestep.hardware.limits.CurrentLimits`:

* over-current: a measured ``|i| > trip_ratio · max_current`` → trip ``OVER``;
* heating: the I²t model (:func:`~spherestep.hardware.limits.heating_step`) of any coil above 1 → ``HEAT``;
* a coil that does not follow its drive, by two rules with the tolerance ``tol(x) = 50 mA + 0.1 |x|`` and 20 ms
  (→ ``OPEN`` when ``|i| < 50 mA``: an open coil, a sense stuck at zero; else ``STUCK``: a bridge shorted to the
  supply, a frozen sense the PI loop winds its duty away from):

  - the coil's own law, only while the host's back-EMF estimate is fresh (the last ``DRIVE`` carried it and is
    under ``EMF_MS`` = 20 ms old: alone, an estimate cannot fill the window): each step the device predicts
    ``î ← a î + (1 − a)(d V − e) / R`` with ``a = e^{−R h / L}`` (the coil's L/R; ``î`` starts at the reading
    when driving starts or the estimate turns fresh); a reading off it by more than ``tol(î)`` for 20 ms trips, unless under 50 mA and within
    ``tol(i_set)`` of its setpoint (an idle coil doing its job, whatever an estimate that may be wrong predicts);
  - the held reading, always (whatever the back-EMF): the reading within ``tol(i_ref)`` of where it was, more
    than ``tol(i_set)`` off its setpoint, the loop's own duty ``d − e/V`` swept by ``SWEEP · tol(i_ref) · R / V``
    since, and the loop at its limit (duty or integral at ``±max_duty``): 20 ms of that trips. A healthy coil's
    current answers such a sweep unless the back-EMF moved with the duty; a back-EMF faster than the loop moves
    the reading once the loop is at its limit. A coil at its DC limit (full duty, ``i = (d V − e)/R``, steady
    for as long as the host asks more) never swept and runs on; a moving rotor under a silent host runs on;
    a sense frozen at the setpoint, where the loop never winds, is harmless until the demand moves;
* 8 damaged frames in a row during a session → ``CRCS``; no accepted command for the watchdog period → ``WDOG``.

A trip switches every bridge off (duty 0, drivers asleep, supply cut), ends the session and is answered to
every later command but ``HELLO``/``OFF``. ``OFF`` (and ``HELLO``) leave the bridges asleep too, session kept,
until the next ``DRIVE`` (or ``SET``): the loops and the monitors run only while driving. The PI loop cancels the coil's pole: ``duty = k_p ε + Σ k_i ε + e/V``,
``k_p = ω_c L / V``, ``k_i = k_p (R / L) h`` (anti-windup: the sum is clamped to ``±max_duty``), so the
closed loop is first order with bandwidth ``ω_c`` when ``L``, ``R`` are right; ``e/V`` is the back-EMF's
feed-forward (``e`` per coil from ``DRIVE``'s second block, V, kept until the next ``DRIVE``; 0 without it,
after ``SET``, ``OFF`` or a trip). Both implementations pass
``firmware/test/vectors2.txt`` with integer mA and µs, so they answer byte for byte alike.

The relay board (:meth:`CurrentDevice.relay_board`, no bridges) has ``relays`` channels (1–64) that ``SET``
drives as they are, polarity relays moved only while every enable relay is open (break before make; the last 4096
writes in :attr:`CurrentDevice.trace`); it speaks protocol 1 only (frames of at most
:data:`~spherestep.hardware.protocol.MAX_FRAME` bytes), has no current loop, no current limits and no ``CRCS``
trip, and passes ``firmware/test/vectors.txt`` as ``protocol.cpp`` does. Times are µs on both (the relay board's
``millis()`` × 1000).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Protocol

import numpy as np

from .. import checks
from ..electrics import from_centivolts, from_milliamperes, milliamperes
from ..errors import bad_value
from .limits import DRIVE, CurrentLimits
from .protocol import MAX_FRAME, MAX_MASK_DIGITS, FrameError, LineReader, decode, encode, format_mask, \
    parse_decimal, parse_hex
from .protocol2 import CAP_EMF, MAX_COILS, MAX_FRAME2, MAX_SENSORS, VERSION2, decode_block, format_state

_NAME_CHARS = frozenset("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789._-")
CRC_STORM = 8  # damaged frames in a row that trip a session
FOLLOW_MS = 20  # a reading off the coil's law (FOLLOW_A + FOLLOW_REL |î|) this long → trip
FOLLOW_A = 0.05  # A: the absolute part of the tolerance (sense noise and offset)
FOLLOW_REL = 0.1  # the relative part (the winding's R with temperature, the back-EMF)
EMF_MS = FOLLOW_MS  # a back-EMF estimate is fresh this long after its DRIVE (alone it cannot fill a window)
SWEEP = 2  # the held-reading rule: the loop's duty swept SWEEP tolerances' worth of current (× R/V) → watch


class Bridges(Protocol):
    """What the device drives and reads: one H-bridge with a current sense per coil, and magnetometers."""

    def measure(self) -> np.ndarray:
        """Coil currents now, integer mA ``(N,)`` (sampled with the magnetometers for a reply, and each step)."""

    def drive(self, duty: np.ndarray, enabled: bool) -> None:
        """Apply duties ``(N,)`` in ``[−1, 1]``; ``enabled`` False puts every bridge to sleep and cuts the supply."""

    def sense(self) -> tuple[np.ndarray, int]:
        """Latest magnetometer counts ``(S, 3)`` (integers) and the mask of stale sensors."""


class CurrentDevice:
    """The device state machine for ``coils`` H-bridges and ``sensors`` magnetometers, or (``bridges`` None,
    ``coils`` and ``sensors`` 0, ``relays`` given: see :meth:`relay_board`) a relay board; see the module.

    ``watchdog_ms`` (1–65535), control ``period_us``, ``limits``, ``supply`` V, coil ``inductance`` H and
    ``resistance`` (from ``limits``) for the PI gains, closed-loop ``bandwidth`` rad/s, ``nominal_ma`` the
    current of a relay-mode coil, ``field_lsb_nt`` the magnetometers' nT per count (TMAG5273A2 at ±266 mT).
    ``off_us`` is the time the coils last went from driven to all off (a trip, ``OFF`` or ``HELLO``). ``trips`` lists ``(code, coil or -1, time µs)``.
    ``enable``/``polarity`` are the protocol-1 masks last set (the relays driven, on a relay board), ``channels``
    the protocol-1 channel count (``relays``, or ``2 coils``: coil ``k`` on enable bit ``k``, polarity bit
    ``coils + k``), ``versions`` the protocol versions spoken.
    """

    def __init__(self, bridges: Bridges | None, coils: int, sensors: int, *, relays: int | None = None,
                 watchdog_ms: int = 100, period_us: int = 1000, limits: CurrentLimits | None = None,
                 supply: float = DRIVE.supply_voltage, inductance: float = DRIVE.inductance,
                 bandwidth: float = 2 * math.pi * 100, nominal_ma: int = round(milliamperes(DRIVE.nominal_current)),
                 field_lsb_nt: int = 8118, name: str = "spherestep-t41"):
        if relays is None:
            if bridges is None:
                raise bad_value("bridges", "the coils' bridges (or relays=channels for a relay board)", bridges)
            coils = checks.count(coils, "coils", 1, MAX_COILS, expected=f"an integer 1..{MAX_COILS}")
            sensors = checks.count(sensors, "sensors", 0, MAX_SENSORS, expected=f"an integer 0..{MAX_SENSORS}")
            self.channels, self.versions, max_frame = 2 * coils, (1, VERSION2), MAX_FRAME2
        else:
            relays = checks.count(relays, "channels", 1, 4 * MAX_MASK_DIGITS, expected="an integer 1..64")
            if bridges is not None or coils != 0 or sensors != 0:
                raise bad_value("relays", "given alone: a relay board has no bridges, coils or sensors", relays)
            self.channels, self.versions, max_frame = relays, (1,), MAX_FRAME
        watchdog_ms = checks.count(watchdog_ms, "watchdog_ms", 1, 65535, expected="an integer 1..65535 (milliseconds)")
        period_us = checks.count(period_us, "period_us", 50, 100000, expected="an integer 50..100000 (microseconds)")
        if not 1 <= len(name) <= 16 or not set(name) <= _NAME_CHARS:
            raise bad_value("name", "1-16 characters from A-Z a-z 0-9 . _ -", name)
        self.bridges, self.coils, self.sensors = bridges, coils, sensors
        self.watchdog_ms, self.period_us, self.name = watchdog_ms, period_us, name
        self.limits = limits if limits is not None else CurrentLimits()
        lim = self.limits
        self.nominal_ma = int(nominal_ma)
        self.field_lsb_nt = int(field_lsb_nt)
        if not 0 < self.nominal_ma <= milliamperes(lim.max_current):
            raise bad_value("nominal_ma", "a current in mA within the current limit", nominal_ma)
        h = period_us * 1e-6
        self.kp = bandwidth * inductance / supply
        self.ki = self.kp * lim.resistance / inductance * h
        self.decay = math.exp(-h / lim.thermal_time)
        self.coil_decay = math.exp(-h * lim.resistance / inductance)  # a = e^{−R h / L}
        self.follow_steps = max(1, round(FOLLOW_MS * 1000 / period_us))
        self.setpoint = np.zeros(coils)  # A
        self.emf = np.zeros(coils)  # V: each coil's back-EMF as the host last estimated it
        self.integral = np.zeros(coils)
        self.duty = np.zeros(coils)
        self.heat = np.zeros(coils)
        self.expected = np.zeros(coils)  # A: î, the current the coil's law predicts from the duties driven
        self._fresh = True  # the next driving step starts î at the reading (the bridges were asleep)
        self._follow = np.zeros(coils, dtype=np.int64)
        self.emf_us: int | None = None  # µs: when the last back-EMF estimate arrived (None: none this drive)
        self._ref = np.zeros(coils)  # A: the reading the held-reading rule compares with
        self._low = np.zeros(coils)  # the loop's duty d − e/V, lowest and highest since the reading was _ref
        self._high = np.zeros(coils)
        self._held = np.zeros(coils, dtype=np.int64)  # steps held since the sweep passed SWEEP tolerances
        self.supply, self.inductance = float(supply), float(inductance)
        self.version = 0  # 0: no session, 1: relay session, 2: current session
        self.enable = self.polarity = 0  # relay-mode masks
        self.trace: deque[tuple[str, int]] = deque(maxlen=4096)
        self.tripped: str | None = None
        self.trips: list[tuple[str, int, int]] = []
        self.bad_frames = 0
        self.last_valid_us = 0
        self.max_frame = max_frame
        self._reader = LineReader(max_frame)
        self._all_off()

    @classmethod
    def relay_board(cls, channels: int = 32, watchdog_ms: int = 500, name: str = "spherestep-emu") -> CurrentDevice:
        """The relay board of ``firmware/spherestep/protocol.cpp``: ``channels`` relays (1–64), watchdog
        ``watchdog_ms`` (1–65535), ``name`` in the handshake; protocol 1 only (see the module)."""
        return cls(None, 0, 0, relays=channels, watchdog_ms=watchdog_ms, name=name)

    # -- outputs and trips --------------------------------------------------------------------------------------
    @property
    def session(self) -> bool:
        return self.version != 0

    def _all_off(self, now_us: int = 0) -> None:
        if not hasattr(self, "off_us") or self.enable or np.any(self.setpoint != 0) or np.any(self.duty != 0):
            self.off_us = now_us  # the moment the coils went from driven to off
        self.driving = False
        self.setpoint[:] = 0.0
        self.emf[:] = 0.0
        self._feed = np.zeros(len(self.emf))
        self._setpoint_tol = np.full(len(self.emf), FOLLOW_A)
        self.emf_us = None
        self.integral[:] = 0.0
        self.duty[:] = 0.0
        self._follow[:] = 0
        self._held[:] = 0
        self._fresh = True
        self._set_enable(0)
        self._set_polarity(0)
        if self.bridges is not None:
            self.bridges.drive(self.duty.copy(), False)

    def _set_enable(self, mask: int) -> None:
        self.enable = mask
        self.trace.append(("enable", mask))

    def _set_polarity(self, mask: int) -> None:
        self.polarity = mask
        self.trace.append(("polarity", mask))

    def _apply_masks(self, enable: int, polarity: int) -> None:
        """Drive the masks, break before make: polarity relays move only while every enable relay is open."""
        if polarity != self.polarity:
            if self.enable:
                self._set_enable(0)
            self._set_polarity(polarity)
        if enable != self.enable:
            self._set_enable(enable)

    def _trip(self, code: str, coil: int, now_us: int) -> None:
        self._all_off(now_us)
        self.version = 0
        self.tripped = code
        self.trips.append((code, coil, now_us))

    def tick(self, now_us: int) -> None:
        """Watchdog: a session with no accepted command for ``watchdog_ms`` → all off, trip ``WDOG``."""
        if self.session and ((now_us - self.last_valid_us) & 0xFFFFFFFF) >= self.watchdog_ms * 1000:
            self._trip("WDOG", -1, now_us)

    def step(self, now_us: int) -> None:
        """One control period at ``now_us``: read currents, update heat, run the PI loops, check, drive (a relay
        board: the watchdog only)."""
        self.tick(now_us)
        if self.bridges is None:
            return
        lim = self.limits
        ma = np.asarray(self.bridges.measure(), dtype=np.int64)
        i = from_milliamperes(ma)
        self.heat = self.decay * self.heat + (1.0 - self.decay) * (i / lim.continuous_current) ** 2
        if not self.session or not self.driving:
            return
        over = np.flatnonzero(np.abs(ma) > lim.trip_ratio * milliamperes(lim.max_current))
        if len(over):
            return self._trip("OVER", int(over[0]), now_us)
        hot = np.flatnonzero(self.heat > 1.0)
        if len(hot):
            return self._trip("HEAT", int(hot[0]), now_us)
        told = self.emf_us is not None and ((now_us - self.emf_us) & 0xFFFFFFFF) < EMF_MS * 1000
        if self._fresh or not told:  # the law starts again at the reading once a fresh estimate arrives
            self.expected = i.copy()
        else:  # the duties driven over the last period less the back-EMF, through the coil's L/R
            a = self.coil_decay
            self.expected = a * self.expected + (1.0 - a) * (self.duty * self.supply - self.emf) / lim.resistance
        e = self.setpoint - i
        dmax = lim.max_duty
        self.integral = np.clip(self.integral + self.ki * e, -dmax, dmax)
        self.duty = np.clip(self.kp * e + self.integral + self._feed, -dmax, dmax)
        off = np.abs(e) > self._setpoint_tol  # the reading off its setpoint: the loop is not doing its job
        if told:  # an idle coil (under 50 mA) at its setpoint is never judged by an estimate that may be wrong
            off_law = (off | (np.abs(ma) >= 50)) & \
                (np.abs(i - self.expected) > FOLLOW_A + FOLLOW_REL * np.abs(self.expected))
            self._follow = np.where(off_law, self._follow + 1, 0)
        else:
            self._follow[:] = 0
        # the held reading: off its setpoint, unmoved while the loop's own duty swept (whatever the back-EMF)
        loop = self.duty - self._feed
        held = None
        if not self._fresh and off.any():
            band = FOLLOW_A + FOLLOW_REL * np.abs(self._ref)
            held = off & (np.abs(i - self._ref) <= band)
        self._fresh = False
        if held is None or not held.any():  # every coil follows or sits at its setpoint: the rule starts again
            self._ref, self._low, self._high = i, loop, loop
            self._held[:] = 0
        else:
            self._low = np.where(held, np.minimum(self._low, loop), loop)
            self._high = np.where(held, np.maximum(self._high, loop), loop)
            swept = held & ((np.abs(self.duty) >= dmax) | (np.abs(self.integral) >= dmax)) & \
                ((self._high - self._low) * self.supply > SWEEP * band * lim.resistance)
            self._held = np.where(swept, self._held + 1, 0)
            self._ref = np.where(held, self._ref, i)
        if (told and self._follow.max() >= self.follow_steps) or self._held.max() >= self.follow_steps:
            k = int(np.flatnonzero((self._follow >= self.follow_steps) | (self._held >= self.follow_steps))[0])
            return self._trip("OPEN" if abs(ma[k]) < 50 else "STUCK", k, now_us)
        self.bridges.drive(self.duty.copy(), True)

    # -- frames -------------------------------------------------------------------------------------------------
    def receive(self, data: bytes, now_us: int) -> bytes:
        """Consume received bytes at ``now_us``; return the replies to send back."""
        return b"".join(self._process(body, now_us) for body in self._reader.feed(data))

    def _state(self, now_us: int) -> tuple[str, ...]:
        counts, stale = self.bridges.sense()
        return format_state(now_us, stale, self.bridges.measure(), np.asarray(counts).reshape(-1))

    def _damaged(self, code: str, now_us: int) -> bytes:
        self.bad_frames += 1
        if self.session and self.bridges is not None and self.bad_frames >= CRC_STORM:
            self._trip("CRCS", -1, now_us)
        return encode(None, "NAK", code)

    def _process(self, body: bytes, now_us: int) -> bytes:
        self.tick(now_us)
        try:
            frame = decode(body, self.max_frame)
        except FrameError as exc:
            return self._damaged(exc.code, now_us)
        if frame.seq is None:
            return self._damaged("FRAME", now_us)
        self.bad_frames = 0
        seq, verb, args = frame.seq, frame.verb, frame.args

        def nak(code: str) -> bytes:
            return encode(seq, "NAK", code)

        def accepted(*data: object) -> bytes:
            if self.session:
                self.last_valid_us = now_us
            return encode(seq, "ACK", verb, *data, max_frame=self.max_frame)

        def refused() -> bytes:
            return nak(self.tripped or "SESSION")

        if verb == "HELLO":
            version = parse_decimal(args[0], 3) if len(args) == 1 else None
            if version is None:
                return nak("ARGS")
            if version not in self.versions or (version == 1 and self.channels > 4 * MAX_MASK_DIGITS):
                return nak("VERSION")
            if np.any(self.heat > 0.9):
                return nak("HEAT")
            self._all_off(now_us)
            self.version, self.tripped = version, None
            if version == 1:
                return accepted(1, self.channels, self.watchdog_ms, self.name)
            lim = self.limits
            return accepted(VERSION2, self.coils, self.sensors, self.watchdog_ms, self.period_us,
                            round(milliamperes(lim.max_current)), round(lim.max_power), self.field_lsb_nt,
                            round(self.supply * 1000), round(lim.resistance * 1000), round(self.inductance * 1e6),
                            f"{CAP_EMF:X}", self.name)
        if verb == "OFF":
            if args:
                return nak("ARGS")
            self._all_off(now_us)
            return accepted() if self.version == VERSION2 else accepted(0, 0)
        if verb == "PING":
            if args:
                return nak("ARGS")
            if not self.session:
                return refused()
            return accepted() if self.version == VERSION2 else accepted(format_mask(self.enable),
                                                                       format_mask(self.polarity))
        if verb == "SET":
            masks = [parse_hex(a, 1, MAX_MASK_DIGITS) for a in args] if len(args) == 2 else [None]
            if None in masks:
                return nak("ARGS")
            if self.version != 1:
                return nak("VERB") if self.version == VERSION2 else refused()
            enable, polarity = masks
            if (enable | polarity) >> self.channels:
                return nak("RANGE")
            if self.bridges is not None:
                n = self.coils
                on = np.array([(enable >> k) & 1 for k in range(n)], dtype=float)
                sign = np.array([1.0 - 2.0 * ((polarity >> (n + k)) & 1) for k in range(n)])
                if not self._set(on * sign * self.nominal_ma):
                    return nak("LIMIT")
            self._apply_masks(enable, polarity)
            return accepted(format_mask(self.enable), format_mask(self.polarity))
        if verb in ("DRIVE", "READ") and VERSION2 in self.versions:
            block = emf = None
            if verb == "DRIVE" and len(args) in (1, 2):
                block = decode_block(args[0], self.coils)
                emf = decode_block(args[1], self.coils) if len(args) == 2 else np.zeros(self.coils, dtype=np.int64)
            if (verb == "DRIVE" and (block is None or emf is None)) or (verb == "READ" and args):
                return nak("ARGS")
            if self.version != VERSION2:
                return nak("VERB") if self.version == 1 else refused()
            if block is not None and not self._set(block, emf):
                return nak("LIMIT")
            if block is not None:
                self.emf_us = now_us if len(args) == 2 else None
            return accepted(*self._state(now_us))
        return nak("VERB")

    def _set(self, ma, emf_cv=None) -> bool:
        """Take setpoints in mA (and the back-EMF in 10 mV units, 0 if None) if within the current and power
        limits; False (nothing changed) otherwise."""
        lim = self.limits
        amps = from_milliamperes(ma).tolist()  # each float(m) / 1000, as the firmware's
        limit = milliamperes(lim.max_current)
        if any(abs(m) > limit for m in ma):
            return False
        if lim.resistance * sum(a * a for a in amps) > lim.max_power:  # summed in order, as the firmware does
            return False
        self.setpoint = np.array(amps)
        self.emf = from_centivolts(np.zeros(self.coils) if emf_cv is None else emf_cv)  # each float(c) / 100
        self._feed = self.emf / self.supply  # the duty fed forward
        self._setpoint_tol = FOLLOW_A + FOLLOW_REL * np.abs(self.setpoint)  # off the setpoint by more: "off"
        self.driving = True
        return True
