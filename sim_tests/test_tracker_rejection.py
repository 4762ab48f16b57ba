"""The rejection probability p* and P* of METHODS.md §7, against their textbook definitions."""

import numpy as np
import pytest
from scipy import stats

from rmbench.tracker.rejection import combined_p_star, log_acceptance, p_star, rejection_statistic


def test_1d_p_star_is_two_sided_normal_probability_of_clipped_candidate():
    mean = np.array([[1.7], [-1.4], [0.3]])
    sigma_hat = np.array([[0.5], [0.2], [0.1]])
    eta = 1.0
    candidate = np.clip(mean, -eta, eta)
    z = np.abs(mean - candidate) / sigma_hat
    expected = (stats.norm.cdf(z) - stats.norm.cdf(-z))[:, 0]
    assert p_star(mean, sigma_hat, eta) == pytest.approx(expected, rel=1e-12)


def test_3d_p_star_uses_directional_bounds_and_chi2_3():
    mean = np.array([0.3, -0.4, 0.2])
    sigma_hat = np.array([0.05, 0.08, 0.1])
    eta = 0.35
    bounds = eta * np.abs(mean) / np.linalg.norm(mean)  # seed Eq. 24
    z = (np.abs(mean) - bounds) / sigma_hat
    expected = stats.chi2.cdf(np.sum(z**2), 3)  # seed Eqs. 25-26
    assert p_star(mean, sigma_hat, eta) == pytest.approx(expected, rel=1e-12)


def test_p_star_is_zero_inside_the_accuracy_level():
    assert p_star(np.array([[0.2, 0.1, -0.1]]), np.full((1, 3), 1e-6), 0.3) == [0.0]


@pytest.mark.parametrize("dim", [1, 3], ids=["chi2-1", "chi2-3"])
def test_log_acceptance_matches_chi2_log_survival_far_into_the_tail(dim):
    r = np.array([0.0, 0.3, 4.0, 40.0, 400.0, 1400.0])
    assert log_acceptance(r, dim) == pytest.approx(stats.chi2.logsf(r, dim), rel=1e-10, abs=1e-300)


def test_combined_p_star_is_one_minus_product_of_acceptances():
    p = np.array([0.2, 0.5, 0.05])
    assert combined_p_star(np.log1p(-p)) == pytest.approx(1 - np.prod(1 - p), rel=1e-14)


def test_combined_p_star_stays_exact_for_many_tiny_contributions():
    # 1000 locations each with p* = 1e-9: P* = 1e-6 to relative 1e-6, no cancellation
    assert combined_p_star(np.full(1000, np.log1p(-1e-9))) == pytest.approx(1e-6, rel=1e-6)


def test_rejection_statistic_in_1d_is_squared_z_of_the_excess():
    assert rejection_statistic(np.array([[-2.0]]), np.array([[0.5]]), 1.0) == pytest.approx([4.0])
