"""Design files: lossless save/load, the shipped prototype file, one-line errors that name the field, a fuzz of
malformed files, and the ``spherestep design`` commands."""

import copy
import json
import math
import os
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from hypothesis import event, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from spherestep import design_file as df
from spherestep import packing as pk
from spherestep.cli import main
from spherestep.errors import InputError
from spherestep.motor import MotorDesign, prototype
from spherestep.motor.coil import CoilSpec, IronMaterial, air_coil, iron_coil

BASE = yaml.safe_load(df.prototype_text())


def assert_same(a: MotorDesign, b: MotorDesign, tol: float = 0.0) -> None:
    """Everything a design holds agrees: centres and radii to ``tol``, the rest exactly."""
    for pa, pb in ((a.rotor, b.rotor), (a.stator, b.stator)):
        assert pa.centers.shape == pb.centers.shape
        assert np.max(np.abs(pa.centers - pb.centers), initial=0.0) <= tol
        assert np.max(np.abs(pa.radii - pb.radii), initial=0.0) <= tol
        assert pa.label == pb.label
    assert np.array_equal(a.polarity, b.polarity)
    assert np.array_equal(a.stator_axis, b.stator_axis)
    assert np.array_equal(a.channel_map, b.channel_map)
    for f in ("cap_half_angle", "sphere_diameter", "magnet_diameter", "magnet_length", "coil_diameter", "coil_length",
              "air_gap", "tol", "remanence", "coil_ampere_turns", "name", "allow_hemisphere", "max_coils",
              "failed_coils", "coil"):
        assert getattr(a, f) == getattr(b, f), f


def write(tmp_path: Path, doc, name: str = "motor.yaml") -> Path:
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else yaml.safe_dump(doc), encoding="utf-8")
    return path


def mutate(**changes):
    """The prototype document with ``section__key=value`` changes (``None`` deletes the key)."""
    doc = copy.deepcopy(BASE)
    for key, value in changes.items():
        *parents, leaf = key.split("__")
        target = doc
        for p in parents:
            target = target[p]
        if value is None:
            del target[leaf]
        else:
            target[leaf] = value
    return doc


# --- lossless files ----------------------------------------------------------------------------------------

def test_shipped_prototype_file_builds_the_prototype_bit_for_bit():
    design = MotorDesign.loads(df.prototype_text(), source="prototype.yaml")
    assert_same(design, prototype(), tol=0.0)
    assert (len(design.rotor), len(design.stator)) == (92, 29)
    assert design.polarity[:60].tolist() == [1] * 60 and design.polarity[60:].tolist() == [-1] * 32


def test_the_documented_examples_load():
    page = (Path(__file__).parents[1] / "docs" / "design-files.md").read_text()
    blocks = page.split("```yaml\n")[1:]
    assert len(blocks) == 3
    assert_same(MotorDesign.loads(blocks[0].split("```")[0]), prototype())
    coil = yaml.safe_load(blocks[1].split("```")[0])["coil"]
    air = MotorDesign.loads(yaml.safe_dump(mutate(coil=coil)))
    assert air.coil == CoilSpec(core="air", wire_diameter=0.5e-3, fill_factor=0.55, supply_power=150.0)
    six = yaml.safe_load(blocks[2].split("```")[0])
    design = MotorDesign.loads(yaml.safe_dump(mutate(rotor=six["rotor"])))
    assert design.rotor.label == "six" and np.allclose(np.abs(design.rotor.centers).sum(axis=1), 1, atol=1e-15)


def test_save_then_load_the_prototype_is_identical_and_uses_the_named_forms(tmp_path):
    design = prototype()
    path = design.save(tmp_path / "proto.yaml")
    assert_same(MotorDesign.load(path), design, tol=0.0)
    doc = yaml.safe_load(path.read_text())
    assert doc["rotor"] == {"packing": "truncated-icosahedron", "refine": 1, "polarity": {"primary": 1, "filled": -1}}
    assert doc["stator"]["coils"] == "fit" and doc["stator"]["cap_half_angle"] == "80 deg"
    assert doc["dimensions"] == {"sphere_diameter": "12 in", "magnet_diameter": "1 in", "magnet_length": "0.5 in",
                                 "coil_diameter": "2 in", "coil_length": "1.625 in", "air_gap": "0.005 in",
                                 "rotor_shell": "0.0625 in"}
    assert "channel_map" not in doc and "tolerance" not in doc  # defaults are left out
    assert doc["schema_version"] == 2 and doc["coil"] == {  # the coil as built is always stated
        "core": "iron", "material": {"name": "low-carbon steel (AISI 1010, annealed)",
                                     "relative_permeability": 1000.0, "knee": "1.5 T"},
        "pole_diameter": "1 in", "wall_thickness": "0.125 in", "back_thickness": "0.375 in",
        "wire_diameter": "286 um", "fill_factor": 0.6, "supply_voltage": "24 V", "supply_power": "100 W",
        "coils_on": 4}
    assert [p.name for p in tmp_path.iterdir()] == ["proto.yaml"]  # no temporary file left behind


