"""The pages of ``scripts/docs_numbers.py``: one module per source of stored numbers (the demo, the forces, the
benchmarks, the gallery, the sweep, the potential and dynamics, the hand-measured notes of control.md and
sensing.md), each with the renderers of its blocks and, where it measures, the function that measures;
:mod:`.common` the stores and the formatters they share. The registry of blocks and the command are
``scripts/docs_numbers.py``."""
