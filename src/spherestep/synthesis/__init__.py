"""Designs for a specification (issue 29; the paper's open problem, Sec. V): from what a builder asks — torque,
speed, precision, size, power, drive, core — to verified design files.

* :mod:`.spec`: the specification file (:func:`load_spec`, :class:`Spec`, :class:`SpecError`);
* :mod:`.ladder`: the candidates (:class:`Candidate`) and the cheap rungs of the fidelity ladder (:func:`evaluate`:
  geometry → states → capability);
* :mod:`.verify`: the top rung, full simulation against every requirement (:func:`verify` → :class:`Verification`);
* :mod:`.run`: the search on Dask (:func:`synthesize` → :class:`SynthesisResult`, :data:`BUDGETS`);
* :mod:`.front`: the Pareto set and the finalists (:func:`objectives`, :func:`pareto`, :class:`Finalist`);
* :mod:`.answer`: the winner and the sentence that says why (:func:`describe_change`);
* :mod:`.outputs`: the files, the Pareto figure and the HTML report.

>>> from spherestep.synthesis import load_spec, synthesize          # doctest: +SKIP
>>> result = synthesize(load_spec("examples/specs/camera-gimbal.yaml"), "out", budget="quick")  # doctest: +SKIP
>>> print(result.statement)                                          # doctest: +SKIP

docs/synthesis.md describes every field of a spec, the ladder, the optimiser and measured results.
"""

from ..lazy import lazy_names

_MODULES = {
    "spec": ("SPEC_VERSION", "Spec", "SpecError", "load_spec", "parse_spec", "validate_spec"),
    "ladder": ("Candidate", "PROTOTYPE", "build", "evaluate", "iron_is_stored", "range_orientations"),
    "verify": ("Check", "Verification", "verify"),
    "run": ("BUDGETS", "Budget", "Ladder", "SynthesisResult", "candidates", "synthesize"),
    "front": ("Finalist", "choose_finalists", "objectives", "pareto"),
    "answer": ("describe_change",),
    "outputs": ("figure_front", "write_outputs"),
}
__getattr__, __dir__, __all__ = lazy_names(__name__, _MODULES)  # noqa: PLE0605  (the one list of names)
