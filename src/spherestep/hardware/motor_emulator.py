"""The pseudo-terminal device grows a motor: coil electrics, the rotor and the magnetometers behind
:class:`~spherestep.hardware.current_device.CurrentDevice`, served on a real pseudo-terminal.

:class:`EmulatedMotor` is the device's :class:`~spherestep.hardware.current_device.Bridges`:

* Coils: ``L di/dt = d V − R i − e`` per coil (``R``, ``L``, ``V`` of a :class:`spherestep.electrics.DriveLimits`),
  solved exactly over each control period with the duty ``d`` and the back-EMF ``e`` held (``i ← a i + (1 − a)
  (d V − e)/R``, ``a = e^{−R h / L}``: :func:`spherestep.electrics.rl_step`, the simulation's coil model too).
  ``e_k = K_k(R)·ω / I_n`` (:meth:`~spherestep.electrics.DriveLimits.back_emf`) of the rotor's true ``ω`` and
  the plant's ``K`` at the last rotor step (so ``Σ e_k i_k`` is the power the coils give the rotor). Asleep
  (``enabled`` False) the bridges' diodes return the current to the supply, ``L di/dt = −V sign(i) − R i − e``,
  until it is zero (a back-EMF above the supply, which would drive a current through the diodes, is not
  modelled: a coil at rest stays at zero). The sense reads
  ``round(1000 (i + noise))`` mA, ``current_noise`` A RMS.
* Rotor: a :class:`spherestep.dynamics.Rotor` (passed in) under the torque model's ``b(R) + K(R) ī`` (currents per unit of
  the nominal current; ``b`` the bias, zero for the air-core magnets), one step per ``torque_refresh`` s (2 ms: the
  servo's period at 500 Hz; at 20 ms the rotor's acceleration answered the coils up to 20 ms late on the
  pseudo-terminal, where nothing else brings the rotor up to date, and the servo on iron tracked within ~10°
  there, while in lockstep, whose truth is read every cycle, it did not),
  with ``K`` and ``b`` at the orientation predicted for the middle of the step (``torque_cache``, passed in: the
  control room's :class:`~spherestep.control.ModelCache`, the servo law's cache; the drive room builds it exact,
  ``reuse=0``, re-evaluated every step: reused within ``K_REUSE`` = 0.11° the iron detent's 230 N·m/rad made the
  emulated torque a saw-tooth of up to 0.46 N·m along a move, half the residual of the rotor's identification)
  and ``ī`` the coils' mean current over it; in between, the sensors see
  :meth:`EmulatedMotor.orientation`, the last step continued to second order.
* Magnetometers: ``field`` (passed in): the sensing room's :func:`~spherestep.sensing.field_model` of the design, the one the
  simulated Hall sensor reads and the session's estimator fits: the rotor's field table, on an iron design the
  cores it magnetises, and the coils at the measured currents (on iron each winding with its own core), read in
  each sensor's own axes, through each chip's own offset and gain (``chips``: the drive room's
  :class:`~spherestep.sensing.SensorErrors`, whose array ``sensors`` and ``field`` are then the built, turned one),
  with the part's noise, quantised to its LSB and clipped to ±32767 counts.

:class:`MotorFaults` injects the faults the servo must survive: an open coil, a coil stuck at full current (a
shorted bridge, which only the supply cut stops), a frozen current reading, a magnetometer that stops (stale)
or returns garbage, link loss (the device vanishes, or stops reading), and a starved device (its answers late).
:class:`MotorPty` is the one pseudo-terminal server (:class:`~spherestep.hardware.pty_device.PtyDevice`) built for
a motor: a host opens :attr:`MotorPty.port` like a USB serial device; :class:`LockstepLink` talks to the same
device in this process on a simulated clock.

The room assembles no application: the rotor, the field model and the torque cache are built by the drive room
(:func:`spherestep.drive.connect.emulated_motor`) and passed in, so this module imports neither dynamics, control
nor sensing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import so3
from ..electrics import DriveLimits, milliamperes, rl_step
from .backend import LinkError
from .current_device import CurrentDevice
from .drive_link import DeviceTrip, device_info, drive_blocks
from .limits import CurrentLimits
from .protocol import decode, encode
from .protocol2 import FULL_SCALE, MAX_FRAME2, TRIP_CODES, VERSION2, parse_state
from .pty_device import Faults, PtyDevice, Truth
from .serialport import NakError


@dataclass(frozen=True)
class MotorFaults:
    """Faults by emulated time (s since the device started): each a ``(index, time)`` pair or None; a coil index
    of −1 is the coil carrying the most current when the fault strikes.

    ``open_coil``: the coil's circuit opens (no current). ``stuck_coil``: its bridge shorts to the supply (full
    current whatever the duty, until the supply is cut). ``frozen_reading``: its current sense repeats the last
    value. ``sensor_stops``: the magnetometer stops answering (repeats its last sample, flagged stale).
    ``sensor_garbage``: it returns random counts (not flagged: the host must notice). ``vanish_at`` s: the
    device closes its end of the line; ``deaf_at`` s: it stops reading the line (the watchdog still runs).
    ``slow_answers`` ``(delay, from, until)`` s: between those times every answer leaves ``delay`` s late (a
    starved device or link: the host's loop misses its deadlines; on :class:`LockstepLink` the emulated time
    runs on by ``delay`` before the answer).
    """

    open_coil: tuple[int, float] | None = None
    stuck_coil: tuple[int, float] | None = None
    frozen_reading: tuple[int, float] | None = None
    sensor_stops: tuple[int, float] | None = None
    sensor_garbage: tuple[int, float] | None = None
    vanish_at: float | None = None
    deaf_at: float | None = None
    slow_answers: tuple[float, float, float] | None = None

    def answer_delay(self, t: float) -> float:
        """How late an answer at emulated time ``t`` leaves (s): ``slow_answers``' delay within its window."""
        if self.slow_answers is None:
            return 0.0
        delay, since, until = self.slow_answers
        return float(delay) if since <= t < until else 0.0


