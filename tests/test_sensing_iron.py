"""The iron cores' field at the sensors (spherestep.sensing.iron) against direct method-of-moments solves, its
Jacobian, and the Hall estimator on the iron prototype with and without it."""

from __future__ import annotations

from importlib import resources

import numpy as np
import pytest

from spherestep import so3
from spherestep.errors import InputError
from spherestep.motor import prototype
from spherestep.sensing import HallSensor, default_array
from spherestep.sensing import iron


@pytest.fixture(scope="module")
def design():
    return prototype()


@pytest.fixture(scope="module")
def fields(design):
    return iron.iron_fields(design, default_array(design).positions)


def reference():
    path = resources.files("spherestep.data") / "sensing_iron_reference.csv"
    rows = np.array([[float(v) for v in line.split(",")] for line in
                     [ln for ln in path.read_text().splitlines() if ln and not ln.startswith("#")][1:]])
    return rows[:, 2:].reshape(3, 24, 15)  # independent, coupled; the 2-core cluster: independent, coupled, joint


def test_the_prototype_reads_its_stored_table(design, fields):
    """The default array of the prototype finds the stored table (no minute-long build)."""
    core, coils = fields
    assert core.coefficients.shape == (184, 363, 24, 3)
    assert coils.per_coil.shape == (len(design.stator), 24, 3)


def test_a_remarked_rotor_shares_the_stators_table_with_its_own_polarities(design, fields):
    """The table is the stator's response to one magnet: a rotor with one pole reversed (sensing.marked_design)
    reads the same stored table, weighted by its own polarities — its cores' field is the prototype's minus twice
    the marked pole's share — and asking for it leaves the prototype's own fields as they were."""
    from spherestep.sensing import marked_design

    marked = marked_design(design)
    pole = int(np.flatnonzero(marked.polarity != design.polarity)[0])
    mine = iron.iron_fields(marked, default_array(design).positions)[0]
    again = iron.iron_fields(design, default_array(design).positions)[0]
    assert mine.coefficients is again.coefficients  # one table, read once
    R = so3.random(2, 4)
    alone = type(again)(again.coefficients, again.frame, again.step, again.poles[pole:pole + 1],
                        again.polarity[pole:pole + 1])
    np.testing.assert_allclose(mine.field(R), fields[0].field(R) - 2.0 * alone.field(R), atol=1e-9)
    np.testing.assert_array_equal(again.polarity, design.polarity)


def test_cores_field_matches_the_direct_solve(design, fields):
    """The stored table against the whole rotor magnetising every core directly (magpylib at every cell, each core
    solved, the cores magnetising each other through the same dipole coupling, iterated on the polarizations;
    scripts/sensing_iron_table.py reference) at 3 orientations: relative RMS ≤ 1e-3 (measured 2.5e-4), max |ΔB| ≤
    50 µT (measured 21 µT; the part's noise is 100 µT)."""
    ref = reference()[..., 3:6]
    model = fields[0].field(so3.random(3, 26))
    err = model - ref
    assert np.sqrt(np.sum(err ** 2) / np.sum(ref ** 2)) < 1e-3
    assert np.abs(err).max() < 50e-6
    assert np.abs(ref).max() > 5e-3  # the cores' field is real: millitesla at the sensors


def test_dipole_coupling_against_one_moment_system(design):
    """The two cores nearest sensor 8 solved as one moment system against the model's physics (each solved
    alone, coupled through their cells as point dipoles): the coupling takes out ≥ 95 % of the difference
    from the cores solved alone (measured 99.95 %: 0.05 µT RMS left of 110 µT) and leaves ≤ 0.1 % of their field
    (RMS; measured 0.001 %)."""
    ref = reference()
    ind, first, joint = ref[..., 6:9], ref[..., 9:12], ref[..., 12:15]
    left = np.sqrt(np.sum((joint - first) ** 2))
    assert left < 0.05 * np.sqrt(np.sum((joint - ind) ** 2))
    assert left < 1e-3 * np.sqrt(np.sum(joint ** 2))


def test_jacobian_matches_central_differences(fields):
    core = fields[0]
    R = so3.random(1, 3)[0]
    B, J = core.field_and_jacobian(R)
    assert np.allclose(B, core.field(R), atol=1e-12)
    h = 1e-5
    num = np.stack([(core.field(so3.exp(h * e) @ R) - core.field(so3.exp(-h * e) @ R)) / (2 * h)
                    for e in np.eye(3)], axis=-1)
    assert np.abs(num - J).max() < 1e-3 * np.abs(J).max()


def test_field_is_linear_in_the_polarity_and_batched(design, fields):
    core = fields[0]
    R = so3.random(4, 5)
    assert np.allclose(core.field(R)[2], core.field(R[2]), atol=1e-12)


def test_hall_on_iron_models_the_cores_by_default(design):
    """Noiseless readings of the iron motor (rotor + cores + iron coils at 4 currents): the default estimator
    recovers the orientation to 1e-4° from 2° off; the one that ignores the cores is biased by degrees' tenths."""
    rng = np.random.default_rng(0)
    c = np.zeros(len(design.stator))
    c[[1, 5, 9, 20]] = [1.0, -1.0, 1.0, -1.0]
    on = HallSensor(design, noise_T=1e-12, seed=1)
    off = HallSensor(design, noise_T=1e-12, seed=1, cores=False)
    assert on.cores and not off.cores
    errs_on, errs_off = [], []
    for R in so3.random(5, rng):
        R0 = so3.exp(np.radians(2.0) * np.array([0.6, 0.0, 0.8])) @ R
        m = on.readings(R, c)
        errs_on.append(so3.distance(on.estimator.solve(m, R0, c).R, R))
        errs_off.append(so3.distance(off.estimator.solve(m, R0, c).R, R))
    assert np.degrees(max(errs_on)) < 1e-4
    assert np.degrees(np.sqrt(np.mean(np.square(errs_off)))) > 0.1


def test_cores_refused_on_an_air_design(design):
    from dataclasses import replace

    air = replace(design, coil=replace(design.coil, core="air"))
    with pytest.raises(InputError, match="cores"):
        HallSensor(air, cores=True)
    assert HallSensor(air).core_field is None


@pytest.mark.slow
def test_servo_on_the_iron_model_with_the_array_in_the_loop(design):
    """``move --sensor hall`` on the iron prototype (its own model, the cores modelled by default): the array's
    estimate stays within 0.05° (issue 26 §2's RMS target, held here as the worst; measured 0.008° on a 90° turn
    in bench_sensing_iron.py)."""
    import math

    from spherestep.drive import drive_turn

    move = drive_turn(design, [1, 0.5, 2], math.radians(20), sensor="hall").to_dict()
    assert move["details"]["sensor"] == "hall" and move["details"]["sensor_error_max_deg"] < 0.05
    assert move["final_error_deg"] < 0.05
