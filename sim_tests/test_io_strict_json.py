"""``rmbench.io.strict_json``: NaN and infinities become null, nothing else changes, and a
non-finite value that gets past the conversion raises instead of writing invalid JSON."""

import json
import math

import numpy as np
import pytest

from rmbench.io.strict_json import jsonable, strict_dumps


def strict_loads(text: str):
    def refuse(name):
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(text, parse_constant=refuse)


NON_FINITE = [float("nan"), float("inf"), -float("inf"), np.float64("nan"), np.float32("inf"),
              np.float16("-inf"), np.longdouble("nan")]


@pytest.mark.parametrize("value", NON_FINITE, ids=["nan", "inf", "-inf", "np.float64-nan", "np.float32-inf",
                                                    "np.float16--inf", "np.longdouble-nan"])
def test_a_non_finite_float_becomes_null(value):
    assert jsonable(value) is None
    assert strict_loads(strict_dumps({"a": [value, (value,)]})) == {"a": [None, [None]]}


def test_non_finite_array_elements_become_null():
    a = np.array([[1.5, np.nan], [-np.inf, 2.0]])
    assert strict_loads(strict_dumps({"a": a})) == {"a": [[1.5, None], [None, 2.0]]}


def test_everything_else_is_unchanged():
    """Finite numbers keep every digit, ints stay ints and bools bools, strings and None pass."""
    plain = {"f": [0.1, -2.5e-300, 5e-324, 1.7976931348623157e308, -0.0], "i": [0, -3, 2 ** 70],
             "b": [True, False], "s": "NaN Infinity", "n": None, "nested": {"t": [1, [2.0, "x"]]}}
    assert json.loads(strict_dumps(plain)) == plain
    assert strict_dumps(plain, sort_keys=True) == json.dumps(plain, sort_keys=True)


def test_numpy_values_become_the_same_python_values():
    obj = {"f": np.float64(0.1), "f32": np.float32(0.5), "i": np.int64(7), "u": np.uint8(255),
           "b": np.bool_(True), "a": np.arange(3), "k": {1: np.array([True, False])}}
    assert strict_loads(strict_dumps(obj)) == {"f": 0.1, "f32": 0.5, "i": 7, "u": 255, "b": True,
                                               "a": [0, 1, 2], "k": {"1": [True, False]}}
    assert type(jsonable(np.bool_(False))) is bool and type(jsonable(np.int32(1))) is int


def test_a_nan_past_the_conversion_raises():
    """A ``default`` that hands back NaN is caught by ``allow_nan=False``."""
    with pytest.raises(ValueError, match="Out of range float"):
        strict_dumps({"x": object()}, default=lambda o: math.nan)


def test_allow_nan_cannot_be_asked_for():
    with pytest.raises(TypeError, match="allow_nan"):
        strict_dumps([1.0], allow_nan=True)
