"""The one servo law: observer → feedback → the model's ``K(R)`` and bias → warm-started allocation.

Simulation (:func:`spherestep.dynamics.simulate_servo`) and hardware (:func:`spherestep.hardware.run_servo`) call
:meth:`ServoLaw.step` once per control period; nothing of the law is written anywhere else.

Units. The law works in currents *per unit of the coil's nominal current* ``c`` (the torque models' unit, see
:mod:`.limits`); :meth:`ServoLaw.amperes` is the one conversion to the amperes ``i = I_n c`` of the drive, with
``I_n`` = ``limits.nominal_current``. Torques are N·m in the fixed frame, angles radians, times seconds.

One period, at loop time ``t`` (s):

1. *predict*: the observer (:class:`~spherestep.control.controller.Observer`) advances from its last time to ``t``
   under the torque the previous command promised, ``τ_p − b_d ω̂`` (``b_d`` the rotor's known damping);
2. *correct*: a measurement ``R_m`` taken at ``t_m`` (default ``t``; a sensor of latency ``δ`` delivers
   ``t_m = t − δ``) corrects it against the estimate of that time; the first measurement starts it;
3. *feedback*: :class:`~spherestep.control.controller.GeometricPD` gives the torque ``τ*`` from ``(R̂, ω̂)`` and
   the trajectory's ``(R_d, ω_d, α_d)(t)``; with a ``lead`` (hardware: the command takes effect a period after
   the reading and acts over the next, so ``lead`` = 1.5 periods, the middle of that period) both at ``t + lead``:
   the state carried on under the torque already commanded (:meth:`ServoLaw._ahead`), the target taken there,
   and steps 4–5 at that state;
4. *model*: ``K(R̂)`` (3 × N, N·m per unit current) and the bias ``b(R̂) = τ(R̂, 0)`` from :class:`ModelCache`,
   re-evaluated only when ``R̂`` has turned more than ``K_REUSE`` since they were last evaluated (the bias only
   for a model that has one); for a model with a bias, while the trajectory turns slower than ``SLOPE_SPEED``,
   carried from there to ``R̂`` to first order (:meth:`ModelCache.at`'s ``slope``): held frozen, the detent's
   stiffness — up to ~230 N·m/rad on the iron prototype, above the loop's own ``I ω_c²`` = 65 — is a
   position-dependent torque error within the reuse angle that only a fast ``d̂`` could cancel;
5. *allocation*: :func:`~spherestep.control.allocation.allocate_matrix`, least copper power with
   ``b + K c = τ*`` within the limits, warm-started from the last period's dual; the command is ``c``, the
   torque it promises ``τ_p = b + K c`` (what step 1 uses next period) and whether ``τ*`` was reachable.

6. *the current's lag* (``current_lag`` τ > 0: the drive's current follows its setpoint first order with τ):
   over a period ``h`` from the last setpoint ``c'_prev`` toward ``c'`` the current's mean is
   ``c' − β (c' − c'_prev)``, ``β = (τ/h)(1 − e^{−h/τ})``; the setpoint sent is the ``c'`` whose mean is the
   allocation's ``c``, ``c' = c + β/(1 − β)(c − c'_prev)``, kept within the period's box and the power ball (the
   torque promised stays ``b + K c``). On the emulated device's 2000 rad/s current loop (τ = 0.5 ms) at 500 Hz,
   β = 0.245.

The limits of step 5 are the period's *supply box* (``voltage=True``, the default): per coil the supply voltage
against the back-EMF of the estimated motion, ``|R I_n c_k + K_k·ω̂/I_n| ≤ V``, with ``|c_k| ≤ u``
(:func:`spherestep._fast.allocation.voltage_box`, asymmetric per coil and not always holding 0: a coil whose
back-EMF exceeds the supply brakes whatever the bridge does, and its torque is counted) — the box the planner of
:mod:`.time_optimal` plans within. ``slew=True`` also keeps each coil within what one period of full supply
moves its current from the last command (``e^{−h/T}``, ``T = L/R``; off by default: on the iron prototype with
the honest 0.65 H it tracked worse, 1.96° against 1.31°).

The power ball (``supply=True``, the default) bounds the supply's power, ``Σ R i² + Σ e_k i_k`` and, with
``inductive=True`` (off by default), the inductance's ``L I_n² (c² − c_prev²)/(2h)`` over the period from the
last command: one ball centred at ``−ê/(2a)``, ``a = 1 + T/(2h)`` (:func:`~spherestep.control.allocation.
allocate_matrix`'s ``emf``/``previous``/``period``; the copper's own ``‖c‖ ≤ ρ`` kept too). The inductive term
keeps the demo turn's peak under 100 W (97.8 W against 102.9 W without it) but slows the currents' rise where a
hold needs nearly the whole power ball: against the winding ×0.85 plant the worst of 8 holds went from 0.057° to
0.243°, so it is off by default (the stored energy returns to the supply's capacitor within milliseconds).

Scales (``adapt``, default on for a model with a bias and a disturbance estimate): the plant's bias taken as
``(1 + θ_b) b̂`` (and, with ``ADAPT_WINDING``, its coils' torque as ``(1 + θ_K) K̂ c``), the step-5 model scaled
so; ``θ`` learnt in motion (``|ω_d| > ADAPT_SPEED``) by exponentially weighted least squares on what ``d̂`` and
the scales attribute to the plant (:meth:`ServoLaw._adapt`). A detent wrong by a factor is a position-dependent
torque the estimate ``d̂`` follows with lag; as a scale it is a constant. The winding's scale is off by default:
the coils' current lags the command by ``L/R``, which the regression reads as a weaker winding (θ_K ≈ −0.14 on
the exact model), and the fastest turn leaves the feedback only 10 % of the drive.

The observer's state is ``(R̂, ω̂, d̂)``: ``d̂`` the torque the model gets wrong (N·m, fixed frame), carried in the
prediction ``ω̂ ← ω̂ + h (τ_p + d̂)/I`` and corrected by the residual with the gain of the extended observer
(:func:`~spherestep.control.controller.observer_gains`, bandwidth ``disturbance_bandwidth``, 0 turns it off).
Step 3's torque is then ``τ* − d̂``: the allocation asks ``b̂ + K̂ c = τ* − d̂``, so the plant's ``b + K c + d``
is ``τ*`` once ``d̂ = d``. Anti-windup: the observer predicts with the torque the allocation *promised* (the
reachable one when ``τ* − d̂`` is out of reach), so ``d̂`` never integrates a shortfall of the drive, only the
plant's departure from the model.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from .. import checks, so3
from ..errors import bad_value
from ..statics import TorqueModel, is_torque_model
from .allocation import allocate_matrix
from .controller import SPEED_MEMORY, GeometricPD, Observer, disturbance_bandwidths
from ..electrics import DriveLimits, lag_weight
from .trajectory import Trajectory

K_REUSE = 2e-3  # rad: K(R) and b(R) are re-evaluated when the orientation has turned further than this
ADAPT_MEMORY = 1.0  # s: the scale regression's memory
ADAPT_RIDGE = 0.05  # its ridge, relative to the regressors' energy (damps the common scale, which holds leave unexcited)
ADAPT_LIMIT = 0.5  # the largest |θ| (a plant within ±50 % of the model's bias and winding)
ADAPT_WINDING = False  # learn the winding's scale θ_K too (measured worse: the coils' L/R lag reads as a weaker winding)
ADAPT_SPEED = 0.2  # rad/s: the scales learn only in motion (|ω_d| above this); at rest d̂ alone serves
SLOPE_SPEED = 0.2  # rad/s: K and b to first order about their anchor while |ω_d| is below this (an anchor then
# serves ≥ K_REUSE × rate / SLOPE_SPEED = 10 periods at 1 kHz, which pays for its slopes' 3 evaluations)


class ModelCache:
    """``K(R)`` and the bias ``b(R) = τ(R, 0)`` of a torque ``model`` near the last orientation they were evaluated
    at: :meth:`at` re-evaluates them only when ``R`` has turned more than ``reuse`` rad from there (a relative
    error in ``K`` up to ~1 % for the air-core map and ~5 % for the iron model at 2e-3 rad, which the feedback
    absorbs; the angle is
    judged from ``tr(R Aᵀ)``, to about 1e-7 rad). Serves the servo law (at the estimate) and the emulated motor
    (at the true orientation).

    A model that declares its packed terms affine in each coil's own current
    (:attr:`~spherestep.statics.TorqueModel.affine_in_currents`: the torque map, the iron model, the fast
    potential) is evaluated by one compiled call, ``K`` and ``b`` together (:mod:`spherestep._fast.linear`,
    equal to ``model.torque_matrix``/``model.torque`` to rounding; ``compiled`` tells); any other through the
    model's own methods."""

    def __init__(self, model: TorqueModel, reuse: float = K_REUSE):
        if not is_torque_model(model):
            raise bad_value("model", "a torque model (spherestep.statics.TorqueModel)", type(model).__name__)
        self.model = model
        self.reuse = checks.non_negative(reuse, "reuse")
        self._cos = 1.0 + 2.0 * math.cos(self.reuse)  # tr(R Aᵀ) at the reuse angle
        self.has_bias = bool(model.has_bias)
        self.evaluations = 0
        self.slope_evaluations = 0
        self._slopes: tuple[np.ndarray, np.ndarray] | None = None
        self._K1, self._bias1 = np.zeros((3, model.coil_count)), np.zeros(3)
        self._at: np.ndarray | None = None
        self._K = np.zeros((3, model.coil_count))
        self._bias = np.zeros(3)
        self._zeros = np.zeros(model.coil_count)
        self._affine = _affine_terms(model)
        from .._fast.linear import first_order  # compiled: imported with the law, not with the room

        self._first_order = first_order
        self.compiled = self._affine is not None
        # the first calls here, not in a loop's first period: on a fresh install they compile (first_order took
        # 0.7 s in the first period of move --emulate, 7x the device's watchdog period; the model's own evaluation
        # on a port, where no emulator's warm-up has called it)
        eye = np.eye(3)
        self._evaluate(eye, self._K, self._bias)
        first_order(eye, eye, self._K, np.zeros(self._K.shape + (3,)), self._bias, np.zeros((3, 3)), self._K1,
                    self._bias1)

    def at(self, R: np.ndarray, slope: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """``(K (3, N), b (3,))`` for one rotation ``R (3, 3)`` (trusted: the loop's own estimate). The arrays are
        the cache's own, overwritten at the next re-evaluation: copy them to keep them.

        ``slope``: to first order about the anchor ``A`` (the orientation they were last evaluated at),
        ``K(A) + Σ_j ε_j ∂_j K(A)`` and ``b(A) + ∂b(A) ε`` with ``ε = vee(R Aᵀ − A Rᵀ)/2`` (fixed frame; ``≈
        log(R Aᵀ)`` to ``|ε|³``), the derivatives ``∂_j`` along the fixed axes by forward differences of
        ``reuse/2`` (3 evaluations, once per anchor, when first asked: :attr:`slope_evaluations`; their error
        ``O(reuse)`` is of the order of the ``O(ε)`` neglected; one compiled call per period after that,
        :func:`spherestep._fast.linear.first_order`).
        Within the reuse angle the error is then ``O(ε²)`` instead of the stiffness ``∂b ε`` (the iron's detent:
        up to ~230 N·m/rad, ×2e-3 rad)."""
        A = self._at
        if A is None or self._moved(R, A):
            self._evaluate(R, self._K, self._bias)
            self._at = A = np.array(R, dtype=float)
            self._slopes = None
            self.evaluations += 1
        if not slope or self.reuse == 0:
            return self._K, self._bias
        if self._slopes is None:
            self._slopes = self._derivatives(A)
        dK, db = self._slopes
        self._first_order(R, A, self._K, dK, self._bias, db, self._K1, self._bias1)
        return self._K1, self._bias1

    def _evaluate(self, R: np.ndarray, K: np.ndarray, bias: np.ndarray) -> None:
        """``K(R)`` and ``b(R)`` written into ``K (3, N)`` and ``bias (3,)``."""
        if self._affine is not None:
            self._affine(R if R.flags.c_contiguous else np.ascontiguousarray(R), K, bias)
            if not self.has_bias:
                bias[:] = 0.0
        else:
            K[:] = np.asarray(self.model.torque_matrix(R), dtype=float)
            bias[:] = np.asarray(self.model.torque(R, self._zeros), dtype=float) if self.has_bias else 0.0

    def _derivatives(self, A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(∂K (3, N, 3), ∂b (3, 3))`` at ``A`` along the fixed axes (``[..., j]``: per rad about axis ``j``),
        forward differences of ``reuse/2`` from the anchor's own ``K``, ``b``."""
        dK = np.empty(self._K.shape + (3,))
        db = np.empty((3, 3))
        h = 0.5 * self.reuse
        Kp, bp = np.empty_like(self._K), np.empty(3)
        for j in range(3):
            v = np.zeros(3)
            v[j] = h
            self._evaluate(so3.exp(v) @ A, Kp, bp)
            dK[:, :, j] = (Kp - self._K) / h
            db[:, j] = (bp - self._bias) / h
        self.slope_evaluations += 3
        return dK, db

    def _moved(self, R: np.ndarray, A: np.ndarray) -> bool:
        """Whether ``R`` is more than ``reuse`` rad from ``A``: ``tr(R Aᵀ) < 1 + 2 cos(reuse)``."""
        Rl, Al = R.tolist(), A.tolist()
        if self.reuse == 0:
            return Rl != Al
        (a, b, c), (d, e, f), (g, h, i) = Rl
        (p, q, r), (s, u, v), (w, x, y) = Al
        return a * p + b * q + c * r + d * s + e * u + f * v + g * w + h * x + i * y < self._cos


def _affine_terms(model: TorqueModel):
    """The compiled ``call(R, K, bias)`` for ``model`` (:func:`spherestep._fast.linear.affine_call`) from its packed
    terms at 0 and 1 per unit in every live coil, when the model declares them affine in the currents
    (:attr:`~spherestep.statics.TorqueModel.affine_in_currents`); else ``None``."""
    if not model.affine_in_currents:
        return None
    live = np.ones(model.coil_count)
    live[list(model.failed)] = 0.0
    p0, p1 = model.packed_terms(0.0 * live), model.packed_terms(live)
    C0 = np.ascontiguousarray(p0.C, dtype=float)
    D = np.ascontiguousarray(p1.C - p0.C, dtype=float)
    from .._fast.linear import affine_call

    return affine_call(p0, C0, D)


@dataclass(frozen=True)
class ServoCommand:
    """One period's output of :meth:`ServoLaw.step`: ``currents (N,)`` per unit (:meth:`ServoLaw.amperes` for
    A); ``torque (3,)`` N·m that they promise at the estimate, ``b + K c``; ``requested (3,)`` the feedback's
    ``τ* − d̂``; ``reachable`` whether it was within the limits; ``estimate (3, 3)`` and ``velocity (3,)`` rad/s,
    the observer's ``(R̂, ω̂)`` the command was computed from; ``disturbance (3,)`` N·m its ``d̂`` (already
    subtracted from ``requested``: the torque the plant is estimated to add to the model's); ``emf (N,)`` V each
    coil's back-EMF ``e_k = K_k(R)·ω / I_n`` at the state the currents were allocated for (the voltage box's,
    sent to a device that takes it: its current loop feeds it forward and its coil's-law check expects it)."""

    currents: np.ndarray
    torque: np.ndarray
    requested: np.ndarray
    reachable: bool
    estimate: np.ndarray
    velocity: np.ndarray
    disturbance: np.ndarray
    emf: np.ndarray


class ServoLaw:
    """The servo law of the module for ``model`` (the controller's belief, any
    :class:`~spherestep.statics.TorqueModel`) following ``trajectory`` (a :class:`Trajectory`; see
    :meth:`Trajectory.hold` for a fixed pose).

    ``controller`` a :class:`GeometricPD` (its ``inertia`` and ``damping`` are also the observer's);
    ``limits`` the :class:`DriveLimits` the allocation keeps within (default 24 V / 100 W);
    ``sensor_rate`` (Hz) the rate measurements arrive at (the observer's gains; default the controller's rate);
    ``observer_bandwidth`` (rad/s, default the observer's: ``ω_d`` with the disturbance estimate, else 120);
    ``disturbance_bandwidth`` and ``motion_bandwidth`` (rad/s, the extended observer's triple pole at rest and
    in motion; default :func:`~spherestep.control.controller.disturbance_bandwidths`: for a model with a bias
    (the iron's detent) ``1/T`` at rest (``T`` = ``limits.time_constant``, the coil's ``L/R``; 128 rad/s for the
    iron coil's 0.65 H) within ``[100, 300]``, 200 in motion with a 1 kHz sensor; 100 at rest and 300 in motion
    without, off with a sensor slower than 333 Hz; ``disturbance_bandwidth=0``: no disturbance estimate, the PD
    law with feed-forward alone; a ``disturbance_bandwidth`` given alone: fixed poles); ``reuse``
    rad (see :class:`ModelCache`);
    ``delay`` the control periods between a command and the drive applying it (0 in simulation; 1 on hardware,
    where the currents computed in a cycle are sent at the next cycle's start): the observer predicts with the
    torque promised ``delay`` periods before; ``lead`` s (default 0) how far ahead of the reading the command
    acts (step 3 of the module). ``voltage`` (default on): the allocation within the period's supply
    box at ``ω̂``; ``slew`` (default off): also within the coil's slew; ``adapt`` (default: with a bias and a
    disturbance estimate) the scales :attr:`scales` (see the module); ``supply`` (default on): the power ball
    bounds the supply's power ``Σ R i² + Σ e_k i_k ≤ P`` at ``ω̂`` rather than the copper loss alone
    (:func:`~spherestep.control.allocation.allocate_matrix`'s ``emf``); ``inductive`` (default off): with it the
    power the coils' inductance takes over the period from the last command (see the module).
    """

    def __init__(self, model: TorqueModel, trajectory: Trajectory, controller: GeometricPD, *,
                 limits: DriveLimits | None = None, sensor_rate: float | None = None,
                 observer_bandwidth: float | None = None, disturbance_bandwidth: float | None = None,
                 motion_bandwidth: float | None = None, reuse: float = K_REUSE, delay: int = 0,
                 voltage: bool = True, slew: bool = False, adapt: bool | None = None, supply: bool = True,
                 inductive: bool = False, lead: float = 0.0, current_lag: float = 0.0):
        if not isinstance(trajectory, Trajectory):
            raise bad_value("trajectory", "a spherestep.control.Trajectory", type(trajectory).__name__)
        if not isinstance(controller, GeometricPD):
            raise bad_value("controller", "a spherestep.control.GeometricPD", type(controller).__name__)
        if limits is not None and not isinstance(limits, DriveLimits):
            raise bad_value("limits", "a spherestep.control.DriveLimits", type(limits).__name__)
        self.cache = ModelCache(model, reuse)
        self.model, self.trajectory, self.controller = model, trajectory, controller
        self.limits = DriveLimits() if limits is None else limits
        rate = controller.rate if sensor_rate is None else checks.positive(sensor_rate, "sensor_rate")
        wd, wm = disturbance_bandwidths(rate, controller.bandwidth, bool(model.has_bias), self.limits.time_constant)
        if disturbance_bandwidth is not None:
            wd, wm = disturbance_bandwidth, 0.0
        self.observer = Observer(trajectory.start, inertia=controller.inertia, sensor_period=1.0 / rate,
                                 **({} if observer_bandwidth is None else {"bandwidth": observer_bandwidth}),
                                 disturbance_bandwidth=wd, motion_bandwidth=wm if motion_bandwidth is None
                                 else motion_bandwidth)
        self.started = False  # the observer starts from the first measurement
        self._speed = 0.0
        self._failed = tuple(model.failed)
        self._lam = None
        self.delay = checks.count(delay, "delay", 0, 8)
        self.lead = checks.non_negative(lead, "lead")
        lag = checks.non_negative(current_lag, "current_lag")
        beta = lag_weight(lag, 1.0 / controller.rate)
        self._emphasis = beta / (1.0 - beta)  # the step's pre-emphasis β/(1 − β) (step 6 of the module)
        self._promised = deque([np.zeros(3)] * (self.delay + 1), maxlen=self.delay + 1)
        self.voltage = bool(voltage)
        self.supply = bool(supply)
        self._period = 1.0 / controller.rate if inductive else 0.0
        lim = self.limits
        N = model.coil_count
        self._box = (np.zeros(N), np.zeros(N))
        self._failed_idx = np.array(self._failed, dtype=np.int64)
        self._emf = lim.emf_factor  # K·ω (N·m·rad/s) → per-unit volts
        self._u = lim.per_unit_bound
        self._uv = lim.voltage_bound
        period = 1.0 / controller.rate
        self._slew = math.exp(-period / lim.time_constant) if slew else 0.0
        self._last = np.zeros(N)
        self._sent = np.zeros(N)  # the last setpoint sent (step 6)
        self.adapt = bool(model.has_bias and self.observer.l3) if adapt is None else bool(adapt)
        self._theta = (0.0, 0.0)  # (θ_b, θ_K): the plant's bias ≈ (1 + θ_b) b̂, its coils' torque ≈ (1 + θ_K) K̂ c
        self._normal = (0.0,) * 5  # the regression's discounted normal equations (A₀₀, A₀₁, A₁₁, y₀, y₁)
        self._parts = deque([((0.0,) * 3, (0.0,) * 3)] * (self.delay + 1), maxlen=self.delay + 1)
        from .._fast.allocation import voltage_box  # compiled: imported with the law, not with the room

        self._voltage_box = voltage_box
        # first calls (model set-up, imports, caches) here rather than in the first period
        self._allocate(np.zeros(3), self.observer.R)
        self._lam = None
        self._last = np.zeros(N)
        self._parts.extend([((0.0,) * 3, (0.0,) * 3)] * (self.delay + 1))

    @property
    def scales(self) -> tuple[float, float]:
        """``(θ_b, θ_K)``: the law's estimate that the plant's bias is ``(1 + θ_b) b̂`` and its coils' torque
        ``(1 + θ_K) K̂ c`` (0, 0 when it does not adapt; see :meth:`_adapt`)."""
        return self._theta

    def amperes(self, currents) -> np.ndarray:
        """Per-unit ``currents`` in amperes: ``I_n c`` (the drive's wire unit; :meth:`DriveLimits.amperes`)."""
        return self.limits.amperes(currents)

    def predicted(self, t: float) -> np.ndarray:
        """The observer's orientation carried on to ``t`` at its rate of turn, ``exp((t − t̂) ω̂) R̂`` (a search's
        start for a sensor that estimates from readings; the state is not changed)."""
        return so3.exp((t - self.observer.t) * self.observer.w) @ self.observer.R

    def step(self, t: float, measurement: np.ndarray | None = None, measured_at: float | None = None
             ) -> ServoCommand:
        """One control period at loop time ``t`` (s): predict to ``t``, correct with ``measurement`` (a rotation
        ``(3, 3)`` taken at ``measured_at``, default ``t``, or ``None``), feedback, ``K``/bias, allocation (see the
        module). Call with non-decreasing ``t``."""
        obs = self.observer
        h = t - obs.t
        if h > 0:
            obs.predict(self._promised[0] - self.controller.damping * obs.w, h)
        Rd, wd, ad = self.trajectory.at(t)
        if obs.motion_bandwidth:  # the speed the observer's poles follow: |ω_d|, its peaks held SPEED_MEMORY s
            self._speed = max(math.sqrt(float(wd @ wd)), self._speed * math.exp(-max(h, 0.0) / SPEED_MEMORY))
        if measurement is not None:
            if not self.started:
                obs.restart(measurement)
                self.started = True
            else:
                obs.correct(measurement, measured_at, self._speed)
        if self.adapt and measurement is not None and h > 0 and float(wd @ wd) > ADAPT_SPEED * ADAPT_SPEED:
            self._adapt(h)
        R, w = obs.R, obs.w
        if self.lead > 0 and self.started:  # the state when this command takes effect (see the module, step 3)
            R, w = self._ahead(self.lead)
            Rd, wd, ad = self.trajectory.at(t + self.lead)
        tau = self.controller.torque(R, w, Rd, wd, ad)
        if obs.l3:
            tau = tau - obs.d
        alloc = self._allocate(tau, R, self.cache.has_bias and float(wd @ wd) < SLOPE_SPEED * SLOPE_SPEED, w)
        self._promised.append(alloc.torque)
        currents = self._emphasised(alloc.currents) if self._emphasis else alloc.currents
        return ServoCommand(currents, alloc.torque, tau, alloc.reachable, obs.R, obs.w, obs.d, self._volts)

    def _emphasised(self, c: np.ndarray) -> np.ndarray:
        """Step 6 of the module: the setpoint ``c' = c + β/(1 − β) (c − c'_prev)`` whose first-order response from
        the last setpoint has the mean ``c`` over the period, within the period's box and the power ball
        (``‖c + s δ‖ ≤ ρ``, the largest ``s ≤ 1``)."""
        lower, upper = self._box if self.voltage else (-self._u, self._u)
        delta = np.clip(c + self._emphasis * (c - self._sent), lower, upper) - c
        rho2 = self.limits.per_unit_power_radius ** 2
        out = c + delta
        if out @ out > rho2:  # |c + s δ|² = ρ²: the root s in [0, 1] (|c| ≤ ρ from the allocation)
            a, b, cc = delta @ delta, 2.0 * (c @ delta), c @ c - rho2
            root = (-b + math.sqrt(max(b * b - 4.0 * a * cc, 0.0))) / (2.0 * a)
            out = c + min(max(root, 0.0), 1.0) * delta
        self._sent = out
        return out

    def _ahead(self, lead: float) -> tuple[np.ndarray, np.ndarray]:
        """The observer's state carried ``lead`` s on under the torque already commanded, ``τ_p − b_d ω̂ + d̂``
        (the newest promise: the currents the drive applies until this period's command takes effect), without
        changing it: ``ω⁺ = ω̂ + lead (τ_p − b_d ω̂ + d̂)/I``, ``R⁺ = exp(lead (ω̂ + ω⁺)/2) R̂``."""
        obs = self.observer
        acc = (self._promised[-1] - self.controller.damping * obs.w + obs.d) / obs.inertia
        w = obs.w + lead * acc
        return so3.exp((0.5 * lead) * (obs.w + w)) @ obs.R, w

    def _allocate(self, tau: np.ndarray, R: np.ndarray, slope: bool = False, w: np.ndarray | None = None):
        """Steps 4 and 5 of the module: ``K``/bias at ``R`` (to first order about the cache's anchor with
        ``slope``), the period's current box at the rate of turn ``w`` (default the observer's) and the
        warm-started allocation of ``tau``."""
        w = self.observer.w if w is None else w
        K, b = self.cache.at(R, slope)
        if self.adapt:
            b_nominal = b
            kb, kk = 1.0 + self._theta[0], 1.0 + self._theta[1]
            b = b * kb
            K = K * kk
        bounds = emf = None
        self._volts = self.limits.back_emf(w @ K)  # e_k = K_k·ω / I_n (V), the coils' back-EMF this period
        if self.supply:  # the supply's power Σ R i² + Σ e_k i_k ≤ P at the estimated motion
            emf = (w * self._emf) @ K
        if self.voltage:
            lower, upper = self._box
            self._voltage_box(K, w * self._emf, self._last, self._u, self._uv, self._slew, lower, upper)
            if self._failed:
                lower[self._failed_idx] = 0.0
                upper[self._failed_idx] = 0.0
            bounds = self._box
        alloc, self._lam = allocate_matrix(K, tau, self.limits, bias=b if self.cache.has_bias else None,
                                           failed=self._failed, lam0=self._lam, bounds=bounds, emf=emf,
                                           previous=self._last, period=self._period)
        self._last = alloc.currents
        if self.adapt:  # the nominal model's parts of the promise, for the regression (``delay`` periods on)
            self._parts.append((b_nominal.tolist(), ((alloc.torque - b) / kk).tolist()))
        return alloc

    def _adapt(self, h: float) -> None:
        """The scales ``θ = (θ_b, θ_K)`` by exponentially weighted least squares (memory ``ADAPT_MEMORY`` s) on
        the plant's departure from the nominal model, ``z = d̂ + θ_b b̂ + θ_K K̂ c ≈ [b̂, K̂ c] θ`` (the torque the
        estimate ``d̂`` and the scaled model together attribute to the plant, regressed on the nominal model's bias
        and coil torque of the command applied), ridge ``ADAPT_RIDGE``, each scale within ``±ADAPT_LIMIT``;
        without ``ADAPT_WINDING``, ``θ_K = 0`` and ``θ_b = Σ b̂·z / (Σ b̂·b̂ + ridge (Σ b̂·b̂ + Σ |K̂c|²))``."""
        (b0, b1, b2), (u0, u1, u2) = self._parts[0]
        d0, d1, d2 = self.observer.d.tolist()
        sb, sk = self._theta
        z0, z1, z2 = d0 + sb * b0 + sk * u0, d1 + sb * b1 + sk * u1, d2 + sb * b2 + sk * u2
        f = math.exp(-h / ADAPT_MEMORY)
        a00, a01, a11, y0, y1 = self._normal
        a00 = f * a00 + b0 * b0 + b1 * b1 + b2 * b2
        a01 = f * a01 + b0 * u0 + b1 * u1 + b2 * u2
        a11 = f * a11 + u0 * u0 + u1 * u1 + u2 * u2
        y0 = f * y0 + b0 * z0 + b1 * z1 + b2 * z2
        y1 = f * y1 + u0 * z0 + u1 * z1 + u2 * z2
        self._normal = (a00, a01, a11, y0, y1)
        r = ADAPT_RIDGE * (a00 + a11) + 1e-12
        if not ADAPT_WINDING:  # the bias's scale alone
            if a00 > 0:
                t0 = y0 / (a00 + r)
                self._theta = (min(max(t0, -ADAPT_LIMIT), ADAPT_LIMIT), 0.0)
            return
        p00, p11 = a00 + r, a11 + r
        det = p00 * p11 - a01 * a01
        if det > 0:
            t0 = (p11 * y0 - a01 * y1) / det
            t1 = (p00 * y1 - a01 * y0) / det
            self._theta = (min(max(t0, -ADAPT_LIMIT), ADAPT_LIMIT), min(max(t1, -ADAPT_LIMIT), ADAPT_LIMIT))
