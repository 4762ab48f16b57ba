"""Gaussian-process posture predictors (issue 15): the Kronecker posterior, MTGP, the seed's grouping,
the trained predictor and its plain-file persistence."""

import json
import warnings

import numpy as np
import pytest
import xarray as xr
from _posture_grid import grid as _grid
from _posture_grid import smooth as _smooth

from rmbench.errors import InputError
from rmbench.predict import (MTGP, STGP, ExtrapolationWarning, GroupedMTGP, PosturePredictor,
                             TrainingSet, cross_validate, predicted_frf, seed_groups)
from rmbench.predict.mtgp import split_by_postures
from rmbench.predict.posterior import KronPosterior, loo_residuals, rbf
from rmbench.robot.modes import PARAMS


def test_kronecker_posterior_equals_the_dense_gaussian_process():
    """The eigendecomposition route gives the dense (nm x nm) GP's mean, variance and likelihood to
    round-off: it is the same algebra, only factorised."""
    from scipy.stats import multivariate_normal

    rng = np.random.default_rng(1)
    n, m = 12, 3
    X, Xs = rng.normal(size=(n, 3)), rng.normal(size=(4, 3))
    B = rng.normal(size=(m, m))
    Kc, d, mean = B @ B.T + 0.1 * np.eye(m), np.array([0.05, 0.2, 0.01]), rng.normal(size=m)
    ls = np.array([0.8, 1.3, 2.0])
    Y = rng.normal(size=(n, m))
    post = KronPosterior.build(X, Y, ls, Kc, d, mean)
    # dense, task-major ordering: index j * n + i
    K = np.kron(Kc, rbf(X, X, ls)) + np.kron(np.diag(d), np.eye(n))
    r = (Y - mean).T.ravel()
    Ks = np.kron(Kc, rbf(Xs, X, ls))                         # (m * 4, m * n)
    mu = Ks @ np.linalg.solve(K, r) + np.repeat(mean, 4)
    var = np.repeat(np.diag(Kc), 4) - np.einsum("ij,ji->i", Ks, np.linalg.solve(K, Ks.T))
    got_mu, got_sd = post.predict(Xs, return_std=True)
    np.testing.assert_allclose(got_mu.T.ravel(), mu, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got_sd.T.ravel() ** 2, var, rtol=1e-9, atol=1e-12)
    ll = multivariate_normal(np.zeros(n * m), K).logpdf(r)
    assert post.log_likelihood == pytest.approx(ll, rel=1e-10)


def test_kronecker_likelihood_and_its_gradient_equal_the_dense_computation():
    """½ (vᵀ K⁻¹ v + log|K|) of K = K_t ⊗ K_c + I from the two eigendecompositions, with its
    closed-form gradient: equal to the dense matrix algebra, and the gradient to finite
    differences (torch's gradcheck: float64, relative 1e-3 of a central difference)."""
    import torch

    # an internal numerical kernel (torch autograd function) checked against its definition
    from rmbench.predict.gp import _kron_quad_logdet

    fn = _kron_quad_logdet(torch).apply
    gen = torch.Generator().manual_seed(0)
    B, n, m = 2, 6, 3

    def spd(k):
        a = torch.randn(B, k, k, dtype=torch.float64, generator=gen)
        return a @ a.transpose(-1, -2) / k

    k_t, k_c, r = spd(n), spd(m), torch.randn(B, n, m, dtype=torch.float64, generator=gen)
    K = torch.stack([torch.kron(k_t[b], k_c[b]) + torch.eye(n * m, dtype=torch.float64)
                     for b in range(B)])
    v = r.reshape(B, -1, 1)
    dense = 0.5 * ((v.transpose(-1, -2) @ torch.linalg.solve(K, v)).reshape(B) + torch.logdet(K))
    assert torch.allclose(fn(k_t, k_c, r), dense, rtol=1e-12)
    # the covariance factors are symmetric: perturb them symmetrically
    inputs = tuple(t.clone().requires_grad_(True) for t in (k_t / 2, k_c / 2, r))
    assert torch.autograd.gradcheck(lambda a, c, x: fn(a + a.transpose(-1, -2), c + c.transpose(-1, -2), x),
                                    inputs)