@settings(max_examples=25, deadline=None)
@given(data=st.data())
def test_save_load_round_trip_of_varied_designs(proto, data):
    base = proto
    n = len(base.stator)
    coils = data.draw(st.lists(st.integers(0, n - 1), min_size=1, max_size=n, unique=True))
    stator = pk.Packing(base.stator.centers[coils], base.stator.radii[coils], name=base.stator.name,
                        family=base.stator.family, level=base.stator.level)
    channels = np.array(data.draw(st.permutations(range(2 * len(coils))))).reshape(len(coils), 2)
    design = replace(
        base, stator=stator, channel_map=channels,
        polarity=np.array(data.draw(st.lists(st.sampled_from([1, -1]), min_size=92, max_size=92))),
        failed_coils=tuple(data.draw(st.lists(st.integers(0, len(coils) - 1), max_size=3))),
        tol=data.draw(st.none() | st.floats(1e-4, 0.49)),
        remanence=data.draw(st.floats(0.1, 2.0)), coil_ampere_turns=data.draw(st.floats(1.0, 1e5)),
        air_gap=data.draw(st.floats(0.0, 1e-3)), name=data.draw(st.text(st.characters(categories=["L", "N", "P", "S", "Zs"]), min_size=1, max_size=12)
                                                     .filter(str.isprintable)),
        max_coils=data.draw(st.integers(len(coils), 64)),
        coil=CoilSpec(core=data.draw(st.sampled_from(["air", "iron"])),
                      material=IronMaterial(relative_permeability=data.draw(st.floats(1.0, 1e5))),
                      wire_diameter=data.draw(st.floats(1e-5, 1e-3)), fill_factor=data.draw(st.floats(0.01, 0.9)),
                      wall_thickness=data.draw(st.floats(0.0, 5e-3)), supply_voltage=data.draw(st.floats(1.0, 1e3)),
                      supply_power=data.draw(st.floats(1.0, 1e4)), coils_on=data.draw(st.integers(1, 29)),
                      ampere_turns=data.draw(st.none() | st.floats(1.0, 1e5))),
    )
    with tempfile.TemporaryDirectory() as tmp:
        back = MotorDesign.load(design.save(Path(tmp) / "d.yaml"))
    assert_same(back, design, tol=0.0)


@pytest.mark.parametrize("coil", [
    air_coil(), replace(iron_coil(), core="air"), iron_coil(fill_factor=0.3, coils_on=6, back_thickness=0.0),
    iron_coil(material=IronMaterial(name="M-19 (datasheet)", relative_permeability=4000.0, knee=1.2,
                                    bh=((0.0, 0.0), (50.0, 0.6), (200.0, 1.3), (3000.0, 1.7)),
                                    source="vendor datasheet, 2024"), supply_voltage=12.5, wire_diameter=0.4e-3),
    CoilSpec(core="air", material=IronMaterial(relative_permeability=50.0)),
], ids=["air_coil", "air-winding", "iron-changed", "iron-own-material", "air-own-material"])
def test_save_then_load_keeps_the_coil(tmp_path, coil):
    design = replace(prototype(), coil=coil)
    back = MotorDesign.load(design.save(tmp_path / "coil.yaml"))
    assert back.coil == coil and back.coil.material.bh == coil.material.bh
    assert_same(back, design)


