"""One numbering on every machine (issue 35): the canonical order of caps, its independence of the last bits of the
inputs (which the CPU's BLAS kernel decides) and of their order, the same numbering under two OpenBLAS kernels in
fresh processes, and the fingerprint that refuses a file made for another numbering."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from spherestep import packing as pk
from spherestep.commutation import Plan, turn
from spherestep.errors import InputError
from spherestep.motor import MotorDesign, prototype
from spherestep.sphere import canonical_order, tolerant_ranks

ROOT = Path(__file__).resolve().parents[1]
GALLERY = ROOT / "src" / "spherestep" / "data" / "gallery"
FAMILIES = [name for name in pk.names() if name != "tetrahedron"] + ["tetrahedron"]


def _ulps(rng, x, k: int = 4):
    """``x`` moved by up to ``k`` ulps per coordinate, as another BLAS kernel's rounding would."""
    return x + rng.integers(-k, k + 1, x.shape) * np.spacing(np.abs(x) + 1e-300)


def test_canonical_order_is_north_to_south_then_azimuth():
    """Bands of height from the north pole down; within one, azimuth from just above −π to π (a point on the −x
    side, computed as −π or π by its last bit, is last)."""
    pts = np.array([[0, 0, -1.0], [-1, -0.0, 0], [1, 0, 0], [0, -1, 0], [0, 0, 1.0], [-1, 0.0, 0], [0, 1, 0]])
    pts[5] = [-1, 1e-17, 0]  # the same point as pts[1] up to rounding: both at the seam, both last in the band
    order = canonical_order(np.delete(pts, 5, axis=0))
    assert order.tolist() == [4, 3, 2, 5, 1, 0]  # N pole; equator at −90°, 0°, 90°, 180°; S pole
    assert canonical_order(np.delete(pts, 1, axis=0)).tolist() == [3, 2, 1, 5, 4, 0]


def test_tolerant_ranks_merge_chains_below_the_tolerance():
    v = np.array([0.3, 0.1, 0.1 + 1e-12, 0.2, 0.1 - 1e-12, 0.3 + 5e-8])
    assert tolerant_ranks(v).tolist() == [2, 0, 0, 1, 0, 2]


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(FAMILIES), seed=st.integers(0, 2**32 - 1))
def test_order_ignores_ulps_and_permutations(name, seed):
    """Every named packing refined once: its centres moved by a few ulps and shuffled sort into the same order."""
    rng = np.random.default_rng(seed)
    centres = pk.named(name, 1).centers
    perm = rng.permutation(len(centres))
    shaken = _ulps(rng, centres[perm])
    assert np.array_equal(perm[canonical_order(shaken)], canonical_order(centres))


@settings(max_examples=15, deadline=None)
@given(name=st.sampled_from(["truncated-icosahedron", "truncated-cuboctahedron", "icosidodecahedron", "cube",
                             "truncated-tetrahedron"]), seed=st.integers(0, 2**32 - 1))
def test_refinement_numbers_new_caps_alike_from_shaken_shuffled_input(name, seed):
    """Refinement of a packing whose centres are a few ulps off and listed in another order adds the same new caps
    in the same order (to 1e-9), two levels deep; the old caps keep their (permuted) indices."""
    rng = np.random.default_rng(seed)
    base = pk.named(name, 0)
    perm = rng.permutation(len(base))
    shaken = pk.Packing(_ulps(rng, base.centers[perm]), base.radii[perm], name=base.name, family=base.family)
    want, got = pk.refine(base, levels=2), pk.refine(shaken, levels=2)
    assert np.allclose(got.centers[:len(base)], base.centers[perm], atol=1e-12)
    assert np.allclose(got.centers[len(base):], want.centers[len(base):], atol=1e-9)


_NUMBERING = """
import hashlib, json, numpy as np
from pathlib import Path
from spherestep import packing as pk
from spherestep.motor import MotorDesign, prototype
import threadpoolctl
np.ones((8, 8)) @ np.ones((8, 8))
kernel = [i.get("architecture") for i in threadpoolctl.threadpool_info() if i.get("internal_api") == "openblas"]
out = {"kernel": sorted(set(kernel)), "prototype": prototype().fingerprint}
for f in sorted(Path(GALLERY).glob("*.yaml")):
    out[f.name] = MotorDesign.load(f).fingerprint
for name in pk.names():
    c = pk.named(name, 2).centers
    out[name] = hashlib.sha256(np.rint(1e6 * c).astype(np.int64).tobytes()).hexdigest()[:16]
s = prototype().states()
out["states"] = hashlib.sha256(np.rint(1e6 * s.rotations).astype(np.int64).tobytes()).hexdigest()[:16]
print(json.dumps(out))
"""


