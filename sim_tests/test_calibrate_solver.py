"""Specification of the regularised least squares every calibration shares (FRF and tracker data):
a maximum a posteriori fit with a Gaussian prior per parameter, bounds, an optional robust loss, and
its posterior account."""

import numpy as np
import pytest

from rmbench.calibrate.solver import Bounds, SolverOptions, huber, identifiability, posterior, solve


def _linear(a, y):
    return (lambda x: a @ x - y), (lambda x: a)


def test_a_linear_problem_lands_on_the_closed_form_posterior_mean():
    rng = np.random.default_rng(0)
    a, y = rng.normal(size=(30, 3)), rng.normal(size=30)
    sd = np.array([0.5, 1.0, np.inf])
    sol = solve(*_linear(a, y), np.zeros(3), prior_sd=sd, options=SolverOptions(max_nfev=50))
    precision = np.array([4.0, 1.0, 0.0])
    expected = np.linalg.solve(a.T @ a + np.diag(precision), a.T @ y)
    # a linear problem is one Gauss-Newton step: the solver's tolerance (1e-4 of x) is the only gap
    np.testing.assert_allclose(sol.x, expected, rtol=1e-4, atol=1e-6)
    assert sol.chi2_prior == pytest.approx(np.sum(precision * sol.x ** 2), rel=1e-9)


def test_a_bound_holds_the_parameter_the_data_push_past_it():
    a, y = np.eye(2), np.array([3.0, 0.5])
    sol = solve(*_linear(a, y), np.zeros(2), prior_sd=[np.inf, np.inf], bounds=Bounds([-1, -1], [1, 1]),
                options=SolverOptions(max_nfev=50))
    assert sol.x[0] == pytest.approx(1.0, abs=1e-6) and sol.x[1] == pytest.approx(0.5, abs=1e-4)


def test_a_one_sided_bound_leaves_the_other_side_open():
    lo, hi = Bounds(lower=[0.0, -1.0]).arrays(2)
    np.testing.assert_array_equal(lo, [0.0, -1.0])
    assert np.all(np.isinf(hi)) and np.all(hi > 0)


def test_solver_options_refuse_no_evaluations():
    with pytest.raises(ValueError, match="max_nfev must be at least 1, got 0"):
        SolverOptions(max_nfev=0)


def test_a_parameter_the_data_do_not_see_keeps_its_prior_and_is_not_identifiable():
    # residuals see the first parameter strongly, the second not at all
    jac = np.column_stack([10.0 * np.ones(20), np.zeros(20)])
    post = posterior(jac, [1.0, 1.0], chi2=20.0, n=20)
    assert post.ratio[1] == pytest.approx(1.0)
    assert identifiability(post.ratio[0]) == "identifiable"
    assert identifiability(post.ratio[1]) == "not identifiable"
    # fixed by the data, but not to the resolution that matters: weak at best
    assert identifiability(post.ratio[0], resolved=False) == "weak"


def test_a_model_short_of_the_noise_widens_its_intervals_by_the_reduced_chi2():
    jac = np.column_stack([np.ones(10), np.arange(10.0)])
    fits = posterior(jac, [1e-6, 1e-6], chi2=8.0, n=10)
    misfit = posterior(jac, [1e-6, 1e-6], chi2=32.0, n=10)
    assert fits.scale == 1.0 and misfit.scale == pytest.approx(4.0)
    np.testing.assert_allclose(misfit.sd, 2.0 * fits.sd)
    # identifiability is what the data say, not how well the model fits them
    np.testing.assert_allclose(misfit.ratio, fits.ratio)


def test_hubers_residuals_are_the_residuals_within_the_threshold_and_linear_cost_beyond():
    r = np.array([-10.0, -3.0, 0.5, 2.9, 40.0])
    out, d = huber(r, 3.0)
    np.testing.assert_array_equal(out[1:4], r[1:4])
    np.testing.assert_array_equal(d[1:4], 1.0)
    # beyond the threshold the cost is 2c|r| − c², and the residual keeps its sign
    np.testing.assert_allclose(out[[0, 4]] ** 2, 2 * 3.0 * np.abs(r[[0, 4]]) - 9.0)
    assert out[0] < 0 < out[4]
    # and the derivative is that of the transformed residual: d r̃/dr = c / |r̃|
    eps = 1e-6
    np.testing.assert_allclose(d[[0, 4]], (huber(r + eps, 3.0)[0] - huber(r - eps, 3.0)[0])[[0, 4]] / (2 * eps),
                               rtol=1e-6)


def test_one_gross_error_pulls_a_robust_fit_as_little_as_one_at_the_threshold():
    # the mean of 20 readings of 1.0 and one of 100: least squares moves by 99/21 ≈ 4.7, Huber's
    # loss (threshold 3) by the threshold's share, 3/20 = 0.15
    y = np.concatenate([np.ones(20), [100.0]])
    a = np.ones((21, 1))
    plain = solve(*_linear(a, y), np.zeros(1), prior_sd=[np.inf], options=SolverOptions(max_nfev=50))
    robust = solve(*_linear(a, y), np.zeros(1), prior_sd=[np.inf], options=SolverOptions(max_nfev=50, robust=3.0))
    assert plain.x[0] == pytest.approx(100 / 21 + 20 / 21, rel=1e-4)
    assert robust.x[0] == pytest.approx(1.15, abs=1e-3)
    # χ² is the data's own, unchanged by the loss
    assert robust.chi2 == pytest.approx(20 * 0.15 ** 2 + 98.85 ** 2, rel=1e-4)
