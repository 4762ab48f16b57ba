"""The sequential invalidation test: exploration, re-measurement, stopping rules, bad input."""

import math

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.tracker import invalidate


def scripted(values):
    """measure(location) returning, per location, its scripted readings in turn."""
    queue = {k: list(v) for k, v in values.items()}

    def measure(q):
        return queue[int(q)].pop(0)

    return measure


def test_accurate_model_is_not_rejected_after_exploring_every_location_once():
    loc = np.arange(20.0)
    res = invalidate(lambda q: 0.5, loc, 0.01, eta=1.0, alpha=0.9, max_per_location=5)
    assert not res.rejected
    assert res.stop == "explored"
    assert res.n_measurements == 20 and np.all(res.n_per_location == 1)


def test_clear_violation_is_rejected_once_the_worst_location_reaches_its_cap():
    res = invalidate(lambda q: 2.0, np.arange(5.0), 0.1, eta=1.0, alpha=0.9, max_per_location=4,
                     on_cap="reject")
    assert res.rejected and res.stop == "cap"
    assert res.n_per_location[0] == 4 and res.n_measurements == 4


def test_the_worst_location_is_remeasured_only_while_p_star_exceeds_alpha():
    # σ = 0.1, η = 1. Location 1 reads 1.5 (p* ≈ 1 > α), then 0.9s. Means 1.2, 1.1, 1.05 give
    # p* = 0.995, 0.917, 0.683: re-measuring stops at the third extra reading although the mean
    # is still above η, and exploration resumes at location 2.
    measure = scripted({0: [0.0], 1: [1.5, 0.9, 0.9, 0.9, 0.9], 2: [0.0]})
    res = invalidate(measure, np.arange(3.0), 0.1, eta=1.0, alpha=0.9, max_per_location=10)
    assert not res.rejected
    assert res.remeasured.tolist() == [1]
    assert res.index.tolist() == [0, 1, 1, 1, 1, 2]


def test_skip_rule_remeasures_the_next_worst_location_when_the_worst_is_capped():
    # σ = 0.05, η = 1, cap 2: location 0 reads 1.04 (p* = 0.58), location 1 reads 1.5 twice and
    # is capped; "skip" then re-measures location 0 (0.9: back inside) before rejecting,
    # "reject" stops at once
    def fresh():
        return scripted({0: [1.04, 0.9], 1: [1.5, 1.5]})

    common = dict(sigma=0.05, eta=1.0, alpha=0.9, max_per_location=2)
    skip = invalidate(fresh(), np.arange(2.0), on_cap="skip", **common)
    reject = invalidate(fresh(), np.arange(2.0), on_cap="reject", **common)
    assert skip.rejected and skip.stop == "cap" and skip.n_per_location.tolist() == [2, 2]
    assert reject.rejected and reject.stop == "cap" and reject.n_per_location.tolist() == [1, 2]


def test_budget_stops_the_test_with_the_verdict_on_the_data_so_far():
    res = invalidate(lambda q: 0.0, np.arange(10.0), 1.0, 1.0, 0.9, 5, max_measurements=4)
    assert res.stop == "budget" and res.n_measurements == 4 and not res.rejected


def test_no_location_exceeds_its_cap():
    rng = np.random.default_rng(3)
    res = invalidate(lambda q: math.sin(6 * q) + 0.5 * rng.standard_normal(), np.linspace(0, 1, 200),
                     0.5, 0.9, 0.9, 7, rng)
    assert res.n_per_location.max() <= 7


def test_same_seed_gives_the_same_test():
    def run():
        rng = np.random.default_rng(11)
        return invalidate(lambda q: math.sin(6 * q) + 0.3 * rng.standard_normal(),
                          np.linspace(0, 1, 300), 0.3, 1.0, 0.9, 20, rng)

    a, b = run(), run()
    assert np.array_equal(a.index, b.index) and np.array_equal(a.measurements, b.measurements)