def kernels() -> list[str]:
    """The kernel running and another one this CPU can run (``scripts/blas_kernel.py``, as ``make test`` picks it)."""
    spec = importlib.util.spec_from_file_location("blas_kernel", ROOT / "scripts" / "blas_kernel.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    now = module.current()
    return [now, module.other(now)]


def test_same_numbering_under_two_blas_kernels():
    """The prototype, every gallery design, every named packing refined twice and the prototype's 101,640 stepper
    states, each built in a fresh process under two OpenBLAS kernels: the same fingerprints (the issue's failure:
    SkylakeX renumbered the prototype's rotor and the NCSU stator)."""
    runs = []
    for kernel in kernels():
        env = {"OPENBLAS_CORETYPE": kernel, "OPENBLAS_NUM_THREADS": "1", "PATH": "/usr/bin:/bin"}
        done = subprocess.run([sys.executable, "-c", _NUMBERING.replace("GALLERY", repr(str(GALLERY)))],
                              capture_output=True, text=True, env=env, timeout=600)
        assert done.returncode == 0, done.stderr
        runs.append(json.loads(done.stdout))
    for r, kernel in zip(runs, kernels()):  # each ran the kernel it was given (NumPy's and SciPy's OpenBLAS)
        assert r.pop("kernel") == [kernel]
    assert runs[0] == runs[1]
    assert runs[0]["prototype"] == prototype().fingerprint


def test_fingerprint_names_the_numbering_not_the_sizes():
    """Moving a coil index (another stator cap, or another order) changes the fingerprint; a size does not."""
    from dataclasses import replace

    proto = prototype()
    assert replace(proto, air_gap=2 * proto.air_gap).fingerprint == proto.fingerprint
    order = np.arange(len(proto.stator))
    order[[0, 1]] = order[[1, 0]]
    swapped = replace(proto, stator=proto.stator.subset(order))
    assert swapped.fingerprint != proto.fingerprint




def test_a_plan_for_another_numbering_is_refused(tmp_path, capsys):
    """``run --simulate`` (and ``dynamics.simulate``) refuse a plan whose fingerprint is not the design's, and a plan
    of version 1, with one line and exit 2, before anything runs."""
    from spherestep.cli import main

    proto = prototype()
    plan = turn(proto, [1, 0.5, 2], np.radians(10), steps=2)
    assert plan.design_fingerprint == proto.fingerprint
    data = plan.to_dict()
    data["design_fingerprint"] = "sha256:0123456789abcdef"
    path = tmp_path / "plan.json"
    path.write_text(json.dumps(data))
    assert main(["run", str(path), "--simulate", "--rate", "5"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "plan.design_fingerprint must be " + proto.fingerprint in err[0]
    assert "another motor or numbering" in err[0]
    with pytest.raises(InputError, match="plan.design_fingerprint"):
        Plan.from_json(path).check_design(proto)
    data["version"] = 1
    path.write_text(json.dumps(data))
    assert main(["run", str(path), "--dry-run", "--rate", "5"]) == 2
    assert "plan.version must be 2" in capsys.readouterr().err


def test_a_design_file_for_another_numbering_is_refused(tmp_path):
    """A design file that lists cap indices records the fingerprint; edited to another, it is refused naming the
    field; the gallery's index-listing files carry theirs."""
    from spherestep.design_file import DesignFileError

    text = (GALLERY / "ncsu-goldberg.yaml").read_text()
    design = MotorDesign.loads(text)
    assert f"fingerprint: {design.fingerprint}" in text
    with pytest.raises(DesignFileError, match=r"fingerprint must be sha256:[0-9a-f]{16}, the numbering"):
        MotorDesign.loads(text.replace(design.fingerprint, "sha256:0123456789abcdef"))
    listed = prototype().without_coils([3])  # failed coils are named by index: the dump records the numbering
    assert f"fingerprint: {listed.fingerprint}" in listed.dumps()
    assert "fingerprint" not in prototype().dumps()  # named packings and 'fit' only: nothing to renumber


def test_a_calibration_for_another_numbering_is_refused(tmp_path):
    """A calibration file records the fingerprint; one without it (written before) or with another is refused by
    ``design_model(calibration=...)`` naming ``calibration.design_fingerprint``."""
    import yaml

    from spherestep.magnetics.calibrated import Calibration
    from spherestep.magnetics import design_model

    proto = prototype()
    nodes, z = np.linspace(0.0, 0.5, 6), np.zeros(6)
    cal = Calibration(design_model(proto).model, nodes, z + 1, z + 1, z, z, z + 1, z + 1, 1.0, 1.0, (0.0, 0.0), 1.0,
                      0.1, 0.01, 10, 30, (), (), False, "test", design_fingerprint=proto.fingerprint)
    path = cal.save(tmp_path / "calibration.yaml")
    assert yaml.safe_load(path.read_text())["design_fingerprint"] == proto.fingerprint
    for recorded, why in ((None, "has none"), ("sha256:0123456789abcdef", "another motor or numbering")):
        data = yaml.safe_load(path.read_text())
        data["design_fingerprint"] = recorded
        bad = tmp_path / "bad.yaml"
        bad.write_text(yaml.safe_dump(data))
        with pytest.raises(InputError, match=f"calibration.design_fingerprint.*{why}"):
            design_model(proto, calibration=bad)


def test_the_prototypes_stored_tables_are_found():
    """The stored table keyed by the stator's numbering is the prototype's: the sensing cores' table
    (``sensing_iron_cores.npz``) is read, not rebuilt for minutes, as it silently was while another numbering made
    its key miss. (Its per-coil field was re-keyed by geometry; checked once against a live
    ``IronCoilField.build``, 310 s: within 2.7e-5 T of a 1.47e-3 T peak, 2026-11-28.)"""
    from spherestep.sensing import iron
    from spherestep.sensing.placement import default_array

    proto = prototype()
    p = np.ascontiguousarray(default_array(proto).positions)
    stored = iron._stored(iron.design_key(proto), p, iron.GRID_STEP_DEG)
    assert stored is not None and stored[1].shape == (len(proto.stator), len(p), 3)
