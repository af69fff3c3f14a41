"""The rotor identified from its moves (issue 37 §1): inertia, damping and friction by the windowed rigid-body
equation (spherestep.dynamics.identify) on plants with known values; the fit was developed on seed 0's moves,
these run seeds 11 and 1."""

from dataclasses import replace

import numpy as np
import pytest

from spherestep.drive.records import record_moves
from spherestep.dynamics import Rotor
from spherestep.dynamics.identify import fit_rotor, rotor_excitation
from spherestep.errors import InputError
from spherestep.magnetics import design_model
from spherestep.magnetics.percoil import PerCoil


@pytest.fixture(scope="module")
def own(proto):
    return design_model(proto)


@pytest.fixture(scope="module")
def plant_rotor(proto):
    return Rotor(1.3 * Rotor.from_design(proto).inertia, damping=0.04, friction=0.04)


def test_excitation_moves():
    moves = rotor_excitation(speeds=(1.0, 3.0), repeats=2, seed=4)
    assert len(moves) == 4
    for a, b in zip(moves, moves[1:]):
        assert np.allclose(a.end, b.start)
    peak = [max(np.linalg.norm(m.sample(np.linspace(0, m.duration, 400))[1], axis=1)) for m in moves]
    assert peak == pytest.approx([1.0, 3.0, 1.0, 3.0], rel=1e-3)


def test_simulated_servo_recovers_the_rotor(proto, own, plant_rotor):
    """The simulated servo (fourth-order integrator, exact dissipation flows) on the ×1.3 rotor with damping and
    friction, the controller believing the design's rotor: the fit recovers each within 1 % (measured ~1e-4), a
    current lag of zero (the simulation's currents are the period's means), and the moves it did not fit have
    the same residual as those it did; with a model whose winding is 3 % strong, the damping or the friction leaks
    by more than 20 % (the friction +69 %, measured) unless ``winding=True`` fits the factor (then 1/1.03 within
    0.2 %, the rotor within 2 %)."""
    moves = rotor_excitation(seed=11, repeats=1, speeds=(1.0, 2.5, 5.0, 1.5))
    series = record_moves(proto, moves, plant_rotor=plant_rotor)
    fit = fit_rotor(own.model, series[:3], lag=True)
    assert fit.inertia == pytest.approx(plant_rotor.inertia, rel=0.01)
    assert fit.damping == pytest.approx(plant_rotor.damping, rel=0.01)
    assert fit.friction == pytest.approx(plant_rotor.friction, rel=0.01)
    assert abs(fit.current_lag) < 2e-5
    assert all(s < 0.01 * v for s, v in zip(fit.std, (fit.inertia, fit.damping, fit.friction)))
    assert fit.residual(own.model, series[3:]) < 5 * fit.sigma
    wrong = Rotor(plant_rotor.inertia / 1.3, 0.0, 0.0)  # the design's rotor does not explain the moves
    assert replace(fit, inertia=wrong.inertia, damping=0.0, friction=0.0).residual(own.model, series[3:]) > 20 * fit.sigma
    # a model whose winding is 3 % strong (its detent right): damping and friction leak unless its factor is fitted
    strong = PerCoil(own.model, np.full(own.model.coil_count, 1.03))
    leaky = fit_rotor(strong, series[:3], lag=True)
    assert max(abs(leaky.damping / plant_rotor.damping - 1), abs(leaky.friction / plant_rotor.friction - 1)) > 0.2
    fixed = fit_rotor(strong, series[:3], lag=True, winding=True)
    assert fixed.winding_scale == pytest.approx(1 / 1.03, rel=2e-3)
    for value, true in zip((fixed.inertia, fixed.damping, fixed.friction), (plant_rotor.inertia, plant_rotor.damping,
                                                                             plant_rotor.friction)):
        assert value == pytest.approx(true, rel=0.02)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, reason="issue 37, open: since the emulated coils have their back-EMF (issue 36 §3, "
                   "merged 2026-11-28 19:00) the fit from the commanded currents reads damping 0.080-0.082 N·m·s for "
                   "0.04 and friction 0.006-0.008 N·m for 0.04 (speeds 1/2.5/5 and 1/1.75/2.5 rad/s alike: not the "
                   "supply's limit); inertia stays within 2 %")
def test_emulated_motor_recovers_the_rotor(proto, own, plant_rotor):
    """The emulated motor in lockstep (the magnetometers' estimate, the commanded currents, the device's current
    loop): inertia within 5 %, damping and friction within 20 %, each within three of its standard deviations."""
    moves = rotor_excitation(seed=1, repeats=2)
    fit = fit_rotor(own.model, record_moves(proto, moves, plant_rotor=plant_rotor, emulate=True), lag=True)
    truth = (plant_rotor.inertia, plant_rotor.damping, plant_rotor.friction)
    for value, std, true, tol in zip((fit.inertia, fit.damping, fit.friction), fit.std, truth, (0.05, 0.2, 0.2)):
        assert value == pytest.approx(true, rel=tol)
        assert abs(value - true) < 3 * std + 0.01 * true
    assert 0.2e-3 < fit.current_lag < 1.5e-3  # the emulated device's current loop, ω_c = 2000 rad/s at 4 kHz


def test_bad_input_names_the_field(own):
    with pytest.raises(InputError, match="series"):
        fit_rotor(own.model, [])
    t = np.linspace(0, 1, 50)
    at_rest = (t, np.broadcast_to(np.eye(3), (50, 3, 3)), np.zeros((50, own.model.coil_count)))
    with pytest.raises(InputError, match="series"):
        fit_rotor(own.model, [at_rest])
    with pytest.raises(InputError, match="model"):
        fit_rotor("not a model", [at_rest])
    with pytest.raises(InputError, match="speeds"):
        rotor_excitation(speeds=(1.0, -2.0))
    with pytest.raises(InputError, match="plant_rotor"):
        record_moves(None, rotor_excitation(repeats=1), plant_rotor=0.1)


def test_fit_round_trips_through_its_dict():
    import json

    from spherestep.dynamics import RotorFit

    fit = RotorFit(0.094, 0.04, 0.041, (1e-4, 7e-4, 9e-4), 0.002, 120, 40, 6.4e-4, 5e-5, 2e-3, 2)
    assert RotorFit.from_dict(json.loads(json.dumps(fit.to_dict()))) == fit
    bad = fit.to_dict()
    del bad["friction_N_m"]
    with pytest.raises(InputError, match="friction_N_m"):
        RotorFit.from_dict(bad)