def test_a_missing_coil_section_is_the_prototypes_iron_coil():
    old = mutate(schema_version=1, coil=None)  # a file of schema version 1
    assert MotorDesign.loads(yaml.safe_dump(old)).coil == iron_coil()
    assert MotorDesign.loads(yaml.safe_dump(mutate(coil=None))).coil == iron_coil()
    assert MotorDesign.loads(yaml.safe_dump(mutate(coil={"core": "air"}))).coil == replace(iron_coil(), core="air")
    text = yaml.safe_dump(mutate(coil={"wire_diameter": "0.286 mm", "material": {"bh": [[0, 0], [100, 1], [900, 2]],
                                                                                  "knee": 1.1}}))
    coil = MotorDesign.loads(text).coil
    assert coil.wire_diameter == pytest.approx(0.286e-3, rel=1e-15) and coil.material.knee == 1.1
    assert coil.material.bh == ((0.0, 0.0), (100.0, 1.0), (900.0, 2.0)) and hash(coil)


def test_explicit_poles_and_coil_directions_round_trip_to_1e12(tmp_path):
    base = prototype()
    turn = Rotation.from_rotvec([0.1, -0.2, 0.3]).as_matrix()
    rotor = pk.Packing(base.rotor.centers @ turn.T, base.rotor.radii, name="turned")
    stator = pk.Packing(base.stator.centers[:7], np.full(7, 0.15), name="seven")
    design = replace(base, rotor=rotor, stator=stator, channel_map=None, polarity=-base.polarity)
    path = design.save(tmp_path / "explicit.yaml")
    doc = yaml.safe_load(path.read_text())
    assert len(doc["rotor"]["poles"]) == 92 and doc["rotor"]["polarity"] == (-base.polarity).tolist()
    assert "packing" not in doc["stator"] and len(doc["stator"]["coils"]) == 7
    assert_same(MotorDesign.load(path), design, tol=1e-12)


def test_hand_written_angles_units_and_toml(tmp_path):
    text = """
schema_version: 1
name: small
rotor:
  poles: [[0, 0, 1], {phi: 90 deg, theta: 90 deg}, {phi: 3.141592653589793 rad, theta: 90 deg}]
  polarity: [1, -1, 1]
stator:
  axis: {phi: 0 deg, theta: 180 deg}
  cap_half_angle: 1 rad
  coils: [[0, 0, -1], {phi: 45 deg, theta: 150 deg, radius: 5 deg}]
dimensions: {sphere_diameter: 304.8 mm, magnet_diameter: 1 in, magnet_length: 1 cm, coil_diameter: 2 in,
             coil_length: 0.1 ft, air_gap: 0 mm}
tolerance: 2 deg
remanence: 1200 mT
channel_map: [[5, 6], [7, 8]]
failed_coils: [1]
"""
    design = MotorDesign.load(write(tmp_path, text))
    assert np.allclose(design.rotor.centers, [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], atol=1e-15)
    assert np.allclose(design.stator_axis, [0, 0, -1], atol=1e-15)
    s = math.sin(math.radians(150))
    assert np.allclose(design.stator.centers[1], [s * math.sqrt(0.5), s * math.sqrt(0.5), -math.sqrt(0.75)],
                       atol=1e-15)
    assert design.stator.radii[0] == design.coil_angle and design.stator.radii[1] == math.radians(5)
    assert np.all(design.rotor.radii == design.magnet_angle)
    assert design.sphere_diameter == 304.8e-3 and design.magnet_length == 0.01 and design.air_gap == 0.0
    assert design.coil_length == 0.1 * 0.3048 and design.cap_half_angle == 1.0
    assert design.tol == math.radians(2) and design.remanence == 1.2
    assert design.channel_map.tolist() == [[5, 6], [7, 8]] and design.failed_coils == (1,)
    toml = """
schema_version = 1
name = "small"
[rotor]
packing = "truncated-icosahedron"
refine = 1
polarity = {primary = 1, filled = -1}
[stator]
packing = "truncated-cuboctahedron"
refine = 1
axis = [0, 0, -1]
cap_half_angle = "80 deg"
coils = "fit"
[dimensions]
sphere_diameter = "12 in"
magnet_diameter = "1 in"
magnet_length = "0.5 in"
coil_diameter = "2 in"
coil_length = "1.625 in"
air_gap = "0.005 in"
"""
    from_toml = MotorDesign.load(write(tmp_path, toml, "motor.toml"))
    assert_same(from_toml, replace(prototype(), name="small"))


