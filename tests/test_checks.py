"""The shared input contracts (spherestep.checks): what each function accepts, what it refuses (bool, NaN, inf,
wrong types, out of range) with the one-line InputError naming the field, and the types it returns."""

import math

import numpy as np
import pytest

from spherestep import checks
from spherestep.errors import InputError

NOT_NUMBERS = [True, False, math.nan, math.inf, -math.inf, np.float64("nan"), np.bool_(True), "1", None, [1.0],
               np.array([1.0]), 1 + 0j]


def refused(call, name):
    with pytest.raises(InputError, match=rf"^{name} must be .*; instead received ") as err:
        call()
    assert err.value.field == name
    return str(err.value)


@pytest.mark.parametrize("value", [0, 1, -2.5, 1e300, np.float64(0.5), np.float32(2.0), np.int64(-3), np.int8(7)])
def test_number_accepts_finite_reals_as_float(value):
    x = checks.number(value, "x")
    assert type(x) is float and x == float(value)


@pytest.mark.parametrize("value", NOT_NUMBERS)
def test_number_refuses_bool_nan_inf_and_non_numbers(value):
    refused(lambda: checks.number(value, "x"), "x")


def test_number_range_ends_and_messages():
    assert checks.number(0.0, "x", low=0.0) == 0.0
    assert checks.number(1.0, "x", high=1.0) == 1.0
    assert "a finite number > 0" in refused(lambda: checks.number(0.0, "x", low=0.0, low_open=True), "x")
    assert "a finite number < 1" in refused(lambda: checks.number(1.0, "x", high=1.0, high_open=True), "x")
    assert "a finite number >= -1 and <= 1" in refused(lambda: checks.number(2, "x", low=-1, high=1), "x")
    kept = refused(lambda: checks.number(5, "tol", high=1, expected="an angle in (0, 0.5) radians"), "tol")
    assert kept == "tol must be an angle in (0, 0.5) radians; instead received 5"


@pytest.mark.parametrize("value", [1e-300, 3, np.float64(2.0), np.float32(0.5), np.int64(1)])
def test_positive_accepts(value):
    x = checks.positive(value, "p")
    assert type(x) is float and x > 0


@pytest.mark.parametrize("value", [0, 0.0, -0.0, -1, -1e-300, *NOT_NUMBERS])
def test_positive_refuses(value):
    message = refused(lambda: checks.positive(value, "p"), "p")
    assert "a finite positive number" in message


def test_positive_keeps_a_given_message():
    assert refused(lambda: checks.positive(0, "rate", "a positive step rate in Hz, such as 10"), "rate") == \
        "rate must be a positive step rate in Hz, such as 10; instead received 0"


@pytest.mark.parametrize("value", [0, 0.0, -0.0, 2, np.float32(1.5), np.int64(0)])
def test_non_negative_accepts_zero(value):
    x = checks.non_negative(value, "g")
    assert type(x) is float and x >= 0


@pytest.mark.parametrize("value", [-1, -1e-300, np.float64(-2.0), *NOT_NUMBERS])
def test_non_negative_refuses(value):
    assert "a finite non-negative number" in refused(lambda: checks.non_negative(value, "g"), "g")


def test_fraction_open_and_closed():
    assert checks.fraction(0.5, "f") == 0.5 and type(checks.fraction(np.float32(0.25), "f")) is float
    for end in (0, 1, 0.0, 1.0):
        assert "strictly between 0 and 1" in refused(lambda: checks.fraction(end, "f"), "f")
        assert checks.fraction(end, "f", closed=True) == end
    for value in (-0.1, 1.1, *NOT_NUMBERS):
        refused(lambda: checks.fraction(value, "f", closed=True), "f")
    assert refused(lambda: checks.fraction(2, "fill", expected="a fraction in (0, 1]"), "fill") == \
        "fill must be a fraction in (0, 1]; instead received 2"


@pytest.mark.parametrize("value", [1, 7, np.int64(3), np.int8(1), np.uint16(9)])
def test_count_accepts_python_and_numpy_integers_as_int(value):
    n = checks.count(value, "n")
    assert type(n) is int and n == int(value)


