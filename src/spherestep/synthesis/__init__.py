"""Designs for a specification (issue 29; the paper's open problem, Sec. V): from what a builder asks — torque,
speed, precision, size, power, drive, core — to verified design files.

* :mod:`.spec`: the specification file (:func:`load_spec`, :class:`Spec`, :class:`SpecError`);
* :mod:`.ladder`: the candidates (:class:`Candidate`) and the cheap rungs of the fidelity ladder (:func:`evaluate`:
  geometry → states → capability);
* :mod:`.verify`: the top rung, full simulation against every requirement (:func:`verify` → :class:`Verification`);
* :mod:`.run`: the search on Dask (:func:`synthesize` → :class:`SynthesisResult`, :data:`BUDGETS`);
* :mod:`.outputs`: the files, the Pareto figure and the HTML report.

>>> from spherestep.synthesis import load_spec, synthesize          # doctest: +SKIP
>>> result = synthesize(load_spec("examples/specs/camera-gimbal.yaml"), "out", budget="quick")  # doctest: +SKIP
>>> print(result.statement)                                          # doctest: +SKIP

docs/synthesis.md describes every field of a spec, the ladder, the optimiser and measured results.
"""

from importlib import import_module

_MODULES = {
    "spec": ("SPEC_VERSION", "Spec", "SpecError", "load_spec", "parse_spec", "validate_spec"),
    "ladder": ("Candidate", "PROTOTYPE", "build", "evaluate", "iron_is_stored", "range_orientations"),
    "verify": ("Check", "Verification", "verify"),
    "run": ("BUDGETS", "Budget", "Finalist", "Ladder", "SynthesisResult", "candidates", "objectives", "pareto", "synthesize"),
    "outputs": ("figure_front", "write_outputs"),
}
_HOME = {name: module for module, names in _MODULES.items() for name in names}
__all__ = sorted(_HOME)  # noqa: PLE0605  (the lazy table is the one list of names)


def __getattr__(name: str):
    if name not in _HOME:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(import_module(f".{_HOME[name]}", __name__), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))