def test_mtgp_fit_follows_gpytorchs_exact_marginal_likelihood():
    """The closed-form Kronecker likelihood is gpytorch's model, not another one: from the same start
    L-BFGS takes the same steps on both (hyperparameters equal to 1e-7 after 5 and 30 iterations,
    where a different objective or gradient would part them at the first step)."""
    # torch batching internals: the closed-form fitter checked step by step against gpytorch's
    from rmbench.predict.gp import _fit_batch, _fit_batch_kron, _torch

    torch, gpytorch = _torch()
    rng = np.random.default_rng(1)
    X = rng.standard_normal((30, 3))
    f = np.sin(X[:, 0]) + 0.3 * X[:, 1]
    Y = np.stack([np.column_stack([f + 0.1 * rng.standard_normal(30),
                                   -0.5 * f + 0.2 * rng.standard_normal(30),
                                   rng.standard_normal(30)]) for _ in range(3)])
    Y = (Y - Y.mean(axis=1, keepdims=True)) / Y.std(axis=1, keepdims=True)
    for iterations in (5, 30):
        with gpytorch.settings.max_cholesky_size(0):   # gpytorch's own Kronecker path
            ref = _fit_batch(torch, gpytorch, X, Y, 2, 1.0, iterations)
        ours = _fit_batch_kron(torch, gpytorch, X, Y, 2, 1.0, iterations)
        for key in ("lengthscales", "Kc", "noise", "mean", "nll"):
            np.testing.assert_allclose(ours[key], ref[key], rtol=1e-7, atol=1e-9, err_msg=key)


def test_single_task_likelihood_and_its_closed_form_gradient():
    """½ (rᵀK⁻¹r + log|K|) of one-task GPs from the Cholesky factor, and the hand-written gradient
    in the length scales, task variance, noise and mean, against the dense formula and finite
    differences (float64)."""
    import torch

    # an internal numerical kernel (torch autograd function) checked against its definition
    from rmbench.predict.gp import _single_gp

    fn = _single_gp(torch).apply
    gen = torch.Generator().manual_seed(0)
    B, n, d = 3, 7, 3
    x = torch.randn(n, d, dtype=torch.float64, generator=gen)
    y = torch.randn(B, n, dtype=torch.float64, generator=gen)
    ls = 0.5 + torch.rand(B, d, dtype=torch.float64, generator=gen)
    k_c, noise, mean = (0.2 + torch.rand(B, dtype=torch.float64, generator=gen) for _ in range(3))
    k_t = torch.exp(-0.5 * (((x[None, :, None, :] - x[None, None, :, :]) / ls[:, None, None, :]) ** 2).sum(-1))
    K = k_c[:, None, None] * k_t + noise[:, None, None] * torch.eye(n, dtype=torch.float64)
    r = (y - mean[:, None])[..., None]
    dense = 0.5 * ((r.transpose(-1, -2) @ torch.linalg.solve(K, r)).reshape(B) + torch.logdet(K))
    assert torch.allclose(fn(x, y, ls, k_c, noise, mean), dense, rtol=1e-12)
    inputs = tuple(t.clone().requires_grad_(True) for t in (ls, k_c, noise, mean))
    assert torch.autograd.gradcheck(lambda *p: fn(x, y, *p), inputs)


def test_single_task_fit_follows_gpytorchs_exact_marginal_likelihood():
    """One-task models (the residual terms' and clusters' learners) through the Cholesky closed form
    take gpytorch's L-BFGS steps (its Cholesky path for a covariance this small): hyperparameters
    equal to 1e-7 after 5 and 30 iterations, where another objective or gradient would part them at
    the first step."""
    # torch batching internals: the closed-form fitter checked step by step against gpytorch's
    from rmbench.predict.gp import _fit_batch, _fit_batch_kron, _torch

    torch, gpytorch = _torch()
    rng = np.random.default_rng(2)
    X = rng.standard_normal((30, 3))
    Y = np.stack([(np.sin(X[:, 0]) + 0.3 * k * X[:, 1] + 0.1 * rng.standard_normal(30))[:, None]
                  for k in range(4)])
    Y = (Y - Y.mean(axis=1, keepdims=True)) / Y.std(axis=1, keepdims=True)
    for iterations in (5, 30):
        with gpytorch.settings.max_cholesky_size(800):
            ref = _fit_batch(torch, gpytorch, X, Y, 1, 1.0, iterations)
        ours = _fit_batch_kron(torch, gpytorch, X, Y, 1, 1.0, iterations)
        for key in ("lengthscales", "Kc", "noise", "mean", "nll"):
            np.testing.assert_allclose(ours[key], ref[key], rtol=1e-7, atol=1e-9, err_msg=key)


