"""The posture predictors' learning baselines and their cross-validation (issue 15, first part)."""

import json

import numpy as np
import pytest
import xarray as xr
from _posture_grid import grid as _grid
from _posture_grid import smooth as _smooth

from rmbench.errors import InputError
from rmbench.predict import IDWNeighbours, TrainingSet, cross_validate, folds_of, training_set


def test_idw_returns_training_values_at_training_points():
    X = _grid()
    y = _smooth(X)
    model = IDWNeighbours().fit(X, y)
    np.testing.assert_allclose(model.predict(X), y, rtol=1e-12)
    assert 2 <= model.k_ <= 20


def test_idw_reproduces_a_constant_exactly_between_points():
    X = _grid()
    model = IDWNeighbours(k=5).fit(X, np.full(len(X), 7.5))
    np.testing.assert_allclose(model.predict(X[:10] + 0.01), 7.5, rtol=1e-12)


@pytest.mark.parametrize("learner", ["knn", "rf", "gb"])
def test_learners_predict_a_smooth_posture_dependence(learner):
    """On the seed's 112-posture grid a smooth function of the posture is learnt to R² > 0.9 in
    5-fold cross-validation (the grid's spacing resolves it)."""
    X = _grid()
    ts = TrainingSet(X, _smooth(X)[:, None], ("mode0:f_n",))
    cv = cross_validate(ts, learner)
    assert cv.r2_mean[0] > 0.9 and cv.r2_folds.shape == (1, 5)


def test_elastic_net_learns_a_linear_dependence():
    X = _grid()
    ts = TrainingSet(X, (1 + 2 * X[:, 0] - X[:, 1] + 0.1 * X[:, 2])[:, None], ("mode0:f_n",))
    assert cross_validate(ts, "enet").r2_mean[0] > 0.99


def test_angle_split_holds_out_every_posture_of_one_angle_per_fold():
    X = _grid()
    parts = folds_of(X, "angle", 5)
    assert len(parts) == 7
    for p in parts:
        assert len(p) == 16 and np.ptp(X[p, 2]) == 0


def test_fewer_postures_than_folds_is_refused():
    X = _grid()[:4]
    with pytest.raises(InputError, match="4 postures cannot make 5 folds"):
        cross_validate(TrainingSet(X, _smooth(X)[:, None], ("mode0:f_n",)), "knn")


def test_constant_and_missing_parameters_are_skipped_with_a_reason():
    X = _grid()
    Y = np.column_stack([_smooth(X), np.full(len(X), 3.0), np.full(len(X), np.nan)])
    cv = cross_validate(TrainingSet(X, Y, ("a", "b", "c")), "knn")
    assert np.isfinite(cv.r2_mean[0])
    assert "constant" in cv.skipped["b"] and "no finite" in cv.skipped["c"]


def test_a_mode_missing_at_some_postures_drops_those_rows_only():
    X = _grid()
    y = _smooth(X)
    y[::9] = np.nan
    cv = cross_validate(TrainingSet(X, y[:, None], ("mode0:f_n",)), "knn")
    assert cv.r2_mean[0] > 0.9


def _modal_dataset(path):
    X = _grid()
    modal = np.stack([_smooth(X)[:, None] * np.array([1.0, 0.01]),
                      (2 * _smooth(X))[:, None] * np.array([1.0, 0.02])], axis=1)   # (posture, mode, param)
    ds = xr.Dataset({"modal": (("posture", "mode", "param"), modal)},
                    coords={"x": ("posture", X[:, 0]), "y": ("posture", X[:, 1]),
                            "theta": ("posture", X[:, 2]), "mode": [0, 1], "param": ["f_n", "zeta"]})
    ds.to_netcdf(path)
    return path


def test_training_set_reads_a_modal_dataset(tmp_path):
    ts = training_set(xr.open_dataset(_modal_dataset(tmp_path / "m.nc")))
    assert ts.X.shape == (112, 3) and ts.tasks == ("mode0:f_n", "mode0:zeta", "mode1:f_n", "mode1:zeta")


def test_cli_cross_validates_a_modal_dataset(tmp_path, capsys):
    from rmbench.cli.main import main

    path = _modal_dataset(tmp_path / "m.nc")
    assert main(["predict", "cv", str(path), "--model", "knn", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["r2_mean"] > 0.9 and set(out["tasks"]) == {"mode0:f_n", "mode0:zeta", "mode1:f_n", "mode1:zeta"}


def test_cli_refuses_a_dataset_without_modal_parameters(tmp_path, capsys):
    from rmbench.cli.main import main

    path = tmp_path / "empty.nc"
    xr.Dataset({"a": ("posture", np.zeros(3))}).to_netcdf(path)
    assert main(["predict", "cv", str(path)]) == 2
    err = capsys.readouterr().err
    assert "no variable 'modal'" in err and err.count("\n") == 1


def test_stgp_learns_a_smooth_posture_dependence_almost_exactly():
    """A noise-free smooth function on the seed's grid: the GP's CV R² is 1 to 1e-4."""
    X = _grid()
    cv = cross_validate(TrainingSet(X, _smooth(X)[:, None], ("mode0:f_n",)), "stgp")
    assert cv.r2_mean[0] > 0.9999


def test_stgp_estimates_the_noise_and_is_less_sure_away_from_the_data():
    """Noise of 0.05 added to the targets: the fitted σ_n within 25 % of it (112 points give the
    estimate ~7 % scatter); the predictive spread 1 m outside the grid exceeds that at a point
    inside it."""
    from rmbench.predict.gp import STGP

    X = _grid()
    y = _smooth(X) + 0.05 * np.random.default_rng(3).standard_normal(len(X))
    gp = STGP().fit(X, y)
    assert gp.noise_ == pytest.approx(0.05, rel=0.25)
    _, sd = gp.predict(np.array([[1.6, 0.0, 0.0], [2.9, 0.0, 0.0]]), return_std=True)
    assert sd[1] > 3 * sd[0]


def test_cross_validation_summarises_the_mean_r2_and_the_skipped_parameters():
    X = _grid()
    Y = np.column_stack([_smooth(X), np.full(len(X), 3.0)])
    cv = cross_validate(TrainingSet(X, Y, ("a", "b")), "knn")
    lines = cv.summary().splitlines()
    assert lines[0] == (f"knn, random split: mean R² {cv.r2_mean[0]:.3f} over 1 parameters "
                        f"(mean spread over folds {cv.r2_std[0]:.3f}); 1 skipped")
    assert lines[1].startswith("  a: R² ") and lines[2].startswith("  skipped b: ")
