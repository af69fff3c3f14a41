"""The prototype's iron pair tables with the rotor's shell (the gap in front of the magnets) 0.3 mm thinner and
thicker than :data:`spherestep.magnetics._iron.ROTOR_SHELL`, by the method of moments (level 0, the nominal
tables' solver), at the nodes of the package's table ``src/spherestep/data/iron_pair_table.csv``.

Writes ``src/spherestep/data/iron_shell_table.csv``: ``alpha_deg`` and ``(detent, linear)`` N·m for the nominal
shell and for each changed shell, all by the same moment method; the mismatched plants of
:mod:`spherestep.control.robustness` add the moment method's change ``MoM(shell) − MoM(nominal)`` at each node
to the FEM-based nominal table. Run: ``python scripts/iron_shell_tables.py`` (minutes: one factorisation, then
3 × the table's angles).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from spherestep.magnetics import _iron as iron
from spherestep.magnetics._ironforce import pair_tables
from spherestep.magnetics._ironmap import read_table
from spherestep.motor import prototype
from spherestep.motor.coil import iron_coil

PACKAGE_DATA = Path(__file__).resolve().parents[1] / "src" / "spherestep" / "data"
CHANGES_MM = (-0.3, 0.3)


def main() -> None:
    design, coil = prototype(), iron_coil()
    nodes_deg = read_table(PACKAGE_DATA / "iron_pair_table.csv")[:, 0]
    inner = (nodes_deg > 0) & (nodes_deg < 180)
    t0 = time.perf_counter()
    iron.core_solver(iron.CoreGeometry.of(design, coil), iron.IRON_LEVEL)
    t1 = time.perf_counter()
    print(f"factorisation {t1 - t0:.1f} s", flush=True)
    cols, names = [nodes_deg], ["alpha_deg"]
    for label, dt_mm in (("nominal", 0.0),) + tuple((f"{d:+.1f}mm", d) for d in CHANGES_MM):
        shell = iron.ROTOR_SHELL + 1e-3 * dt_mm
        det, lin = np.zeros(len(nodes_deg)), np.zeros(len(nodes_deg))
        ts = time.perf_counter()
        det[inner], lin[inner] = pair_tables(design, coil, np.radians(nodes_deg[inner]), iron.IRON_LEVEL, shell=shell)
        print(f"shell {1e3 * shell:.4f} mm ({label}): {time.perf_counter() - ts:.1f} s", flush=True)
        cols += [det, lin]
        names += [f"detent_{label}_Nm", f"linear_{label}_Nm"]
    header = (f"Iron pair torques of the prototype by the method of moments (level {iron.IRON_LEVEL}) with the rotor's "
              f"shell {1e3 * iron.ROTOR_SHELL:.4f} mm (nominal) and {CHANGES_MM[0]:+.1f} / {CHANGES_MM[1]:+.1f} mm.\n"
              "One +1 rotor magnet at angle alpha from one iron coil's axis; torque about the sphere's centre (N m), "
              "positive away from the axis; linear per nominal current; 0 at 0 and 180 deg by symmetry.\n"
              "The plants use FEM-based nominal table + (column for the shell - nominal column), node by node.\n"
              f"factorisation {t1 - t0:.1f} s, total {time.perf_counter() - t0:.1f} s. "
              "Produced by: python scripts/iron_shell_tables.py")
    text = "".join(f"# {line}\n" for line in header.splitlines()) + ",".join(names) + "\n"
    text += "".join(",".join(f"{v:.9g}" for v in row) + "\n" for row in np.column_stack(cols))
    path = PACKAGE_DATA / "iron_shell_table.csv"
    tmp = path.with_suffix(".tmp")
    tmp.write_text(text)
    tmp.replace(path)
    print("wrote", path, flush=True)


if __name__ == "__main__":
    main()
