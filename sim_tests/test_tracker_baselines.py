"""The seed's common accuracy-identification methods, and Table 1's ordering of all methods."""

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.tracker import largest_error, mean_error, outlier_rejection, table1

READINGS = np.array([0.1, -0.3, 0.2, 5.0, -0.2, 0.0, 0.3, -0.1, 0.2, -0.2])


def replay(values):
    """measure(location) returning the readings in turn."""
    it = iter(values)
    return lambda q: float(next(it))


def test_largest_error_is_the_largest_magnitude_of_single_readings():
    res = largest_error(replay(READINGS), np.arange(10.0))
    assert res.accuracy == 5.0 and res.n_measurements == 10


def test_outlier_rejection_discards_readings_outside_mean_plus_minus_1_96_std():
    res = outlier_rejection(replay(READINGS), np.arange(10.0))
    # mean 0.5, std 1.51: 5.0 lies 2.98 std out; the rest are kept, the largest of them is 0.3
    assert res.kept.tolist() == [True, True, True, False] + [True] * 6
    assert res.accuracy == pytest.approx(0.3)


def test_outlier_rejection_of_vectors_uses_the_error_magnitude():
    vectors = np.zeros((10, 3))
    vectors[:, 2] = np.abs(READINGS)  # magnitudes 0.1 ... 5.0: mean 0.68, std 1.45
    it = iter(vectors)
    res = outlier_rejection(lambda q: next(it), np.arange(10.0))
    assert res.accuracy == pytest.approx(0.3)


def test_mean_error_averages_n_readings_per_location():
    readings = [1.0, 3.0, -1.0, -2.0]  # two locations, two readings each: means 2.0 and -1.5
    res = mean_error(replay(readings), np.arange(2.0), n_per_location=2)
    assert res.accuracy == 2.0 and res.index.tolist() == [0, 0, 1, 1]


def test_budget_truncates_every_method():
    res = mean_error(lambda q: 1.0, np.arange(10.0), n_per_location=10, max_measurements=25)
    assert res.n_measurements == 25 and np.bincount(res.index).tolist() == [10, 10, 5]


def test_bad_baseline_settings_are_refused():
    with pytest.raises(InputError, match="k must be finite and > 0"):
        outlier_rejection(lambda q: 0.0, np.arange(3.0), k=0.0)
    with pytest.raises(InputError, match="n_per_location must be an integer >= 1"):
        mean_error(lambda q: 0.0, np.arange(3.0), n_per_location=0)


def test_table1_orders_largest_above_mean_above_invalidation_at_medium_and_high_noise():
    tab = table1(noise=(0.5, 1.0), seeds=[0])
    acc = tab.mean()
    for s in (0.5, 1.0):
        le, me, mi = (acc.sel(estimator=m, noise=s).item()
                      for m in ("largest_error", "mean_error", "model_invalidation"))
        assert le > me > mi >= 0.98  # the ordering; MI never optimistic