def test_overrides_lift_the_hemisphere_and_coil_limits(tmp_path):
    wide = mutate(stator__cap_half_angle="100 deg", stator__refine=2, dimensions__coil_diameter="1 in")
    with pytest.raises(df.DesignFileError) as err:
        MotorDesign.load(write(tmp_path, wide))
    assert err.value.field == "stator.cap_half_angle" and "overrides.allow_hemisphere" in str(err.value)
    wide["overrides"] = {"allow_hemisphere": True}
    with pytest.raises(df.DesignFileError) as err:
        MotorDesign.load(write(tmp_path, wide))
    assert err.value.field == "stator.coils" and "overrides.max_coils" in str(err.value)
    count = int(str(err.value).split("instead received '")[1].split()[0])
    assert count > 32
    wide["overrides"]["max_coils"] = count
    design = MotorDesign.load(write(tmp_path, wide))
    assert len(design.stator) == count and design.allow_hemisphere and design.max_coils == count
    assert design.cap_half_angle == math.radians(100)
    assert_same(MotorDesign.load(design.save(tmp_path / "wide.yaml")), design)


# --- bad files ---------------------------------------------------------------------------------------------

BAD = [
    (mutate(dimensions__air_gap=None), "dimensions.air_gap", "is missing; add it; for example air_gap: 0.005 in"),
    (mutate(stator__colis="fit"), "stator.colis", "not a known key"),
    (mutate(stator__colis="fit", stator__coils=None), "stator.colis", "not a known key"),  # misspelt, not missing
    (mutate(stator__cap_half_angle="80 in"), "stator.cap_half_angle", "unit deg or rad"),
    (mutate(dimensions__sphere_diameter=0.3), "dimensions.sphere_diameter", "with its unit, like '12 in'"),
    (mutate(dimensions__coil_length="2 furlongs"), "dimensions.coil_length", "unit one of m, cm, mm"),
    (mutate(stator__cap_half_angle="95 deg"), "stator.cap_half_angle", "overrides.allow_hemisphere"),
    (mutate(stator__cap_half_angle="180 deg"), "stator.cap_half_angle", "between 0 and π radians (0° and 180°)"),
    (mutate(dimensions__magnet_diameter="3 in"), "rotor", "overlap"),
    (mutate(dimensions__magnet_diameter="13 in"), "dimensions.magnet_diameter", "smaller than the sphere_diameter"),
    (mutate(rotor={"poles": [[0, 0, 1], [0, 1.1, 0]], "polarity": [1, -1]}), "rotor.poles[1]", "divide it by its norm"),
    (mutate(rotor={"poles": [[0, 0, 1], [0, float("nan"), 1]], "polarity": [1, -1]}), "rotor.poles[1].y",
     "finite number"),
    (mutate(rotor={"poles": [[0, 0, 1], [0, 0, 1]], "polarity": [1, -1]}), "rotor", "overlap"),
    (mutate(rotor={"poles": [[0, 0, 1], {"x": 1, "phi": "3 deg"}], "polarity": [1, -1]}), "rotor.poles[1]",
     "not a mix"),
    (mutate(rotor={"poles": [[0, 1]], "polarity": [1]}), "rotor.poles[0]", "three numbers"),
    (mutate(rotor__refine="one"), "rotor.refine", "valid integer"),
    (mutate(rotor__refine=10 ** 30), "rotor.refine", "less than or equal to 4"),
    (mutate(rotor__packing="football"), "rotor.packing", "spherestep packings --all"),
    (mutate(rotor__poles=[[0, 0, 1]]), "rotor", "either packing"),
    (mutate(rotor__polarity=[1, -1]), "rotor.polarity", "92 values, each +1 or -1"),
    (mutate(rotor__polarity=[1, 2]), "rotor.polarity[1]", "1 or -1"),
    (mutate(rotor__polarity="plus"), "rotor.polarity", "{primary: +1, filled: -1}"),
    (mutate(stator__coils="all"), "stator.coils", "'fit', a list of cap indices"),
    (mutate(stator__coils=[0, 1, 900]), "stator.coils[2]", "cap index 0..73"),
    (mutate(stator__coils=[60, 61, 61]), "stator.coils[2]", "cap 61 repeats"),
    (mutate(stator__coils=[0]), "stator.coils[0]", "a coil within the stator cap"),
    (mutate(stator__coils=[[0, 0, -1]]), "stator", "takes no packing"),
    (mutate(stator__axis=[0, 0, -1.5]), "stator.axis", "unit vector"),
    (mutate(dimensions__coil_diameter="6 in"), "stator.coils", "selecting at least one cap"),
    (mutate(stator__refine=3, stator__cap_half_angle="89 deg", dimensions__coil_diameter="0.5 in"), "stator.coils",
     "overrides.max_coils"),
    (mutate(schema_version=3), "schema_version", "must be 1 or 2"),
    (mutate(schema_version=None), "schema_version", "schema_version: 2"),
    (mutate(schema_version=1), "coil", "set schema_version: 2"),
    (mutate(coil__core="copper"), "coil.core", "must be 'air' or 'iron'; instead received 'copper'"),
    (mutate(coil__colour="red"), "coil.colour", "not a known key"),
    (mutate(coil__fill_factor=1.2), "coil.fill_factor", "a copper fraction in (0, 0.907]"),
    (mutate(coil__fill_factor="0.6"), "coil.fill_factor", "valid number"),
    (mutate(coil__wire_diameter=0.0003), "coil.wire_diameter", "with its unit, like '12 in'"),
    (mutate(coil__wall_thickness="-1 mm"), "coil.wall_thickness", "non-negative length"),
    (mutate(coil__supply_voltage="24 A"), "coil.supply_voltage", "a voltage with unit one of V, mV, kV"),
    (mutate(coil__supply_power="-5 W"), "coil.supply_power", "finite positive power"),
    (mutate(coil__coils_on=0), "coil.coils_on", "greater than or equal to 1"),
    (mutate(coil__ampere_turns=0), "coil.ampere_turns", "greater than 0"),
    (mutate(coil__material__relative_permeability=0.5), "coil.material.relative_permeability", ">= 1"),
    (mutate(coil__material__knee="9 T"), "coil.material.knee", "inside the B–H curve's range"),
    (mutate(coil__material__bh=[[0, 0], [10, 1], [5, 2]]), "coil.material.bh", "strictly increasing"),
    (mutate(coil__material__bh=[[0, 0, 1], [10, 1]]), "coil.material.bh[0]", "at most 2 items"),
    (mutate(coil__material="steel"), "coil.material", "mapping of keys"),
    (mutate(tolerance="45 deg"), "tolerance", "between 0 and 0.5 radians (0° and 28.65°)"),
    (mutate(channel_map=[[0, 1]]), "channel_map", "29 pairs"),
    (mutate(failed_coils=[40]), "failed_coils", "coil indices 0..28"),
    (mutate(name=5), "name", "valid string"),
    (mutate(name="two\nlines"), "name", "printable text on one line"),
    (mutate(remanence="1.3 G"), "remanence", "with unit one of T, mT"),
    (mutate(coil_ampere_turns=float("inf")), "coil_ampere_turns", "finite number"),
    (mutate(overrides={"max_coils": "many"}), "overrides.max_coils", "valid integer"),
]


