"""What the one builder and the input contracts cost (medians of repeats, measured side by side in one run).

Run: ``.venv/bin/python benchmarks/bench_contracts.py [--quick]``.

* ``prototype()`` through ``MotorDesign.from_packings``: the first call in a process refines both packings,
  later calls share them (``packing.named`` caches; a design is immutable). The baseline is the same design
  with the packings refined afresh (what every call did before the cache).
* ``so3.as_rotations`` on one rotation (plain floats), 12 (a planner's batch: one batched matmul) and 10,000, beside the work it guards (``so3.angle`` of the
  same batch, which includes the check) — the contract's share of a call; baseline: ``RᵀR − I`` by a batched
  3 × 3 matmul, as the check was first written.
* ``sphere.as_points`` on 10,000 points beside ``sphere.arc_distance`` of the same points.
* A design file's round trip: ``design.dumps()`` and ``MotorDesign.loads(text)`` for the prototype.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform

import numpy as np

from _timing import median_seconds
from spherestep import packing as pk
from spherestep import so3, sphere
from spherestep.motor import MotorDesign, prototype


def uncached_prototype() -> MotorDesign:
    """The prototype with both packings refined afresh (the cost before ``packing.named``)."""
    base = prototype()
    rotor = pk.refine(pk.by_name("truncated-icosahedron"), levels=1)
    full = pk.refine(pk.by_name("truncated-cuboctahedron"), levels=1)
    return MotorDesign.from_packings(
        rotor=rotor, stator=full, polarity=base.polarity, stator_axis=base.stator_axis,
        cap_half_angle=base.cap_half_angle, sphere_diameter=base.sphere_diameter,
        magnet_diameter=base.magnet_diameter, magnet_length=base.magnet_length, coil_diameter=base.coil_diameter,
        coil_length=base.coil_length, air_gap=base.air_gap, name="prototype")


def matmul_orthogonality(R: np.ndarray) -> float:
    """Baseline: ``max |RᵀR − I|`` by a batched 3 × 3 matmul (how the check was computed before)."""
    return float(np.max(np.abs(np.swapaxes(R, -1, -2) @ R - np.eye(3))))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args()
    repeats = 3 if args.quick else 15
    print(f"# bench_contracts  {datetime.datetime.now().isoformat(timespec='minutes')}  {platform.platform()}  "
          f"cpus={os.cpu_count()}  python={platform.python_version()}  numpy={np.__version__}")
    R = so3.random(10_000, 0)
    u = sphere.point(*np.random.default_rng(1).uniform(0, 3, (2, 10_000)))
    design = prototype()
    text = design.dumps()
    rows = [
        ("prototype(), packings cached", median_seconds(repeats, prototype), None),
        ("prototype(), packings refined afresh (baseline)", median_seconds(repeats, uncached_prototype), None),
        ("as_rotations, 1 rotation", median_seconds(repeats * 100, so3.as_rotations, R[0]), None),
        ("as_rotations, 12 rotations (one batched matmul)", median_seconds(repeats * 100, so3.as_rotations, R[:12]),
         None),
        ("as_rotations, 10,000 rotations", median_seconds(repeats, so3.as_rotations, R), None),
        ("max|RᵀR − I| by batched matmul, 10,000 (baseline)", median_seconds(repeats, matmul_orthogonality, R), None),
        ("so3.angle, 10,000 rotations (includes the check)", median_seconds(repeats, so3.angle, R), None),
        ("as_points, 10,000 points", median_seconds(repeats, sphere.as_points, u), None),
        ("arc_distance, 10,000 pairs (includes 2 checks)", median_seconds(repeats, sphere.arc_distance, u, u[::-1]),
         None),
        ("design.dumps(), prototype", median_seconds(repeats, design.dumps), None),
        ("MotorDesign.loads(text), prototype", median_seconds(repeats, MotorDesign.loads, text), None),
    ]
    print(f"{'what':<52} {'median ms':>10}")
    for what, seconds, _ in rows:
        print(f"{what:<52} {1e3 * seconds:>10.3f}")
    t = dict((w, s) for w, s, _ in rows)
    print(f"ratio baseline/cached prototype: {t['prototype(), packings refined afresh (baseline)'] / t['prototype(), packings cached']:.1f}")
    print(f"ratio batched-matmul baseline/as_rotations on 10,000: "
          f"{t['max|RᵀR − I| by batched matmul, 10,000 (baseline)'] / t['as_rotations, 10,000 rotations']:.1f}")
    print(f"as_rotations share of so3.angle on 10,000: "
          f"{t['as_rotations, 10,000 rotations'] / t['so3.angle, 10,000 rotations (includes the check)']:.2f}")
    print(f"as_points share of arc_distance on 10,000: "
          f"{2 * t['as_points, 10,000 points'] / t['arc_distance, 10,000 pairs (includes 2 checks)']:.2f}")


if __name__ == "__main__":
    main()
