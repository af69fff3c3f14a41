"""The outputs of a sweep: the results table, the Pareto set, its figure, and the proposed designs' files.

Every file is written whole (a temporary file renamed into place). The design files of the Pareto set are
written into a fresh folder that then replaces ``designs/`` in one rename, so the folder never mixes the
proposals of two runs.
"""

from __future__ import annotations

import os
import secrets
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from .. import plots
from ..atomic import atomic_path
from .build import Limits, build_design
from .grid import DesignPoint
from .pareto import figure_pareto, pareto_front


def design_file_name(rank: int, row) -> str:
    """``NN-rotor-Lr-stator-Ls-capC-tolT.yaml`` for the ``rank``-th proposal (1-based)."""
    return (f"{rank:02d}-{row['rotor']}-L{row['rotor_level']}-{row['stator']}-L{row['stator_level']}"
            f"-cap{row['cap_half_angle_deg']:g}-tol{row['tol_deg']:g}.yaml")


def write_designs(front: pd.DataFrame, folder: str | Path, limits: Limits = Limits()) -> list[Path]:
    """Rebuild each design of ``front`` from its stored parameters and save its design file into ``folder``
    (replacing the folder's previous contents as a whole); returns the paths, in the order of ``front``."""
    folder = Path(folder)
    folder.parent.mkdir(parents=True, exist_ok=True)
    fresh = Path(tempfile.mkdtemp(prefix=f".{folder.name}-new-", dir=folder.parent))
    umask = os.umask(0)
    os.umask(umask)
    fresh.chmod(0o777 & ~umask)  # mkdtemp makes 0700; give the folder the usual permissions
    names = []
    try:
        for rank, (_, row) in enumerate(front.iterrows(), start=1):
            point = DesignPoint.from_params(row["params"])
            design = build_design(point, limits, name=f"explore #{rank}: {point.label}")
            name = design_file_name(rank, row)
            design.save(fresh / name)
            names.append(name)
        old = None
        if folder.exists():
            old = folder.rename(folder.parent / f".{folder.name}-old-{secrets.token_hex(4)}")
        fresh.rename(folder)
    except BaseException:
        shutil.rmtree(fresh, ignore_errors=True)
        raise
    if old is not None:
        shutil.rmtree(old)
    return [folder / n for n in names]


def write_table(table: pd.DataFrame, path: str | Path) -> Path:
    """``table`` as CSV (``.csv``) or Parquet (``.parquet``), atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        if path.suffix == ".parquet":
            table.to_parquet(tmp, index=False)
        else:
            table.to_csv(tmp, index=False)
    return path


@dataclass
class Proposal:
    """The Pareto set of a sweep and the files written for it."""

    front: pd.DataFrame
    results: Path
    pareto: Path
    figure: Path
    designs: list[Path]


def propose(table: pd.DataFrame, out: str | Path, limits: Limits = Limits(),
            require_reach_all: bool = True) -> Proposal:
    """Write ``results.csv`` (every design of ``table``), ``pareto.csv`` and ``pareto.png`` (the Pareto set
    within the coil budget) and ``designs/`` (one design file per member) into ``out``."""
    out = Path(out)
    front = pareto_front(table, limits.budget_coils, require_reach_all)
    designs = write_designs(front, out / "designs", limits)
    front = front.assign(design_file=[str(p.relative_to(out)) for p in designs])
    fig = figure_pareto(table, front, limits.budget_coils)
    return Proposal(front=front, results=write_table(table, out / "results.csv"),
                    pareto=write_table(front, out / "pareto.csv"),
                    figure=plots.save_figure(fig, out / "pareto.png"), designs=designs)
