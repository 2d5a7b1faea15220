"""What the Python API fuzzer (fuzz/python_api_fuzz.py) found, each as a test: hostile values are refused
at once with a documented exception, never a hang, a crash or a value that means nothing."""

import os

import numpy as np
import pytest

import microshadow as ms

# A read-only view of 10^11 values: nothing allocated, but any element-wise check or copy of it would run
# for minutes and ask for terabytes.
HUGE = np.broadcast_to(0.5, (10**11,))


@pytest.fixture(scope="module")
def lut():
    return ms.bake(layout="custom", size=2, roughness=[0.5], samples=64, replicates=2, backend="oracle")


def test_huge_broadcast_arguments_are_refused_before_any_work(lut):
    with pytest.raises(MemoryError, match="split the call"):
        ms.evaluate_iso(HUGE, 0.5, 0.5, roughness=0.5, backend="oracle")
    with pytest.raises(MemoryError, match="split the call"):
        lut.lookup(0.5, HUGE, 0.5, roughness=0.5)
    with pytest.raises(MemoryError, match="split the call"):
        ms.analytic(ms.ANALYTIC_TERMS[0], 0.5, HUGE, roughness=0.5)


def test_huge_broadcast_lights_are_refused_before_any_work():
    corners = np.broadcast_to(np.array([[-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float), (10**11, 4, 3))
    with pytest.raises(MemoryError, match="split the call"):
        ms.area_eval(0.5, 0.3, 0.3, [0, 0, 1], light="rect", corners=corners, backend="oracle")
    with pytest.raises(MemoryError, match="split the call"):
        ms.area_eval(0.5, 0.3, 0.3, [0, 0, 1], light_direction=np.broadcast_to([0.0, 0.0, 1.0], (10**11, 3)),
                     half_angle_deg=10.0, backend="oracle")
    with pytest.raises(MemoryError, match="split the call"):
        ms.area_eval(0.5, 0.3, 0.3, [0, 0, 1], light_direction=[0, 0, 1], half_angle_deg=HUGE, backend="oracle")


def test_repr_bake_refuses_a_roughness_of_a_billion_nodes_at_once():
    with pytest.raises(ValueError, match="roughness: 100000000000 values; 1 to 64 nodes"):
        ms.repr_bake(kind="azimuth-axis", roughness=HUGE, backend="oracle")
    with pytest.raises(ValueError, match="roughness: 0 values"):
        ms.repr_bake(kind="azimuth-axis", roughness=[], backend="oracle")


@pytest.mark.parametrize("value, message", [
    (np.array(["2020-01-01"], dtype="datetime64[D]"), "datetime64\\[D\\] values: give real numbers"),
    (np.array([5], dtype="timedelta64[s]"), "timedelta64\\[s\\] values"),
    (np.array(["0.5"]), "<U3 values"),
    (np.ma.masked_array([0.5, 0.7], mask=[False, True]), "masked values"),
    (np.zeros(2, dtype=[("a", "f8")]), "values: give real numbers"),
])
def test_values_that_are_not_real_numbers_are_refused(lut, value, message):
    # Each converted to float64 without a word before: a date became its day count, a masked value the
    # number under the mask.
    with pytest.raises(ValueError, match="visibility: not an array of numbers.*" + message):
        lut.lookup(value, 0.5, 0.5, roughness=0.5)
    with pytest.raises(ValueError, match="visibility: not an array of numbers.*" + message):
        ms.evaluate(value, 0.3, 0.3, [0, 0, 1], [0, 0, 1], backend="oracle")


def test_an_integer_too_large_for_a_double_is_a_value_error():
    with pytest.raises(ValueError, match="visibility: not an array of numbers"):
        ms.analytic(ms.ANALYTIC_TERMS[0], 2**2000, 0.5)