@pytest.mark.parametrize("doc, field, words", BAD, ids=[b[1] + ":" + b[2][:24] for b in BAD])
def test_bad_fields_are_named_with_the_fix(tmp_path, doc, field, words):
    path = write(tmp_path, doc)
    with pytest.raises(df.DesignFileError) as err:
        MotorDesign.load(path)
    message = str(err.value)
    assert isinstance(err.value, InputError) and err.value.field == field
    assert message.startswith(f"{path}: ") and field in message and words in message and "\n" not in message


@pytest.mark.parametrize("content, words", [
    (b"", "is empty"), (b"# only a comment\n", "is empty"), (b"\x00\x01\x02binary", "binary file"),
    (b"\xff\xfe\xfa not utf-8", "not UTF-8"), (b"schema_version: 1\nrotor: [1, 2\n", "YAML syntax error at line 3"),
    (b"schema_version: 1\nschema_version: 1\n", "duplicate key 'schema_version'"),
    (b"- 1\n- 2\n", "mapping of keys"), (b"just words", "mapping of keys"),
    (b"schema_version: 2001-13-45\n", "not valid YAML"),
    (b"schema_version: 1\nrotor: &a [*a]\n", "rotor must be a mapping of keys; instead received [[...]]"),
])
def test_unreadable_files_give_one_line(tmp_path, content, words):
    path = tmp_path / "bad.yaml"
    path.write_bytes(content)
    with pytest.raises(df.DesignFileError) as err:
        MotorDesign.load(path)
    assert words in str(err.value) and "\n" not in str(err.value)


