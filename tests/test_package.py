"""The package's front door (issue 12 §1, §6): every room reachable from ``import spherestep``, the heavy ones
loaded only on use, and BLAS limited to one thread inside the numerical entry points."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

HEAVY = ("magpylib", "matplotlib", "plotly", "dask", "distributed", "serial", "trimesh", "pyarrow", "pandas")


def _run(code: str) -> str:
    return subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True).stdout


def test_import_loads_no_heavy_library():
    loaded = json.loads(_run(f"import sys, json, spherestep; print(json.dumps([m for m in {HEAVY!r} "
                             "if m in sys.modules]))"))
    assert loaded == []


def test_every_room_is_reachable_from_the_top():
    import spherestep as ss

    assert ss.motor.prototype().name
    for room in ss.__all__:
        assert getattr(ss, room).__name__ == f"spherestep.{room}"
    for room in ss.PLUMBING:  # reachable, not advertised (issue 36 §6)
        assert getattr(ss, room).__name__ == f"spherestep.{room}" and room not in ss.__all__
    assert set(ss.__all__) <= set(dir(ss)) and not set(ss.PLUMBING) & set(dir(ss))
    assert ss.magnetics.TorqueMap is not None and ss.statics.TorqueModel is not None
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        ss.nonexistent  # noqa: B018


def test_entry_points_run_on_one_blas_thread_and_restore_the_callers_setting(proto):
    from threadpoolctl import threadpool_info, threadpool_limits

    from spherestep.magnetics import torque_map
    from spherestep.potential import coil_currents
    from spherestep.statics import equilibrium

    tmap = torque_map(proto)
    seen = []

    class Spy(type(tmap)):
        def evaluate(self, R, currents, order):
            seen.append(max(lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas"))
            return super().evaluate(R, currents, order)

    spy = Spy(*(getattr(tmap, f) for f in tmap.__dataclass_fields__))
    states = proto.states()
    with threadpool_limits(2, user_api="blas"):
        equilibrium(spy, states.rotations[:2], np.stack([coil_currents(proto, states.coils(i)) for i in range(2)]),
                    compiled=False)  # the NumPy descent calls evaluate (the compiled one does not)
        after = max(lib["num_threads"] for lib in threadpool_info() if lib["user_api"] == "blas")
    assert seen and max(seen) == 1
    assert after == 2
