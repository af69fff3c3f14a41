"""Coil electrics: each coil an R–L circuit on an H-bridge, with a current loop and PWM resolution.

Per coil, ``L di/dt = v − R i − e`` (A, V, Ω, H). ``e`` is the back-EMF the moving rotor induces: by energy
balance the mechanical power a coil delivers, ``τ_k·ω = (K_k c_k)·ω``, equals ``e_k i_k``, so with per-unit
currents ``c = i / I_n`` (see :mod:`spherestep.electrics`) ``e_k = K_k(R)·ω / I_n`` — exact for a model
linear in the currents. With ``v`` and ``e`` constant over a PWM period ``h`` the solution is exact:

    i(h) = i∞ + (i(0) − i∞) e^{−h/T},   i∞ = (v − e)/R,   T = L/R,

and its mean over the period is ``i∞ + (i(0) − i∞)(1 − e^{−x})/x``, ``x = h/T``.

Current loop, once per PWM period: a PI controller designed by pole–zero cancellation (internal-model
control), ``v = R i_ref + L ω_i (i_ref − i) + R ω_i ∫(i_ref − i) dt``, which makes the closed loop first order
with bandwidth ``ω_i`` (rad/s); the voltage is limited to the supply ``±V`` (the integral stops while it is
limited) and quantised to the PWM's duty resolution, ``2^bits`` levels over ``[−V, +V]``. The bridge is modelled
by its mean voltage over a period (no ripple).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..electrics import DriveLimits, rl_step  # noqa: F401  (rl_step: the room's name for it too)
from .. import checks

PWM_RATE = 10_000.0  # Hz, the PWM period is the current loop's period
PWM_BITS = 10
LOOP_BANDWIDTH = 2 * math.pi * 1000.0  # rad/s


@dataclass(frozen=True)
class CoilDrive:
    """H-bridges with current loops for every coil: ``limits`` (R, L, supply), ``pwm_rate`` (Hz),
    ``pwm_bits`` (duty resolution), ``bandwidth`` ``ω_i`` (rad/s) of the current loop."""

    limits: DriveLimits = DriveLimits()
    pwm_rate: float = PWM_RATE
    pwm_bits: int = PWM_BITS
    bandwidth: float = LOOP_BANDWIDTH

    def __post_init__(self):
        for name in ("pwm_rate", "bandwidth"):
            checks.positive(getattr(self, name), name)
        checks.count(self.pwm_bits, "pwm_bits", 1, 24)

    def quantise(self, v: np.ndarray) -> np.ndarray:
        """Voltage limited to ``±V`` and rounded to the PWM's duty resolution."""
        V = self.limits.supply_voltage
        levels = 2 ** (self.pwm_bits - 1)
        return np.round(np.clip(v, -V, V) / V * levels) / levels * V

    def run(self, i, integral, i_ref, emf, duration: float) -> tuple[np.ndarray, ...]:
        """Advance the coils for ``duration`` s (whole PWM periods) toward the reference ``i_ref (N,)`` (A) under
        back-EMF ``emf (N,)`` (V). Returns ``(i, integral, i_mean, v_mean, supply_energy)``: currents at the end,
        the loop's integral state, mean current and voltage over the interval, and the energy ``∫ Σ v i dt`` (J)
        drawn from the supply (negative: returned to it)."""
        lim = self.limits
        R, L, V = lim.resistance, lim.inductance, lim.supply_voltage
        periods = max(1, int(round(duration * self.pwm_rate)))
        h = duration / periods
        kp, ki = L * self.bandwidth, R * self.bandwidth
        i = np.array(i, dtype=float)
        integral = np.array(integral, dtype=float)
        i_ref = np.asarray(i_ref, dtype=float)
        feed = R * i_ref
        i_sum = np.zeros_like(i)
        v_sum = np.zeros_like(i)
        energy = 0.0
        for _ in range(periods):
            err = i_ref - i
            v_raw = feed + kp * err + ki * integral
            v = self.quantise(v_raw)
            integral += np.where(np.abs(v_raw) < V, err * h, 0.0)
            i, i_mean = rl_step(i, v, emf, R, L, h)
            i_sum += i_mean
            v_sum += v
            energy += float(v @ i_mean) * h
        return i, integral, i_sum / periods, v_sum / periods, energy