def test_missing_folder_and_toml_errors(tmp_path):
    for path, words in ((tmp_path / "nope.yaml", "does not exist"), (tmp_path, "is a folder")):
        with pytest.raises(df.DesignFileError, match=words):
            MotorDesign.load(path)
    with pytest.raises(df.DesignFileError, match="TOML syntax error"):
        MotorDesign.load(write(tmp_path, "schema_version = = 1", "x.toml"))


def test_save_writes_nothing_for_a_design_load_would_refuse(tmp_path):
    base = prototype()
    with pytest.raises(df.DesignFileError, match="written as YAML"):
        base.save(tmp_path / "motor.toml")
    overlapping = replace(base, magnet_diameter=0.08)
    target = tmp_path / "motor.yaml"
    target.write_text("keep me")
    with pytest.raises(InputError, match="overlap"):
        overlapping.save(target)
    assert target.read_text() == "keep me" and sorted(p.name for p in tmp_path.iterdir()) == ["motor.yaml"]


# --- fuzz --------------------------------------------------------------------------------------------------

JUNK = st.one_of(
    st.none(), st.booleans(), st.integers(-10 ** 30, 10 ** 30), st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12), st.binary(max_size=8), st.lists(st.integers(-3, 80), max_size=4),
    st.dictionaries(st.text(max_size=4), st.integers(-2, 2), max_size=2),
    st.sampled_from(["80 deg", "12 in", "-1 in", "nan deg", "1e999 in", "fit", "truncated-icosahedron", "0 deg",
                     "95 deg", "1 rad", "0.5 in", [0, 0, 1], [0, 0, 2], {"primary": -1}, 0, 1, 2, 5, -1]),
)


def _paths(node, prefix=()):
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        yield prefix + (key,)
        yield from _paths(value, prefix + (key,))


@st.composite
def malformed(draw):
    """Bytes of a mutated prototype file, and the suffix to store them under."""
    doc = copy.deepcopy(BASE)
    for _ in range(draw(st.integers(1, 3))):
        paths = list(_paths(doc))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["delete", "replace", "replace", "add"]))
        if action == "delete":
            del parent[path[-1]]
        elif action == "replace":
            parent[path[-1]] = copy.deepcopy(draw(JUNK))
        elif isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=6))] = copy.deepcopy(draw(JUNK))
    text = yaml.safe_dump(doc, sort_keys=False)
    form = draw(st.sampled_from(["yaml", "yaml", "truncated", "spliced", "bytes", "toml"]))
    if form == "truncated":
        text = text[:draw(st.integers(0, len(text)))]
    elif form == "spliced":
        at = draw(st.integers(0, len(text)))
        text = text[:at] + draw(st.text(max_size=10)) + text[at:]
    elif form == "bytes":
        return draw(st.binary(max_size=300)), ".yaml"
    return text.encode("utf-8", "surrogatepass"), ".toml" if form == "toml" else ".yaml"


@pytest.mark.slow
@settings(max_examples=1000, deadline=None)
@given(case=malformed())
def test_fuzz_malformed_files_give_a_design_or_one_input_error(case):
    content, suffix = case
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / f"fuzz{suffix}"
        path.write_bytes(content)
        try:
            result = MotorDesign.load(path)
        except df.DesignFileError as exc:
            assert str(exc).startswith(f"{path}: ") and "\n" not in str(exc)
            event(f"error in {(exc.field or 'the file').split('.')[0].split('[')[0][:20]}")
        else:
            assert isinstance(result, MotorDesign) and len(result.stator) <= result.max_coils
            event("valid design")
        assert os.listdir(tmp) == [path.name]


# --- the commands ------------------------------------------------------------------------------------------

