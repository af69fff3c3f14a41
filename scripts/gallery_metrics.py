"""Measure every gallery entry and store the metrics with the package (src/spherestep/data/gallery/metrics.csv).

    OPENBLAS_NUM_THREADS=1 .venv/bin/python scripts/gallery_metrics.py [--samples 20000] [--capability 500]

Each entry's design file is loaded fresh and measured by ``spherestep.gallery.measure`` (escape check included),
then driven by ``spherestep.gallery.drive_metrics`` (the servo's fastest 360° turn, the settled relay plan); the
timing of each part is printed. The file is written whole or not at all.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from spherestep import gallery
from spherestep.atomic import write_text

OUT = Path(__file__).resolve().parent.parent / "src" / "spherestep" / "data" / "gallery" / "metrics.csv"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=20_000, help="orientations for the resolution")
    parser.add_argument("--capability", type=int, default=500, help="orientations for the torque capability")
    parser.add_argument("--out", type=Path, default=OUT)
    args = parser.parse_args()
    rows = []
    for e in gallery.entries():
        t = time.perf_counter()
        m = gallery.measure(e, samples=args.samples, capability_samples=args.capability, drive=False)
        print(f"{e.key:20s} {m.states:7d} states  {time.perf_counter() - t:6.1f} s  ({m.model})", flush=True)
        design = e.design()
        t = time.perf_counter()
        servo = gallery.drive_metrics(design, relay=False)
        t_servo, t = time.perf_counter() - t, time.perf_counter()
        relay = gallery.drive_metrics(design, servo=False)
        t_relay = time.perf_counter() - t
        notes = [part for n in (servo.note, relay.note) for part in n.split("; ") if part
                 and not part.endswith(": not measured")]  # each run's own reasons, not the part it left out
        servo_part = {k: v for k, v in dataclasses.asdict(servo).items() if k.startswith("servo_")}
        drive = dataclasses.replace(relay, **servo_part, note="; ".join(notes))
        m = dataclasses.replace(m, **drive.measurement_fields())
        turn = "—" if m.servo_turn_s is None else f"{m.servo_turn_s:.3g} s"
        print(f"{'':20s} servo turn {turn} ({t_servo:.1f} s to simulate), relay {m.relay_steps_on_plan}/"
              f"{m.relay_steps} steps on plan ({t_relay:.1f} s)  {m.drive_note or ''}", flush=True)
        rows.append(m)
    write_text(args.out, gallery.metrics_csv(rows))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