def test_quasi_random_order_visits_every_location_once_spread_out():
    rng = np.random.default_rng(0)
    res = invalidate(lambda q: 0.0, np.linspace(0, 1, 64), 1.0, 1.0, 0.9, 3, rng)
    first = np.sort(res.locations[res.index[:8]])
    # 8 scrambled Sobol points put one point in each eighth of [0, 1], so no gap exceeds 2/8;
    # each is then moved to the nearest free location (at most 1/126 away)
    gaps = np.diff(np.concatenate([[0.0], first, [1.0]]))
    assert gaps.max() <= 2 / 8 + 2 / 126
    assert sorted(res.index.tolist()) == list(range(64))


def test_3d_test_takes_vector_errors_and_per_axis_sigma():
    loc = np.arange(6.0)
    sigma = np.tile([1e-3, 2e-3, 3e-3], (6, 1))
    res = invalidate(lambda q: np.array([0.1, 0.0, 0.2]), loc, sigma, 0.2, 0.9, 3)
    assert res.dim == 3 and res.rejected  # |e| = 0.224 > 0.2 by 8 σ_x-scaled units


def test_eta_at_the_largest_reading_is_never_rejected():
    # Every location mean lies inside the ball of radius max |reading|, so every Z is 0 and P* = 0:
    # the smallest η not rejected can never exceed the Largest Error of the same readings.
    # That bounds how far the method can see beyond the measured configurations.
    rng = np.random.default_rng(3)
    loc = np.arange(30.0)
    readings = {k: list(rng.normal(0.0, 1e-4, (10, 3)) + rng.normal(0.0, 2e-4, 3)) for k in range(30)}
    largest = max(np.linalg.norm(r) for v in readings.values() for r in v)
    res = invalidate(scripted(readings), loc, 1e-5, eta=largest, alpha=0.9, max_per_location=10)
    assert not res.rejected and res.p_star == 0.0


def test_correct_hook_reexpresses_all_measurements():
    res = invalidate(lambda q: np.array([5.0, 0.0, 0.0]), np.arange(4.0), 0.01, 1.0, 0.9, 3,
                     correct=lambda idx, raw: raw - np.array([5.0, 0.0, 0.0]))
    assert not res.rejected and np.allclose(res.measurements, 0.0)


@pytest.mark.parametrize("kwargs, message", [
    (dict(alpha=0.0), "alpha must lie strictly between 0 and 1"),
    (dict(alpha=1.0), "alpha must lie strictly between 0 and 1"),
    (dict(alpha=1.5), "alpha must lie strictly between 0 and 1"),
    (dict(sigma=0.0), "sigma must be finite and > 0"),
    (dict(sigma=-1.0), "sigma must be finite and > 0"),
    (dict(sigma=np.array([1.0, np.nan, 1.0])), "sigma must be finite and > 0"),
    (dict(sigma=np.ones(5)), r"sigma must be a scalar, shape \(3,\)"),
    (dict(eta=-0.1), "eta must be finite and >= 0"),
    (dict(max_per_location=0), "max_per_location must be an integer >= 1"),
    (dict(on_cap="never"), "on_cap must be 'reject' or 'skip'"),
    (dict(locations=[]), "locations must be an array"),
], ids=["alpha-0", "alpha-1", "alpha-1.5", "sigma-0", "sigma-negative", "sigma-nan",
        "sigma-shape", "eta-negative", "cap-0", "on-cap", "no-locations"])
def test_bad_arguments_are_refused_by_name(kwargs, message):
    args = dict(measure=lambda q: 0.0, locations=np.arange(3.0), sigma=1.0, eta=1.0, alpha=0.9,
                max_per_location=3)
    args.update(kwargs)
    with pytest.raises(InputError, match=message):
        invalidate(**args)


def test_non_finite_measurement_is_refused():
    with pytest.raises(InputError, match="non-finite error at location 0"):
        invalidate(lambda q: float("nan"), np.arange(3.0), 1.0, 1.0)


def test_measurement_changing_shape_is_refused():
    measure = scripted({0: [0.0], 1: [np.zeros(3)]})
    with pytest.raises(InputError, match="after a scalar at the first location"):
        invalidate(measure, np.arange(2.0), 1.0, 1.0)
