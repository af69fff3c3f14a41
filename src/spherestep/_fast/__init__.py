"""The fast path: compiled (numba) kernels, sums, descent and integrator, and the glue around ducc0.

The one private package that other rooms may import (docs/conventions.md); no other private name crosses a
room. The public entry points are elsewhere: :func:`spherestep.statics.equilibrium` (and
:func:`~spherestep.statics.descend`) for the descent, :class:`spherestep.dynamics.Integrator` for the
integrator, :class:`spherestep.rotor_field.RotorField` and :func:`~spherestep.rotor_field.fast_evaluate` for the
sums; a torque model hands its energy over as a :class:`Packed` (:meth:`spherestep.statics.TorqueModel.packed_terms`),
nobody probes it.

What is where:

* :mod:`.kernels` — a zonal kernel ``h`` as one flat array (quintic table, angle spline), its sums over the
  rotor's poles at a point (``F``, ``g``, ``Hess F``): :func:`~.kernels.kernel_params`,
  :func:`~.kernels.zonal_fields`;
* :mod:`.spheretable` — a whole rotor function tabulated on a cubed sphere (cubic B-splines per face), the
  kernels' ``"sphere_table"`` kind: the coupled iron model's form (:mod:`spherestep.magnetics._coupling`);
* :mod:`.coupling` — the iron model's rotor functions at many points (pair splines, the coupling through a core
  as a quadratic form per harmonic), which its tables are built from;
* :mod:`.packed` — :class:`Packed`, the arrays a model's energy is handed over in (the terms' kernels, poles,
  coils, currents and constant);
* :mod:`.terms` — a sum of zonal terms evaluated at one orientation or a batch (energy,
  fixed-frame torque, Hessian): :func:`~.terms.terms_evaluate`, :func:`~.terms.batch_evaluate`,
  :func:`~.terms.workspace`;
* :mod:`.synthesis` — loops around ducc0's syntheses for large batches (positions in; energies, torques, ``K(R)``
  out);
* :mod:`.descent` — :func:`spherestep.statics.equilibrium`'s safeguarded Newton descent, row by row;
* :mod:`.integrate` — :meth:`spherestep.dynamics.Rotor.step` repeated under a packed model's torque;
* :mod:`.settle` — the same steps until the rotor is trapped in a well or the dwell ends (the iron planner's
  settling check, :mod:`spherestep.commutation.iron_planner`);
* :mod:`.linear` — a packed model's torque as ``b(R) + K(R) c`` at one orientation, ``K`` and the bias in one call
  (:class:`spherestep.control.ModelCache`: the servo law's model and the simulation's plant);
* :mod:`.allocation` — the allocation's semismooth Newton and the closest reachable torque
  (:func:`spherestep.control.allocation.allocate_matrix`; the NumPy Newton and Clarabel stay the references).
* :mod:`.relays` — one step of the potential planner's bookkeeping (candidate currents, distinct activations,
  the choice; :func:`spherestep.commutation.plan_potential`);
* :mod:`.ironfield` — the iron cores' field at the magnetometers: a magnet's field at the cores' cells and the
  cores' B-spline response table summed over the poles, with its Jacobian (:mod:`spherestep.sensing.iron`);
* :mod:`.threads` — :func:`~.threads.single_blas_thread`, the decorator that runs the package's long entry points
  (equilibria, planners, tuning, simulation, calibration) on one BLAS thread.

Why compiled: for the few points of one orientation (a simulation step, a Newton iteration) the NumPy form costs
~40 array operations whose fixed overhead (1–5 µs each) dominates; the compiled loops cost ~5–12 ns per
(point, pole) pair. numba compiles on first use (seconds), then loads from its on-disk cache (``cache=True`` on
every function). That cache is keyed by each function's own file: after editing a function that another file's
compiled code calls (a kernel used by :mod:`.terms`, :func:`spherestep.so3.exp_entries`), delete the
``__pycache__/*.nbi``/``*.nbc`` files of this package so the callers recompile.

Importing this package loads no numba; its modules do, on first use.
"""

from .packed import Packed

__all__ = ["Packed"]
