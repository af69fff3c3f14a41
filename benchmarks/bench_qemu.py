"""The firmware in QEMU (spherestep.hardware.qemu): what the host link and the board's pins cost, and the control
step in instructions. Run: python benchmarks/bench_qemu.py [frames]. Prints the load average with the numbers.

* a model tick: one board control step through the exchange and its doorbells (29 coils, 8 sensors);
* a 29-coil ``DRIVE`` round trip over UART0's pseudo-terminal with the emulated motor behind the board (median,
  p90, p99, most of ``frames``);
* the control step: instructions per step that drove the coils (SysTick against the 100002-instruction loop).
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np

from spherestep.hardware import DriveLink, EmulatedMotor
from spherestep.hardware.limits import CurrentLimits
from spherestep.hardware.qemu import QemuBoard, QemuMotor
from spherestep.magnetics import design_model
from spherestep.motor import prototype
from spherestep.sensing import default_array


def ticks(count: int = 400) -> float:
    """Median s of one model tick (step doorbell and answer) on a board with 29 coils, 8 sensors."""
    counts = np.zeros((8, 3), dtype=np.int64)
    with QemuBoard() as board:
        board.configure(29, 8, watchdog_ms=100, period_us=1000, limits=CurrentLimits(), supply=24.0,
                        inductance=18.7e-3, bandwidth=500.0, nominal_ma=1000, field_lsb_nt=8118, name="bench")
        times = []
        for k in range(count):
            start = time.perf_counter()
            board.step(1000 * (k + 1), np.zeros(29, dtype=np.int64), lambda: (counts, 0))
            times.append(time.perf_counter() - start)
    return float(np.median(times))


def drives(frames: int) -> tuple[np.ndarray, tuple]:
    """Round-trip times (s) of ``frames`` 29-coil DRIVEs (the servo's small currents) to the firmware in QEMU
    driving the iron prototype's emulated motor, and its control step's cost."""
    design = prototype()
    own = design_model(design)
    motor = EmulatedMotor(design, own.model, default_array(design, 8), drive=own.limits, period=1e-3)
    with QemuMotor(motor) as dev, DriveLink(dev.port, timeout=0.1) as link:
        currents = np.full(29, 0.05)
        times = []
        for k in range(frames):
            start = time.perf_counter()
            link.drive(currents * (1 if k % 2 else -1))
            times.append(time.perf_counter() - start)
        cost = dev.step_cost()
    return np.array(times), cost


def main() -> None:
    frames = int(sys.argv[1]) if len(sys.argv) > 1 else 300
    tick = ticks()
    times, (steps, mean, worst) = drives(frames)
    ms = 1e3 * times
    print(f"load {' '.join(open('/proc/loadavg').read().split()[:3])}, {os.cpu_count()} cores")
    print(f"model tick through the exchange: {1e3 * tick:.3f} ms median")
    print(f"29-coil DRIVE round trip over UART0 ({frames} frames): median {np.median(ms):.2f} ms, "
          f"p90 {np.percentile(ms, 90):.2f}, p99 {np.percentile(ms, 99):.2f}, most {ms.max():.2f}")
    print(f"control step: {mean:.0f} instructions mean, {worst:.0f} most, over {steps} driving steps "
          f"({mean / 600:.1f} µs at 600 MHz and one instruction a cycle)")


if __name__ == "__main__":
    main()