def test_mtgp_borrows_a_noisy_task_from_a_clean_correlated_one():
    """Two tasks driven by one posture function, the second observed with noise of 30 % of its
    spread: the MTGP learns the second through the first and predicts it better than an STGP of
    the second alone, in at least 4 of 5 random draws (its whole point, seed 000 §5)."""
    X = _grid()
    wins = 0
    for seed in range(5):
        rng = np.random.default_rng(seed)
        f = _smooth(X)
        Y = np.column_stack([f + 0.001 * rng.normal(size=len(X)),
                             -2 * f + 0.3 * np.std(2 * f) * rng.normal(size=len(X))])
        train = rng.choice(len(X), 40, replace=False)
        test = np.setdiff1d(np.arange(len(X)), train)
        mt = MTGP().fit(X[train], Y[train]).predict(X[test])[:, 1]
        st = STGP().fit(X[train], Y[train, 1]).predict(X[test])
        truth = -2 * f[test]
        wins += np.mean((mt - truth) ** 2) < np.mean((st - truth) ** 2)
    assert wins >= 4


def test_mtgp_reports_the_task_covariance_in_the_tasks_units():
    """Task 2 = 3 x task 1 exactly: the fitted K_c has correlation ~1 and a variance ratio ~9."""
    X = _grid()
    f = _smooth(X)
    m = MTGP().fit(X, np.column_stack([f, 3 * f]))
    K = m.task_covariance_
    assert K[0, 1] / np.sqrt(K[0, 0] * K[1, 1]) > 0.99
    assert K[1, 1] / K[0, 0] == pytest.approx(9.0, rel=0.05)


def test_a_constant_column_is_predicted_as_its_constant_not_learnt():
    X = _grid()
    m = MTGP().fit(X, np.column_stack([_smooth(X), np.ones(len(X))]))
    mu, sd = m.predict(X[:3] + 0.01, return_std=True)
    assert np.all(mu[:, 1] == 1.0) and np.all(sd[:, 1] == 0.0) and list(m.varying_) == [0]


def test_postures_missing_a_task_are_left_out_of_that_model_and_counted():
    X = _grid()
    Y = np.column_stack([_smooth(X), 2 * _smooth(X)])
    Y[:5, 1] = np.nan
    m = MTGP().fit(X, Y)
    assert m.dropped_ == 5 and np.all(np.isfinite(m.predict(X[:5])))


def test_a_model_with_fewer_than_three_complete_postures_is_refused():
    X = _grid()[:5]
    Y = np.column_stack([_smooth(X), [1.0, np.nan, np.nan, np.nan, 2.0]])
    with pytest.raises(InputError, match="2 postures have every task"):
        MTGP().fit(X, Y)


def test_a_model_without_any_complete_posture_is_refused_not_predicted_as_nan():
    X = _grid()[:6]
    Y = np.column_stack([[1.0, 2, 3, np.nan, np.nan, np.nan], [np.nan, np.nan, np.nan, 1.0, 2, 3]])
    with pytest.raises(InputError, match="0 postures have every task"):
        MTGP().fit(X, Y)


def test_grouped_mtgp_leaves_a_mode_seen_at_too_few_postures_unlearnt_and_learns_the_rest():
    X = _grid()
    Y = np.column_stack([_smooth(X), 2 * _smooth(X), np.full(len(X), np.nan)])
    Y[:2, 2] = [5.0, 6.0]      # a mode the fit found at two postures only
    m = GroupedMTGP([[0, 1], [2]]).fit(X, Y)
    pred = m.predict(X[:4])
    assert m.unlearnt_ == [1]
    assert np.all(np.isfinite(pred[:, :2])) and np.all(np.isnan(pred[:, 2]))


