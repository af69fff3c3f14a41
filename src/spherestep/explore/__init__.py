"""Design-space sweeps: rotor × stator packings, refinement, stator cap and tolerance, on Dask (Sec. II-B-3).

>>> from spherestep.explore import ResultStore, default_grid, dask_client, run_sweep   # doctest: +SKIP
>>> with dask_client(workers=2) as client:                                              # doctest: +SKIP
...     run_sweep(default_grid().points(), ResultStore("out/results"), client)

See ``docs/explore.md`` for the grid, the pairing rule and measured results.

The public names are loaded from their modules on first use, so importing the package (as every
``spherestep`` command does, through the CLI) does not import pandas, pyarrow or Dask.
"""

from ..lazy import lazy_names

_MODULES = {
    "build": ("LIMIT_STATUSES", "STATUSES", "Limits", "Unbuildable", "build_design", "candidate_count",
              "evaluate", "holding_torques", "iron_is_stored", "torque_capability_sample", "unmeasured_iron", "lookup_voxels", "motor_fingerprint", "part_sizes"),
    "grid": ("CORES", "DesignPoint", "Grid", "default_grid", "distinct_names", "primary_ratio", "quick_grid",
             "symmetry_family"),
    "pareto": ("CAPABILITY", "OBJECTIVES", "TORQUE", "eligible", "figure_pareto", "objectives", "pareto_front",
               "pareto_mask"),
    "outputs": ("Proposal", "design_file_name", "propose", "write_designs", "write_table"),
    "run": ("SweepSummary", "dask_client", "finished_keys", "run_sweep"),
    "store": ("COLUMNS", "MEASURED", "SCHEMA", "ResultStore"),
}
__getattr__, __dir__, __all__ = lazy_names(__name__, _MODULES)  # noqa: PLE0605  (the one list of names)
