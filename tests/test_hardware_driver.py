"""CoilDriver, thermal limits and plan streaming on the DryRun back end (simulated clock, no device)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from spherestep.commutation import Plan, Step, default_channel_map
from spherestep.errors import InputError
from spherestep.hardware import CoilDriver, DryRun, RelayLink, ThermalLimitError, ThermalLimits, coil_masks

from relays import play_relays
from spherestep.hardware.protocol import decode

I3 = np.eye(3)


def make_plan(coil_sets, coil_count=4):
    steps = [Step(index=i, target=I3, achieved=I3, error=0.0, coils=dict(c)) for i, c in enumerate(coil_sets)]
    return Plan(steps=steps, coil_count=coil_count, channel_map=default_channel_map(coil_count))


@given(st.integers(1, 16).flatmap(lambda n: st.tuples(
    st.just(n), st.dictionaries(st.integers(0, n - 1), st.sampled_from([-1, 1])))))
def test_coil_masks_set_exactly_the_mapped_bits(case):
    """Against a bit string built channel by channel: enable bit of every energised coil, polarity bit of
    every reversed one, nothing else."""
    n, coils = case
    cmap = default_channel_map(n)[::-1].copy()  # a non-trivial map: coil k on channels n-1-k, 2n-1-k
    enable, polarity = coil_masks(coils, cmap)
    bits_e = "".join("1" if any(cmap[k, 0] == ch for k in coils) else "0" for ch in reversed(range(2 * n)))
    bits_p = "".join("1" if any(cmap[k, 1] == ch and coils[k] < 0 for k in coils) else "0"
                     for ch in reversed(range(2 * n)))
    assert enable == int(bits_e, 2) and polarity == int(bits_p, 2)
    step = Step(index=0, target=I3, achieved=I3, error=0.0, coils=coils)
    assert step.masks(cmap) == (enable, polarity)


def test_apply_drives_masks_and_context_ends_all_off():
    backend = DryRun()
    with CoilDriver(RelayLink(backend, default_channel_map(4))) as driver:
        driver.apply({0: 1, 2: -1}, duration=0.1)
        driver.hold(0.1)
        driver.apply(make_plan([{3: -1}]).steps[0], duration=0.1)
        assert driver.coils == {3: -1}
    assert [(s.enable, s.polarity) for s in backend.sent] == [(0b0101, 1 << 6), (0b1000, 1 << 7), (0, 0)]
    assert [s.t for s in backend.sent] == pytest.approx([0.0, 0.1, 0.1])
    frames = [decode(text[1:].encode()) for _, kind, text in backend.transcript.entries if kind == "TX"]
    assert [(f.seq, f.verb, f.args) for f in frames] == [
        (0, "HELLO", ("1",)), (1, "SET", ("5", "40")), (2, "SET", ("8", "80")), (3, "OFF", ())]


def test_exception_inside_the_driver_still_ends_all_off():
    backend = DryRun()
    with pytest.raises(RuntimeError, match="boom"):
        with CoilDriver(RelayLink(backend, default_channel_map(4))) as driver:
            driver.apply({1: 1})
            raise RuntimeError("boom")
    assert (backend.sent[-1].enable, backend.sent[-1].polarity) == (0, 0)
    assert driver.coils == {}


@pytest.mark.parametrize("coils", [{4: 1}, {-1: 1}, {0: 2}, {0: 0}, {"0": 1}])
def test_apply_rejects_bad_coils(coils):
    with CoilDriver(RelayLink(DryRun(), default_channel_map(4))) as driver:
        with pytest.raises(InputError, match="^coils must be a map from coil index 0..3"):
            driver.apply(coils)


@pytest.mark.parametrize("cmap", [[[0, 1], [1, 2]], [[0, -1]], [[0, 1, 2]], np.zeros((0, 2), int), [[0.5, 1]]])
def test_channel_map_is_validated(cmap):
    with pytest.raises(InputError, match="^channel_map must be"):
        CoilDriver(RelayLink(DryRun(), cmap))


def test_device_with_too_few_channels_refuses_the_map_before_switching():
    backend = DryRun(channels=8)
    with pytest.raises(InputError, match="relay channel 9, but device 'dry-run' has 8 channels"):
        with CoilDriver(RelayLink(backend, default_channel_map(5))):
            pass
    assert backend.sent == []


def test_play_keeps_the_schedule_on_the_backend_clock():
    plan = make_plan([{0: 1}, {1: 1}, {1: -1, 2: 1}, {}])
    backend = DryRun()
    report = play_relays(plan, backend, rate=4.0)
    assert [s.t for s in backend.sent] == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    assert [s.coils for s in backend.sent] == [{0: 1}, {1: 1}, {1: -1, 2: 1}, {}, {}]
    assert report.steps == 4 and report.elapsed == pytest.approx(1.0) and report.max_lag == 0.0


def test_play_rejects_empty_plan_and_bad_rate():
    with pytest.raises(InputError, match="^plan.steps must be at least one step"):
        play_relays(make_plan([]), DryRun(), rate=1.0)
    for rate in (0.0, -1.0, float("nan"), float("inf")):
        with pytest.raises(InputError, match="^rate must be a positive step rate"):
            play_relays(make_plan([{0: 1}]), DryRun(), rate=rate)


def test_continuous_on_time_limit_names_step_and_coil():
    plan = make_plan([{0: 1}] * 3 + [{0: -1, 1: 1}] * 3)  # coil 0 on for 6 steps (polarity change is no break)
    ThermalLimits(max_on=6.0).check_plan(plan, rate=1.0)  # exactly at the limit: allowed
    with pytest.raises(ThermalLimitError, match=r"^coil 0 would stay on for 4\.000 s without a break \(to the end "
                                                r"of step 3\), over max_on = 3\.5 s"):
        ThermalLimits(max_on=3.5).check_plan(plan, rate=1.0)
    ThermalLimits(max_on=3.5).check_plan(plan, rate=2.0)  # faster steps, 3 s in all


def test_duty_cycle_limit_over_sliding_window():
    plan = make_plan([{0: 1} if i % 2 == 0 else {} for i in range(20)])  # coil 0 on every other second
    ThermalLimits(max_on=10, max_duty=0.5, window=10).check_plan(plan, rate=1.0)
    with pytest.raises(ThermalLimitError, match=r"^coil 0 would be on for 5\.000 s of the 10 s before the end of "
                                                r"step 8 \(duty 0\.500\), over max_duty = 0\.45"):
        ThermalLimits(max_on=10, max_duty=0.45, window=10).check_plan(plan, rate=1.0)
    rests = make_plan([{0: 1}] * 4 + [{}] * 6 + [{0: 1}] * 4)  # 4 s on, 6 s off: the window forgets the first
    ThermalLimits(max_on=10, max_duty=0.4, window=10).check_plan(rests, rate=1.0)
    with pytest.raises(ThermalLimitError, match="step 10"):
        ThermalLimits(max_on=10, max_duty=0.4, window=11).check_plan(rests, rate=1.0)


def test_driver_aborts_all_off_when_a_hold_would_overheat():
    backend = DryRun()
    with CoilDriver(RelayLink(backend, default_channel_map(4)), ThermalLimits(max_on=1.0)) as driver:
        driver.apply({2: 1}, duration=0.6)
        driver.hold(0.6)
        driver.hold(0.3)
        with pytest.raises(ThermalLimitError, match="^coil 2 would stay on for 1.200 s"):
            driver.hold(0.3)
        assert driver.coils == {} and (backend.sent[-1].enable, backend.sent[-1].t) == (0, pytest.approx(0.9))
        driver.apply({2: 1}, duration=1.0)  # after switching off, a fresh run may start


@pytest.mark.parametrize("kwargs, field", [({"max_on": 0}, "max_on"), ({"max_on": float("inf")}, "max_on"),
                                           ({"max_duty": 0}, "max_duty"), ({"max_duty": 1.5}, "max_duty"),
                                           ({"window": -1}, "window")])
def test_limits_validate_their_fields(kwargs, field):
    with pytest.raises(InputError, match=f"^{field} must be"):
        ThermalLimits(**kwargs)