def one_line_error(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("spherestep: error:") and "Traceback" not in err
    return err


def test_design_new_with_a_core_and_show(tmp_path, capsys):
    path = tmp_path / "air.yaml"
    assert main(["design", "new", str(path), "--core", "air"]) == 0
    assert "(air core)" in capsys.readouterr().out
    design = MotorDesign.load(path)
    assert design.coil == replace(iron_coil(), core="air")
    assert_same(design, replace(prototype(), coil=design.coil))
    assert main(["design", "show", str(path)]) == 0
    out = capsys.readouterr().out
    assert "coil core" in out and " air " in out and "coil turns" in out and "2824" in out
    assert main(["design", "show", str(path), "--json"]) == 0
    coil = json.loads(capsys.readouterr().out)["coil"]
    assert coil == design.coil.electrics(design.coil_diameter, design.coil_length) and coil["core"] == "air"
    back = tmp_path / "iron.yaml"
    assert main(["design", "new", str(back), "--from", str(path), "--core", "iron"]) == 0
    assert MotorDesign.load(back).coil == iron_coil()
    capsys.readouterr()
    assert main(["design", "new", str(tmp_path / "c.yaml"), "--core", "copper"]) == 2
    assert "--core must be air or iron; instead received 'copper'" in one_line_error(capsys)
    assert not (tmp_path / "c.yaml").exists()


def test_design_show_says_when_the_winding_does_not_fit(tmp_path, capsys):
    path = write(tmp_path, mutate(dimensions__coil_length="0.25 in"))  # shorter than the back plate
    assert main(["design", "show", str(path), "--json"]) == 0
    coil = json.loads(capsys.readouterr().out)["coil"]
    assert coil["core"] == "iron" and "centre pole narrower than the groove" in coil["winding"]


def test_design_new_validate_show(tmp_path, capsys):
    path = tmp_path / "motor.yaml"
    assert main(["design", "new", str(path)]) == 0
    assert path.read_text() == df.prototype_text()
    capsys.readouterr()
    assert main(["design", "new", str(path)]) == 2
    assert "--force" in one_line_error(capsys)
    assert main(["design", "new", str(path), "--force"]) == 0
    copy_path = tmp_path / "copy.yaml"
    assert main(["design", "new", str(copy_path), "--from", str(path)]) == 0
    assert_same(MotorDesign.load(copy_path), prototype())
    capsys.readouterr()
    assert main(["design", "validate", str(path)]) == 0
    assert capsys.readouterr().out == ("valid: 92 poles, 29 coils\niron: rotor shell 1.5875 mm; model from the "
                                       "prototype's FEM tables scaled by the law (s = 1): ready at once\n")
    assert main(["design", "show", str(path), "--json"]) == 0
    assert json.loads(capsys.readouterr().out) == json.loads(json.dumps(prototype().summary()))
    assert main(["design", "show", str(path)]) == 0
    out = capsys.readouterr().out
    assert "truncated-icosahedron/L1" in out and "304.8" in out


def test_design_commands_refuse_bad_input_in_one_line(tmp_path, capsys):
    bad = write(tmp_path, mutate(stator__cap_half_angle="95 deg"))
    for args, words in ((["design", "validate", str(bad)], "stator.cap_half_angle"),
                        (["design", "show", str(bad)], "stator.cap_half_angle"),
                        (["design", "validate", str(tmp_path / "none.yaml")], "must be an existing file"),
                        (["design", "new", str(tmp_path / "x.toml")], "written as YAML"),
                        (["design", "new", str(tmp_path / "y.yaml"), "--from", str(bad)], "stator.cap_half_angle"),
                        (["design", "new", str(tmp_path)], "is a folder")):
        assert main(args) == 2, args
        assert words in one_line_error(capsys)
    assert not (tmp_path / "x.toml").exists() and not (tmp_path / "y.yaml").exists()


@pytest.mark.parametrize("command", [["design"], ["design", "new"], ["design", "validate"], ["design", "show"]])
def test_design_help_has_an_example(command, capsys):
    assert main(command + ["--help"]) == 0
    assert "Example: spherestep design" in capsys.readouterr().out


@pytest.mark.slow
def test_plan_uses_the_design_file(tmp_path, capsys):
    doc = mutate(name="rewired", channel_map=[[k, 63 - k] for k in range(29)])
    path = write(tmp_path, doc)
    out = tmp_path / "plan"
    assert main(["plan", "--axis", "0,1,1", "--angle", "20", "--steps", "3", "--planner", "geometric", "--out",
                 str(out), "--json", "--design", str(path)]) == 0
    assert json.loads(capsys.readouterr().out)["steps"] == 3
    plan = json.loads((out / "plan.json").read_text())
    assert plan["design"] == "rewired"
    assert [[c["enable"], c["polarity"]] for c in plan["channel_map"]] == doc["channel_map"]
    assert main(["plan", "--axis", "0,1,1", "--angle", "20", "--out", str(tmp_path / "x"),
                 "--design", str(write(tmp_path, mutate(rotor__refine=9), "bad.yaml"))]) == 2
    assert "rotor.refine" in one_line_error(capsys)
    assert not (tmp_path / "x").exists()