DEVICE_PERIOD = 2.5e-4  # s: the emulated motor's device period (its current loop at 4 kHz)


class EmulatedMotor:
    """Coils, rotor and magnetometers of ``design`` under ``model`` (a torque model with ``torque_matrix``);
    see the module. ``sensors`` a :class:`~spherestep.sensing.SensorArray`; ``rotor`` (``step``, ``inertia``,
    ``damping``), ``field`` (``field(R, c) -> (S, 3)`` T at the sensors, currents per unit) and ``torque_cache``
    (``at(R) -> (K, b)``) the parts the drive room builds (:func:`spherestep.drive.connect.emulated_motor`);
    ``drive`` the :class:`~spherestep.electrics.DriveLimits`; ``R0`` the start orientation; ``chips`` (``local
    (S, 3) -> readings``, T) each chip's own error on the field in its axes before the noise (the drive room passes
    :meth:`spherestep.sensing.SensorErrors.read`; ``None``: exact)."""

    def __init__(self, design, model, sensors, *, rotor, field, torque_cache, drive=None,
                 current_noise: float = 0.002, R0=None, faults: MotorFaults | None = None, period: float = DEVICE_PERIOD,
                 torque_refresh: float = 2e-3, seed: int = 0, chips=None):
        self.design, self.model, self.sensors = design, model, sensors
        self.chips = chips
        self.rotor = rotor
        self.drive_limits = drive if drive is not None else DriveLimits()
        self.current_noise = float(current_noise)
        self.faults = faults if faults is not None else MotorFaults()
        self.period, self.torque_refresh = float(period), float(torque_refresh)
        self.rng = np.random.default_rng(seed)
        self.field = field  # rotor (+ the cores on iron) and the coils
        n = len(design.stator)
        self.t = 0.0
        self.R = np.eye(3) if R0 is None else so3.as_rotations(R0).reshape(3, 3).copy()
        self.w = np.zeros(3)
        self.i = np.zeros(n)
        self.duty = np.zeros(n)
        self.enabled = False
        self._rotor_t = 0.0
        self._charge = np.zeros(n)
        self.emf = np.zeros(n)  # V: each coil's back-EMF at the last rotor step
        self.alpha = np.zeros(3)
        self.torque_cache = torque_cache
        self._struck: dict[str, int] = {}
        self._last_ma = np.zeros(n, dtype=np.int64)
        self._last_counts = np.zeros((len(sensors), 3), dtype=np.int64)

    def _fault(self, name: str) -> int | None:
        """The index a fault strikes now, or None (not injected, or not yet)."""
        fault = getattr(self.faults, name)
        if fault is None or self.t < fault[1]:
            return None
        if fault[0] >= 0:
            return fault[0]
        if name not in self._struck:
            self._struck[name] = int(np.argmax(np.abs(self.i)))
        return self._struck[name]

    # -- the device's view (Bridges) --------------------------------------------------------------------------------
    def measure(self) -> np.ndarray:
        noise = self.current_noise * self.rng.standard_normal(len(self.i))
        ma = np.rint(milliamperes(self.i + noise)).astype(np.int64)
        frozen = self._fault("frozen_reading")
        if frozen is not None:
            ma[frozen] = self._last_ma[frozen]
        self._last_ma = ma
        return ma

    def drive(self, duty: np.ndarray, enabled: bool) -> None:
        self.duty = np.asarray(duty, dtype=float).copy()
        self.enabled = bool(enabled)

    def sense(self) -> tuple[np.ndarray, int]:
        part = self.sensors.part
        B = self.field.field(self.orientation(), self.drive_limits.per_unit(self.i))  # (S, 3), fixed frame
        local = np.einsum("sab,sa->sb", self.sensors.axes, B)  # A_sᵀ B
        if self.chips is not None:
            local = self.chips(local)
        local = local + part.noise_T * self.rng.standard_normal(local.shape)
        counts = np.clip(np.rint(local / part.lsb_T), -FULL_SCALE, FULL_SCALE).astype(np.int64)
        stale = 0
        stopped = self._fault("sensor_stops")
        if stopped is not None:
            counts[stopped] = self._last_counts[stopped]
            stale |= 1 << stopped
        garbage = self._fault("sensor_garbage")
        if garbage is not None:
            counts[garbage] = self.rng.integers(-FULL_SCALE, FULL_SCALE + 1, 3)
        self._last_counts = counts
        return counts, stale

    def warm_up(self) -> None:
        """Make the first (slow) calls now: the field tables, the torque cache, compiled code, the rotor synced."""
        self.sense()
        self.torque_cache.at(self.R)
        self.sync()

    # -- physics ----------------------------------------------------------------------------------------------------
    def advance_to(self, t: float) -> None:
        """Integrate the coils from :attr:`t` to ``t`` in steps of at most one control period; the rotor follows
        in chunks of ``torque_refresh`` (and is brought up to date by :meth:`sync`)."""
        while self.t < t - 1e-12:
            self._advance_coils(min(self.period, t - self.t))
            if self.t - self._rotor_t >= self.torque_refresh - 1e-12:
                self.sync()

    def _advance_coils(self, h: float) -> None:
        e = self.drive_limits
        i0 = self.i
        stuck = self._fault("stuck_coil")
        if self.enabled:
            v = self.duty * e.supply_voltage
            if stuck is not None:
                v[stuck] = e.supply_voltage
            i1 = rl_step(i0, v, self.emf, e.resistance, e.inductance, h)[0]
        else:
            i1 = rl_step(i0, -np.sign(i0) * e.supply_voltage, self.emf, e.resistance, e.inductance, h)[0]
            i1 = np.where(np.sign(i1) != np.sign(i0), 0.0, i1)  # the diodes stop at zero
        opened = self._fault("open_coil")
        if opened is not None:
            i1[opened] = 0.0
        self._charge += 0.5 * h * (i0 + i1)  # ∫ i dt, trapezoidal
        self.i = i1
        self.t += h

    def sync(self) -> None:
        """Bring the rotor up to the coils' time: one :meth:`Rotor.step` under ``b(R_mid) + K(R_mid) σ(ī)`` (``ī``
        the mean current since the last sync, ``σ`` the plant's ``winding_currents``: ``ī`` itself unless its
        windings saturate; ``R_mid`` the orientation predicted for the middle of the interval; ``K`` and ``b``
        from :attr:`torque_cache`)."""
        h = self.t - self._rotor_t
        if h <= 0:
            return
        mid = so3.exp(0.5 * h * self.w) @ self.R
        K, b = self.torque_cache.at(mid, slope=True)  # first order about the anchor (module docstring)
        tau = (b + K @ self.model.winding_currents(self.drive_limits.per_unit(self._charge / h)))[None]
        R, w, _ = self.rotor.step(self.R[None], self.w[None], lambda _R: tau, h, tau)
        self.alpha = (w[0] - self.w) / h
        self.R, self.w = R[0], w[0]
        self.emf = self.drive_limits.back_emf(self.w @ K)  # e_k = K_k·ω / I_n for the coils' next steps
        self._charge = np.zeros_like(self.i)
        self._rotor_t = self.t

    def orientation(self) -> np.ndarray:
        """The rotor now, between two rotor steps: ``exp(Δt ω + ½ Δt² α) R`` from the last step."""
        dt = self.t - self._rotor_t
        return so3.exp(dt * self.w + 0.5 * dt * dt * self.alpha) @ self.R