@pytest.mark.parametrize("value", [0, -1, True, False, np.bool_(True), 1.0, 2.5, math.nan, math.inf, "3", None,
                                   np.float64(3.0), [3]])
def test_count_refuses_non_integers_bool_and_below_minimum(value):
    refused(lambda: checks.count(value, "n"), "n")


def test_count_range_and_messages():
    assert checks.count(0, "k", 0) == 0
    assert checks.count(5, "k", 0, 5) == 5
    assert "an integer >= 1" in refused(lambda: checks.count(0, "n"), "n")
    assert "an integer from 0 to 5" in refused(lambda: checks.count(6, "k", 0, 5), "k")
    assert refused(lambda: checks.count(0, "samples", 1, 10, expected="an integer in 1..10"), "samples") == \
        "samples must be an integer in 1..10; instead received 0"


@pytest.mark.parametrize("value", [1, -1, 1.0, -1.0, np.int64(1), np.float64(-1.0), np.int8(-1)])
def test_sign_accepts_plus_and_minus_one_as_int(value):
    s = checks.sign(value, "polarity")
    assert type(s) is int and s == value


@pytest.mark.parametrize("value", [0, 2, -2, 0.5, True, False, np.bool_(True), math.nan, math.inf, "1", None, [1]])
def test_sign_refuses_other_values_and_bool(value):
    assert "+1 or -1" in refused(lambda: checks.sign(value, "polarity"), "polarity")
    assert "a map" in refused(lambda: checks.sign(value, "coils", "a map to +1 or -1"), "coils")


@pytest.mark.parametrize("value, unit", [([0, 0, 2], [0, 0, 1]), ((3.0, 4.0, 0.0), [0.6, 0.8, 0.0]),
                                         (np.array([1e-140, 0, 0]), [1, 0, 0]),
                                         ([1e300, 1e300, 0], [0.5 ** 0.5] * 2 + [0]),
                                         (np.array([0, -5, 0], dtype=np.int64), [0, -1, 0]),
                                         (np.array([1, 1, 1], dtype=np.float32), [3 ** -0.5] * 3)])
def test_axis_returns_a_unit_float_vector(value, unit):
    n = checks.axis(value)
    assert isinstance(n, np.ndarray) and n.dtype == float and n.shape == (3,)
    np.testing.assert_allclose(n, unit, rtol=0, atol=1e-15)
    assert abs(float(n @ n) - 1.0) < 1e-15


@pytest.mark.parametrize("value", [[0, 0, 0], [1e-320, 0, 0], [1e-200, 1e-200, 0], [math.nan, 0, 1],
                                   [math.inf, 0, 0], [1, 0], [1, 0, 0, 0], [[1, 0, 0]], "x", None, ["a", 0, 0]])
def test_axis_refuses_zero_underflowing_non_finite_and_misshapen(value):
    with np.errstate(all="raise"):  # refused without a NumPy warning, also for 1e-320
        refused(lambda: checks.axis(value, "stator_axis"), "stator_axis")


def test_axis_names_the_field_by_default():
    assert "not all components zero" in refused(lambda: checks.axis([1e-320, 0, 0]), "axis")


def test_currents_shape_finiteness_failed_coils_and_no_copy():
    c = np.array([[0.5, 0.0, -1.0]])
    assert checks.currents(c, 3) is c
    out = checks.currents([1, 0, 2], 3, failed=(1,))
    assert out.dtype == float and out.tolist() == [1.0, 0.0, 2.0]
    assert "shape (..., 3)" in refused(lambda: checks.currents([1, 2], 3), "currents")
    assert "finite" in refused(lambda: checks.currents([1, math.nan, 0], 3, name="c"), "c")
    assert "finite" in refused(lambda: checks.currents(np.full((100, 3), math.inf), 3), "currents")
    assert "failed coils [1]" in refused(lambda: checks.currents([0, 1, 0], 3, failed=(1,)), "currents")
    assert "real numbers" in refused(lambda: checks.currents(["a", "b", "c"], 3), "currents")