def test_a_group_whose_mode_is_lost_at_half_the_postures_splits_so_the_others_keep_their_data():
    # one Kronecker model needs all its tasks at the same postures: kept together, tasks 0 and 1
    # would learn from the half where task 2 was found and extrapolate over the other half
    X = _grid()
    Y = np.column_stack([_smooth(X), 2 * _smooth(X), 3 * _smooth(X)])
    Y[: len(X) // 2, 2] = np.nan
    m = GroupedMTGP([[0, 1, 2]]).fit(X, Y)
    assert m.groups == [[0, 1], [2]]
    assert m.models_[0].dropped_ == 0


def test_a_mode_missed_at_a_few_postures_keeps_its_group():
    # losing a tenth of the postures costs the group-mates less than sharing one model gains them
    X = _grid()
    Y = np.column_stack([_smooth(X), 2 * _smooth(X), 3 * _smooth(X)])
    Y[: len(X) // 10, 2] = np.nan
    assert split_by_postures([[0, 1, 2]], np.isfinite(Y)) == [[0, 1, 2]]


def test_seed_groups_follow_the_seeds_rule():
    """Every parameter in exactly one model of at most 3; eigenvector groups within one mode and
    eigenvector (1X with 1aX, 1Y with 1aY, real and imaginary apart); natural frequencies and damping
    ratios across consecutive modes of one band only."""
    modes = [f"mode{m}" for m in range(10)]
    bands_of = ["low"] * 6 + ["high"] * 4
    tasks = [f"{m}:{p}" for m in modes for p in PARAMS]
    bands = [b for b in bands_of for _ in PARAMS]
    groups = seed_groups(tasks, bands)
    flat = sorted(i for g in groups for i in g)
    assert flat == list(range(len(tasks))) and max(map(len, groups)) <= 3
    for g in groups:
        names = [tasks[i] for i in g]
        kinds = {n.split(":")[1] for n in names}
        if kinds <= {"f_n"} or kinds <= {"zeta"}:
            assert len({bands[i] for i in g}) == 1
        else:
            assert len({n.split(":")[0] for n in names}) == 1
            assert len({n.split(":")[1][:4] for n in names}) == 1           # φL or φR
            assert len({n.rsplit("_", 1)[1] for n in names}) == 1           # re or im
    assert ["mode0:phiR_1X_re", "mode0:phiR_1aX_re"] in [[tasks[i] for i in g] for g in groups]


@pytest.mark.slow
def test_cross_validation_scores_every_gp_learner_on_a_smooth_dependence():
    """Noise-free smooth functions on the seed's grid: CV R² above 0.999 for the STGPs, the grouped
    and the Kronecker MTGP (the grid resolves them; GPs interpolate smooth functions almost exactly).
    Three folds: every posture is still predicted once held out, each model learning from two
    thirds of the grid rather than four fifths, a harder test of the same interpolation (1 - R² is
    1e-7 to 1e-6 with either) at 3/5 of the fits."""
    X = _grid()
    Y = np.column_stack([_smooth(X), 0.01 * _smooth(X) ** 2, np.cos(X[:, 0] + X[:, 2])])
    ts = TrainingSet(X, Y, ("mode0:f_n", "mode1:f_n", "mode0:zeta"), ("low", "low", "low"))
    for learner in ("stgp", "mtgp-grouped", "mtgp"):
        cv = cross_validate(ts, learner, folds=3)
        assert np.all(cv.r2_mean > 0.999), learner
        assert np.all(np.isfinite(cv.predictions))


def _modal_dataset(n_modes=2):
    """A modal dataset over the seed's grid: smooth frequencies, damping and eigenvectors."""
    X = _grid()
    f = _smooth(X)
    modal = np.zeros((len(X), n_modes, 16))
    for m in range(n_modes):
        modal[:, m, 0] = (m + 1) * f
        modal[:, m, 1] = 0.02 + 0.001 * np.sin(X[:, 0] * (m + 1))
        modal[:, m, 2:] = np.cos(np.outer(X[:, 0] + 0.3 * X[:, 2], np.arange(1, 15)) / (m + 2)) * 1e-3
        modal[:, m, 2:8] *= 1e3          # φL dimensionless, φR in s/kg
    ds = xr.Dataset({"modal": (("posture", "mode", "param"), modal),
                     "phiL_1aY": (("posture", "mode"), np.ones((len(X), n_modes), complex))},
                    coords={"x": ("posture", X[:, 0]), "y": ("posture", X[:, 1]),
                            "theta": ("posture", X[:, 2]), "mode": np.arange(n_modes),
                            "mode_band": ("mode", ["low"] * n_modes),
                            "phiL_ref": ("mode", ["1aY"] * n_modes), "param": list(PARAMS)})
    return ds


@pytest.fixture(scope="module")
def one_mode_stgp():
    """Single-task GPs of one mode's parameters over the seed's grid."""
    return PosturePredictor("stgp", vectors="dataset").fit(_modal_dataset(1))


@pytest.mark.slow
def test_saved_predictor_reloads_to_the_same_predictions_without_pickle(grouped_with_residuals, tmp_path):
    _, pred = grouped_with_residuals
    path = pred.save(tmp_path / "p.npz")
    with np.load(path, allow_pickle=False) as z:          # plain arrays only
        meta = json.loads(str(z["meta"]))
    assert meta["model"] == "mtgp-grouped" and meta["params"] == list(PARAMS)
    X = np.array([[1.55, 0.05, 0.3], [1.8, -0.2, 0.0]])
    a, b = pred.predict(X), PosturePredictor.load(path).predict(X)
    np.testing.assert_array_equal(a.modal.values, b.modal.values)
    np.testing.assert_array_equal(a.modal_std.values, b.modal_std.values)


def test_prediction_outside_the_training_hull_warns_and_is_less_certain(one_mode_stgp):
    """1 m beyond the grid the GP reverts towards its mean: flagged, warned, wider spread. (The
    shared predictor learns the vectors as the dataset normalised them: the hull is the postures',
    and f_n is no vector component.)"""
    pred = one_mode_stgp
    with pytest.warns(ExtrapolationWarning, match="1 of 2 postures"):
        out = pred.predict([[1.6, 0.0, 0.0], [2.9, 0.0, 0.0]])
    assert list(out.outside_hull.values) == [False, True]
    sd = out.modal_std.sel(param="f_n").values[:, 0]
    assert sd[1] > 10 * sd[0]


def test_grid_corners_are_inside_the_hull(one_mode_stgp):
    pred = one_mode_stgp
    with warnings.catch_warnings():
        warnings.simplefilter("error", ExtrapolationWarning)
        out = pred.predict(_grid()[[0, -1]])
    assert not out.outside_hull.values.any()


def test_only_gaussian_process_predictors_are_saved(tmp_path):
    pred = PosturePredictor("knn").fit(_modal_dataset(1))
    with pytest.raises(InputError, match="would need pickle"):
        pred.save(tmp_path / "p.npz")


def test_a_file_that_is_not_a_predictor_is_refused(tmp_path):
    bad = tmp_path / "bad.npz"
    np.savez(bad, meta=np.array("{}"))
    with pytest.raises(InputError, match="not an rmbench predictor"):
        PosturePredictor.load(bad)
    with pytest.raises(InputError, match="predictor not found"):
        PosturePredictor.load(tmp_path / "none.npz")


def test_frf_rebuilt_from_parameters_equals_the_modes_own_synthesis():
    """Eq. 15 from the 16 parameters (+ φL at 1aY) gives the mode table's own receptance."""
    from rmbench.robot import Robot, validation_postures
    from rmbench.robot.modes import mode_table

    op = Robot.load("irb6660", tool="dummy").at(validation_postures()[0])
    from rmbench.impact import load_config
    from rmbench.impact.campaign import Campaign

    cfg = load_config("seed_full")
    band = Campaign.build(cfg).bands["low"]
    nominal = op.coordinate_map(("1X", "1Y", "1aX", "1aY"), s_1a=band.s_1a)
    table = mode_table(op.linear.modes(), nominal, nominal, band)
    prm = table.params()[None]                                   # (1, mode, 16)
    ds = xr.Dataset({"modal": (("posture", "mode", "param"), prm),
                     "phiL_1aY": (("posture", "mode"), np.ones((1, len(table)), complex))},
                    coords={"mode": np.arange(len(table)), "param": list(PARAMS)})
    freq = np.linspace(4, 40, 200)
    np.testing.assert_allclose(predicted_frf(ds, freq, 0), table.frf(freq), rtol=1e-10,
                               atol=1e-12 * np.abs(table.frf(freq)).max())


def test_grouped_mtgp_predicts_every_column():
    X = _grid()
    Y = np.column_stack([_smooth(X), 2 * _smooth(X), np.cos(X[:, 2])])
    g = GroupedMTGP([[0, 1], [2]]).fit(X, Y)
    mu, sd = g.predict(X[:4], return_std=True)
    assert mu.shape == sd.shape == (4, 3) and np.all(np.isfinite(mu)) and np.all(sd >= 0)


def test_grouped_mtgp_evaluates_all_its_models_at_once_as_each_would_alone():
    """The grouped predictor pads its models' posteriors to one size and evaluates them in one
    batch; padding must add nothing, whatever the models' task counts, constant tasks, left-out
    postures or an unlearnt group. Round-off only, but amplified: on smooth, near noise-free data
    the GP nearly interpolates, its weights are large and alternate in sign, and the mean is a
    cancelling sum whose evaluation order shows at ~1e-8 relative; 1e-6 still catches any padded
    row or task that contributed."""
    X = _grid()
    Y = np.column_stack([_smooth(X), 2 * _smooth(X) + X[:, 0], np.cos(X[:, 2]), np.full(len(X), 3.0),
                         np.sin(X[:, 1] * 9), np.full(len(X), np.nan)])
    Y[5, 4] = np.nan               # one model drops a posture, so the models' sizes differ
    Y[:2, 5] = [1.0, 2.0]          # seen at two postures only: unlearnt
    g = GroupedMTGP([[0, 1], [2, 3], [4], [5]]).fit(X, Y)
    Xq = np.array([[1.7, 0.1, 0.2], [1.9, -0.15, -0.3], [2.3, 0.0, 0.0]])
    mu, sd = g.predict(Xq, return_std=True)
    for cols, model in zip(g.groups, g.models_):
        if model.posterior_ is None and np.isnan(model.constant_).all():
            assert np.isnan(mu[:, cols]).all() and np.isnan(sd[:, cols]).all()
            continue
        own_mu, own_sd = model.predict(Xq, return_std=True)
        np.testing.assert_allclose(mu[:, cols], own_mu, rtol=1e-6, atol=1e-12)
        # a small posterior sd is √(prior variance − explained variance): its round-off is on the
        # scale of the prior's
        prior_sd = np.sqrt(np.diag(model.task_covariance_)).max()
        np.testing.assert_allclose(sd[:, cols], own_sd, rtol=1e-6, atol=1e-6 * prior_sd)
    assert np.all(sd[:, 3] == 0) and np.all(mu[:, 3] == 3.0)   # a constant task is that constant


@pytest.fixture(scope="module")
def cli_trained(tmp_path_factory):
    """``rmbench predict train`` of one mode's single-task GPs over the seed's grid, run once for the
    CLI tests (they read mode 0 and the 4 x 4 FRF only, which a second mode would not change):
    the exit code and the saved predictor's path."""
    from rmbench.cli.main import main

    folder = tmp_path_factory.mktemp("cli_predictor")
    path = folder / "m.nc"
    _modal_dataset(1).to_netcdf(path, engine="h5netcdf", invalid_netcdf=True)
    pred = folder / "p.npz"
    return main(["predict", "train", str(path), "--model", "stgp", "--out", str(pred)]), pred


def test_cli_trains_saves_and_predicts_at_a_posture(cli_trained, tmp_path, capsys):
    from rmbench.cli.main import main

    code, pred = cli_trained
    assert code == 0
    frf = tmp_path / "h.nc"
    assert main(["predict", "at", str(pred), "--posture", "1600,0,10", "--frf", str(frf), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    mode0 = out["postures"][0]["modes"][0]
    X = np.array([[1.6, 0.0, np.radians(10)]])
    assert mode0["params"]["f_n"] == pytest.approx(_smooth(X)[0], rel=1e-3)   # smooth: GP near-exact
    assert mode0["std"]["f_n"] >= 0 and not out["postures"][0]["outside_hull"]
    H = xr.load_dataset(frf, engine="h5netcdf").H
    assert H.shape[1:] == (H.sizes["freq"], 4, 4) and np.all(np.isfinite(H.values))


def test_cli_warns_about_a_posture_outside_the_training_grid(cli_trained, capsys):
    from rmbench.cli.main import main

    code, pred = cli_trained
    assert code == 0
    assert main(["predict", "at", str(pred), "--posture", "2500,0,0"]) == 0
    out = capsys.readouterr().out
    assert "warning: 1 of 1 postures lie outside" in out and "[outside the training hull]" in out


def test_cli_refuses_a_missing_predictor_in_one_line(tmp_path, capsys):
    from rmbench.cli.main import main

    assert main(["predict", "at", str(tmp_path / "none.npz"), "--posture", "1600,0,0"]) == 2
    err = capsys.readouterr().err
    assert "predictor not found" in err and err.count("\n") == 1


def _with_residuals(ds):
    """Out-of-band terms that vary smoothly over the grid: a stiffness line of a few 1e-9 m/N."""
    from rmbench.modal.residual import RESIDUAL_TERMS

    X = np.column_stack([ds[c].values for c in ("x", "y", "theta")])
    s = _smooth(X)
    r = np.zeros((len(X), 2, len(RESIDUAL_TERMS), 4, 4), complex)
    r[:, :, 0] = 0.5 * s[:, None, None, None]                 # 1/kg
    r[:, :, 1] = 1e-9 * (2 + np.cos(X[:, 2]))[:, None, None, None] * (1 + 0.01j)
    r[:, :, 2] = 2e-10 * s[:, None, None, None]
    return ds.assign(residual=(("posture", "fit_band", "term", "out", "inp"), r)).assign_coords(
        fit_band=["low", "high"], residual_f_max=("fit_band", [40.0, 1400.0]),
        term=list(RESIDUAL_TERMS), out=["1X", "1Y", "1aX", "1aY"], inp=["1X", "1Y", "1aX", "1aY"])


@pytest.fixture(scope="module")
def grouped_with_residuals():
    """The seed's grouped MTGPs of two modes and the bands' out-of-band terms, learnt once for the
    persistence tests, and the dataset they learnt from. Every other posture of the seed's grid: the
    192 term columns' GPs are most of the fitting time, and what a saved predictor holds does not
    depend on how many postures it learnt from."""
    ds = _with_residuals(_modal_dataset()).isel(posture=slice(None, None, 2))
    return ds, PosturePredictor("mtgp-grouped").fit(ds)


@pytest.mark.slow
def test_out_of_band_terms_are_learnt_and_saved_with_the_predictor(grouped_with_residuals, tmp_path):
    """The bands' out-of-band terms are learnt beside the modes and come back from a saved file.
    At a training posture the GP reproduces them to 1 % (smooth, noise-free data: it nearly
    interpolates)."""
    ds, pred = grouped_with_residuals
    X = np.column_stack([ds[c].values for c in ("x", "y", "theta")])[[7]]
    out = pred.predict(X)
    truth = ds.residual.values[7]
    for band in range(2):
        for term in range(3):
            got, want = out.residual.values[0, band, term], truth[band, term]
            assert np.linalg.norm(got - want) < 0.01 * np.linalg.norm(want)
    again = PosturePredictor.load(pred.save(tmp_path / "p.npz")).predict(X)
    np.testing.assert_array_equal(again.residual.values, out.residual.values)
    assert list(again.residual_f_max.values) == [40.0, 1400.0]


def test_a_band_rebuilt_alone_adds_its_out_of_band_terms():
    """predicted_frf(band=…) is that band's modes plus its terms; without ``band`` every mode of
    every band and no terms (the other band's modes are the residual there)."""
    from rmbench.modal.residual import residual_frf

    ds = _with_residuals(_modal_dataset(2))
    freq = np.linspace(10.0, 40.0, 50)
    modes_only = predicted_frf(ds.drop_vars("residual"), freq, 3)
    terms = residual_frf(ds.residual.values[3, 0], freq, 40.0)
    np.testing.assert_allclose(predicted_frf(ds, freq, 3, band="low"), modes_only + terms, rtol=1e-12)
    np.testing.assert_array_equal(predicted_frf(ds, freq, 3), modes_only)


@pytest.mark.parametrize("m", [1, 3])
def test_leave_one_out_residuals_are_those_of_the_model_without_that_posture(m):
    """The block formula gives, to round-off, the residual and predictive standard deviation of
    the same hyperparameters conditioned on every other posture (all tasks there left out)."""
    rng = np.random.default_rng(m)
    n = 10
    X, Y = rng.normal(size=(n, 3)), rng.normal(size=(n, m))
    ls, B = np.array([1.0, 2.0, 0.7]), rng.normal(size=(m, m))
    Kc, noise, mean = B @ B.T + 0.1 * np.eye(m), rng.uniform(0.05, 0.3, m), rng.normal(size=m)
    r, sd = loo_residuals(X, Y, ls, Kc, noise, mean)
    Kt = rbf(X, X, ls)
    for i in range(n):
        rest = np.delete(np.arange(n), i)
        C = np.kron(Kt[np.ix_(rest, rest)], Kc) + np.kron(np.eye(n - 1), np.diag(noise))
        k = np.kron(Kt[i, rest][None], Kc)
        mu = k @ np.linalg.solve(C, (Y[rest] - mean).ravel()) + mean
        var = np.diag(Kc + np.diag(noise) - k @ np.linalg.solve(C, k.T))
        np.testing.assert_allclose(r[i], Y[i] - mu, rtol=1e-8, atol=1e-10)
        np.testing.assert_allclose(sd[i], np.sqrt(var), rtol=1e-8)


def test_calibrated_standard_deviations_are_the_latent_ones_times_the_leave_one_out_factor(one_mode_stgp, tmp_path):
    """``calibrated=True`` multiplies each learnt column's standard deviation by its factor (the
    RMS of its standardised leave-one-out residuals), which a saved predictor keeps."""
    pred = one_mode_stgp
    X = np.array([[1.62, 0.07, 0.1], [1.45, -0.2, -0.3]])
    scale = pred.std_scale()
    assert np.all(np.isfinite(scale.values)) and np.all(scale.values > 0)
    raw, cal = pred.predict(X).modal_std, pred.predict(X, calibrated=True).modal_std
    for p in ("f_n", "zeta"):
        np.testing.assert_allclose(cal.sel(param=p).values, raw.sel(param=p).values * scale.sel(param=p).values,
                                   rtol=1e-12)
    again = PosturePredictor.load(pred.save(tmp_path / "p.npz"))
    np.testing.assert_array_equal(again.std_scale().values, scale.values)


def test_leave_one_out_prediction_is_the_posterior_of_the_other_postures():
    """``source="loo"`` at a training posture is the same hyperparameters' posterior on every
    other posture (a refit's mean and predictive deviation, to round-off); away from the training
    postures it is the ordinary posterior, and ``source="data"`` gives the training data back."""
    X = _grid()[::3]
    rng = np.random.default_rng(4)
    f = _smooth(X)
    Y = np.column_stack([f, 0.5 * f ** 2]) + 0.01 * rng.normal(size=(len(X), 2))
    model = MTGP(iterations=30).fit(X, Y)
    post = model.posterior_
    Ys = (Y - model.y_mean_) / model.y_scale_
    for i in (0, len(X) // 2):
        rest = np.delete(np.arange(len(X)), i)
        alone = KronPosterior.build(post.X[rest], Ys[rest], post.lengthscales, post.Kc, post.noise, post.mean)
        mu, sd = alone.predict(post.X[i:i + 1], return_std=True)
        got_mu, got_sd = model.predict(X[i:i + 1], return_std=True, source="loo")
        np.testing.assert_allclose(got_mu, mu * model.y_scale_ + model.y_mean_, rtol=1e-8)
        # the predictive deviation holds the noise the latent one leaves out
        np.testing.assert_allclose(got_sd ** 2, (sd ** 2 + post.noise) * model.y_scale_ ** 2, rtol=1e-7)
    away = X[:2] + 0.013
    np.testing.assert_array_equal(model.predict(away, source="loo"), model.predict(away))
    np.testing.assert_allclose(model.predict(X[:4], source="data"), Y[:4], rtol=1e-12)
    assert np.isnan(model.predict(away, source="data")).all()


def test_a_saved_predictor_keeps_its_leave_one_out_predictions(one_mode_stgp, tmp_path):
    pred = one_mode_stgp
    again = PosturePredictor.load(pred.save(tmp_path / "p.npz"))
    X = pred.X_train_[:5]
    for source in ("loo", "data"):
        a, b = pred.predict(X, source=source), again.predict(X, source=source)
        np.testing.assert_array_equal(a.modal.values, b.modal.values)
    # left out, a training posture's prediction moves; its data do not
    assert not np.allclose(pred.predict(X, source="loo").modal.values, pred.predict(X).modal.values)


def test_leave_one_out_predictions_need_a_gaussian_process_learner():
    pred = PosturePredictor("knn", vectors="dataset").fit(_modal_dataset(1))
    with pytest.raises(InputError, match="Gaussian-process"):
        pred.predict(pred.X_train_[:2], source="loo")


def test_a_grid_prediction_is_the_posture_by_posture_one(one_mode_stgp):
    """Location and angle factors of the kernel (a path's grid) give each pose's means to round-off
    (the GPs' weights cancel to ~1e-11 of a column's scale)."""
    pred = one_mode_stgp
    xy = np.array([[1.45, -0.12], [1.62, 0.07], [1.8, 0.2]])
    theta = np.radians([-30.0, 0.0, 25.0, 50.0])
    grid = pred.predict_grid(xy, theta)
    X = np.column_stack([np.repeat(xy, len(theta), axis=0), np.tile(theta, len(xy))])
    each = pred.predict(X, std=False)
    np.testing.assert_array_equal(grid.x.values, X[:, 0])
    np.testing.assert_array_equal(grid.theta.values, X[:, 2])
    scale = np.nanmax(np.abs(each.modal.values), axis=0)
    assert np.all(np.abs(grid.modal.values - each.modal.values) <= 1e-9 * scale)


def test_a_predictor_summarises_what_it_learnt_from_which_postures(one_mode_stgp):
    text = one_mode_stgp.summary()
    n = len(one_mode_stgp.tasks_)
    assert text.startswith(f"stgp predictor: 1 modes (low: 1); {n} of {n} parameters learnt from 112 postures")
    assert "training postures: x " in text and "θ -60-60°" in text


def test_a_predictor_as_a_dict_is_strict_json(one_mode_stgp):
    d = json.loads(json.dumps(one_mode_stgp.to_dict(), allow_nan=False))
    assert d["model"] == "stgp" and d["modes"] == [0] and d["n_postures"] == 112
    assert d["posture_range"]["theta_rad"] == pytest.approx([-np.pi / 3, np.pi / 3])


def test_a_predictor_plots_its_training_postures(one_mode_stgp):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ax = one_mode_stgp.plot()
    assert isinstance(ax, matplotlib.axes.Axes)
    assert len(ax.collections) == 1 and len(ax.collections[0].get_offsets()) == 112
    plt.close(ax.figure)