# The device's PI current loop, ω_c h: a coil current must follow its setpoint well inside one servo period. The
# iron coil's own L/R is 1.9 ms (525 rad/s); the former setting (a 2 ms device period, ω_c = 0.25/h = 125 rad/s)
# made the drive four times slower than the bare coil, ~8 ms behind every command, and the servo at 500 Hz could not
# settle against the detent (lockstep 360° turn: max tracking 1.9°, final 0.38°). A 4 kHz loop with ω_c = 2000 rad/s
# (a board's current loop runs at 10–20 kHz): 0.45° and 0.005°.
CURRENT_BANDWIDTH = 0.5


def matching_device_options(motor: EmulatedMotor) -> dict:
    """The :class:`CurrentDevice` settings that match ``motor``: its drive's limits, supply, inductance, control
    period, current-loop bandwidth ``CURRENT_BANDWIDTH`` × the period's rate (rad/s: 2000 at the default 4 kHz),
    relay current and magnetometer LSB."""
    e = motor.drive_limits
    return dict(limits=CurrentLimits.from_drive(e), supply=e.supply_voltage, inductance=e.inductance,
                period_us=round(motor.period * 1e6), bandwidth=CURRENT_BANDWIDTH / motor.period,
                nominal_ma=round(milliamperes(e.nominal_current)), field_lsb_nt=round(motor.sensors.part.lsb_T * 1e9))


class LockstepLink:
    """A :class:`~spherestep.hardware.Link` like :class:`~spherestep.hardware.DriveLink`, without a line or a wall clock: frames go as bytes
    to a :class:`CurrentDevice` on an :class:`EmulatedMotor` in this process, and :meth:`sleep` advances the
    motor and runs the device's control steps. Pass ``clock=link.clock, sleep=link.sleep`` to
    :func:`~spherestep.hardware.run_servo`: the loop then keeps its rate exactly, whatever the machine's load,
    so the control design is judged apart from the host's speed. ``device_options`` as for :class:`MotorPty`."""

    def __init__(self, motor: EmulatedMotor, **device_options):
        self.motor = motor
        self.device = CurrentDevice(motor, len(motor.design.stator), len(motor.sensors),
                                    **{**matching_device_options(motor), **device_options})
        self._seq = 0
        self.info = device_info(self._transact("HELLO", VERSION2), "lockstep")

    def __enter__(self) -> LockstepLink:
        return self

    def __exit__(self, *exc) -> None:
        """``OFF`` (a :class:`~spherestep.hardware.Link`: every coil off on leaving) if the device answers."""
        try:
            self.off()
        except LinkError:
            pass

    def clock(self) -> float:
        return self.motor.t

    def truth(self) -> Truth:
        return truth_of(self.motor, self.device)

    def sleep(self, seconds: float) -> None:
        """Advance emulated time by ``seconds``: coils every period with the device's control step, rotor."""
        m, dev = self.motor, self.device
        end = m.t + seconds
        while m.t + m.period <= end + 1e-12:
            m.advance_to(m.t + m.period)
            dev.step(round(m.t * 1e6))
        m.advance_to(end)

    def _transact(self, verb: str, *args):
        self._seq = (self._seq + 1) & 0xFF
        reply = self.device.receive(encode(self._seq, verb, *args, max_frame=MAX_FRAME2), round(self.motor.t * 1e6))
        delay = self.motor.faults.answer_delay(self.motor.t)
        if delay > 0:  # a starved device: the answer arrives late, emulated time runs on meanwhile
            self.sleep(delay)
        frame = decode(reply[1:-1], MAX_FRAME2)
        if frame.verb == "NAK":
            code = frame.args[0]
            raise (DeviceTrip if code in TRIP_CODES else NakError)(f"device refused {verb}: NAK {code}", code)
        return frame

    def drive(self, currents, *, emf=None, within: float | None = None):
        """As :meth:`DriveLink.drive`; ``within`` does not apply (the answer comes at once on the simulated clock)."""
        return self._state(self._transact("DRIVE", *drive_blocks(self.info, currents, emf)))

    def read(self):
        return self._state(self._transact("READ"))

    def off(self) -> None:
        self._transact("OFF")

    def _state(self, ack):
        try:
            return parse_state(ack.args[1:], self.info.coils, self.info.sensors, self.info.field_lsb)
        except ValueError as exc:
            raise LinkError(f"malformed state ({exc})") from None


def truth_of(motor: EmulatedMotor, device: CurrentDevice, slip: float = 0.0) -> Truth:
    """The :class:`Truth` of a motor and its device in this process (the rotor brought up to date)."""
    motor.sync()
    trips = tuple((code, coil, us * 1e-6) for code, coil, us in device.trips)
    return Truth(motor.R.copy(), motor.w.copy(), motor.i.copy(), motor.t, motor.enabled, device.off_us * 1e-6, slip,
                 trips)


class MotorPty(PtyDevice):
    """The pseudo-terminal server (:class:`~spherestep.hardware.pty_device.PtyDevice`) for ``motor``: a
    :class:`CurrentDevice` with :func:`matching_device_options` (overridden by ``device_options``:
    ``watchdog_ms``, ``limits``...) driving it, in a forked process (``realtime``: see ``PtyDevice``), with the
    line ``faults``; :meth:`~PtyDevice.truth` the :class:`~spherestep.hardware.pty_device.Truth` it publishes."""

    def __init__(self, motor: EmulatedMotor, *, realtime: bool = True, faults: Faults | None = None,
                 **device_options):
        device = CurrentDevice(motor, len(motor.design.stator), len(motor.sensors),
                               **{**matching_device_options(motor), **device_options})
        super().__init__(device, faults, motor=motor, realtime=realtime)
