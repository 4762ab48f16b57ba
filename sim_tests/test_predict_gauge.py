"""The gauge in which the posture predictors learn mode vectors (rmbench.predict.gauge): what it
changes (the arbitrary complex factor of φR, φL) and what it must not (the FRF, the dataset's
normalisation of the answers)."""

import json

import numpy as np
import pytest
import xarray as xr
from _posture_grid import grid as _grid

from rmbench.predict import PosturePredictor
from rmbench.predict.gauge import from_gauge, gauge_directions, to_gauge, vectors
from rmbench.robot.modes import PARAMS


def _turning_mode_dataset():
    """One mode whose shape turns from X (α = 0.1 rad) towards Y (α = 1.4 rad) across the grid's x,
    with a small posture-dependent phase: normalised on its 1aY element (DATA.md's default), which
    is 0.9 sin α, φL reaches cos α / (0.9 sin α) ≈ 11 at the grid's near end."""
    X = _grid()
    alpha = 0.1 + 1.3 * (X[:, 0] - 1.3) / 0.6
    shape = np.column_stack([np.cos(alpha), np.sin(alpha), 0.9 * np.cos(alpha), 0.9 * np.sin(alpha)])
    phase = np.exp(0.05j * X[:, 2])[:, None]
    phi_l, phi_r = shape * phase, 1e-3 * shape * np.exp(0.02j * X[:, 1])[:, None]
    b = phi_l[:, 3:4]
    phi_l, phi_r = phi_l / b, phi_r * b
    modal = np.zeros((len(X), 1, 16))
    modal[:, 0, 0], modal[:, 0, 1] = 20 + 3 * X[:, 0], 0.02
    names = {"phiL": ("1X", "1Y", "1aX"), "phiR": ("1X", "1Y", "1aX", "1aY")}
    for side, vec in (("phiL", phi_l), ("phiR", phi_r)):
        for k, c in enumerate(names[side]):
            modal[:, 0, PARAMS.index(f"{side}_{c}_re")] = vec[:, k].real
            modal[:, 0, PARAMS.index(f"{side}_{c}_im")] = vec[:, k].imag
    return xr.Dataset({"modal": (("posture", "mode", "param"), modal),
                       "phiL_1aY": (("posture", "mode"), phi_l[:, 3:4])},
                      coords={"x": ("posture", X[:, 0]), "y": ("posture", X[:, 1]),
                              "theta": ("posture", X[:, 2]), "mode": [0], "mode_band": ("mode", ["low"]),
                              "phiL_ref": ("mode", ["1aY"]), "param": list(PARAMS)})


def _residues(ds):
    phi_l, phi_r = vectors(ds["modal"].values, ds["phiL_1aY"].values)
    return np.einsum("pmi,pmj->pmij", phi_r, phi_l)


def test_the_gauge_leaves_every_modes_residues_unchanged():
    """φR φLᵀ (what the FRF is built from, Eq. 15) does not depend on the factor the gauge picks."""
    ds = _turning_mode_dataset()
    gauged = to_gauge(ds, gauge_directions(ds)[0])
    np.testing.assert_allclose(_residues(gauged), _residues(ds), rtol=1e-12, atol=1e-18)


def test_gauge_and_back_restores_the_dataset_normalisation():
    ds = _turning_mode_dataset()
    gauged = to_gauge(ds, gauge_directions(ds)[0])
    modal, ay = from_gauge(gauged["modal"].values, gauged["phiL_1aY"].values, ["1aY"])
    np.testing.assert_allclose(modal, ds["modal"].values, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(ay, 1.0, rtol=0, atol=1e-15)


def test_a_turning_mode_is_gauged_on_a_direction_that_never_nears_zero():
    """The shape turns through 74°: its principal direction stays within 37° of every posture's
    (projection ≥ cos 37° ≈ 0.8), while its best single element falls to sin 0.1 ≈ 10 % — so the
    gauged φL stays bounded where the dataset's reaches 11."""
    ds = _turning_mode_dataset()
    v, worst = gauge_directions(ds)
    assert worst[0] > 0.75
    phi_l, _ = vectors(to_gauge(ds, v)["modal"].values, to_gauge(ds, v)["phiL_1aY"].values)
    phi_l_dataset, _ = vectors(ds["modal"].values, ds["phiL_1aY"].values)
    assert np.abs(phi_l).max() <= 1 + 1e-12 and np.abs(phi_l_dataset).max() > 10
    assert np.all(np.abs(np.angle(np.einsum("pmk,mk->pm", phi_l, v.conj())))) < 1e-12   # vᴴφL real > 0


def test_first_order_standard_deviations_of_the_dataset_normalisation_match_sampling():
    """Small independent scatter on the gauge's parts, carried through the division by the
    reference element: the linearised spread agrees with 20 000 samples within their own
    sampling error (~1 %) plus the linearisation's (σ/|φ| = 1 %)."""
    rng = np.random.default_rng(3)
    modal = rng.normal(size=(1, 1, 16))
    ay = np.array([[0.6 + 0.3j]])
    sd = np.full((1, 1, 16), 0.003)
    sd_ay = np.array([[0.003 + 0.003j]])
    _, _, got, _ = from_gauge(modal, ay, ["1aY"], sd, sd_ay)
    draws = modal + sd * rng.normal(size=(20000, 1, 16))
    draws_ay = ay + sd_ay.real * rng.normal(size=(20000, 1)) + 1j * sd_ay.imag * rng.normal(size=(20000, 1))
    sampled = from_gauge(draws, draws_ay, ["1aY"])[0].std(axis=0)
    vec = [PARAMS.index(p) for p in PARAMS[2:]]
    np.testing.assert_allclose(got[0, 0, vec], sampled[0, vec], rtol=0.04)


def test_the_predictor_learns_in_the_gauge_and_answers_in_the_datasets_normalisation():
    """Held out at 3 postures of the turning mode: φL at the reference element is exactly 1 (with
    no spread), and the rebuilt residues are within 2 % of the truth (a smooth turn the GP follows)."""
    ds = _turning_mode_dataset()
    test = np.array([5, 60, 100])
    train = ds.isel(posture=np.setdiff1d(np.arange(ds.sizes["posture"]), test))
    pred = PosturePredictor("stgp").fit(train)
    out = pred.predict(np.column_stack([ds.x.values[test], ds.y.values[test], ds.theta.values[test]]))
    assert np.all(out.phiL_1aY.values == 1.0)
    true, got = _residues(ds.isel(posture=test)), _residues(out)
    err = np.linalg.norm(got - true, axis=(-2, -1)) / np.linalg.norm(true, axis=(-2, -1))
    assert err.max() < 0.02


@pytest.fixture(scope="module")
def cli_trained(tmp_path_factory):
    """``rmbench predict train`` of the turning mode with each vector normalisation, run once for
    the tests of this file: ``{vectors: (exit code, saved predictor's path)}``."""
    from rmbench.cli.main import main

    folder = tmp_path_factory.mktemp("cli_predictors")
    path = folder / "m.nc"
    _turning_mode_dataset().to_netcdf(path, engine="h5netcdf", invalid_netcdf=True)
    trained = {}
    for vectors in ("dataset", "gauge"):
        out = folder / f"{vectors}.npz"
        trained[vectors] = main(["predict", "train", str(path), "--model", "stgp", "--vectors", vectors,
                                 "--out", str(out)]), out
    return trained


def test_a_predictor_saved_before_the_gauge_still_answers_in_the_dataset_normalisation(cli_trained, tmp_path):
    code, path = cli_trained["dataset"]      # the turning mode's single-task GPs, vectors="dataset"
    assert code == 0
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    assert meta.pop("vectors") == "dataset"
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "old.npz", **arrays)
    assert PosturePredictor.load(tmp_path / "old.npz").vectors == "dataset"


def test_cli_train_keeps_the_chosen_vector_normalisation(cli_trained):
    for vectors in ("dataset", "gauge"):
        code, out = cli_trained[vectors]
        assert code == 0
        assert PosturePredictor.load(out).vectors == vectors


def test_a_mode_missing_at_some_postures_is_gauged_without_numpy_warnings():
    """NaN where the fit did not find the mode is the answer there, not a numerical problem: no
    "invalid value" warning reaches the user (the demo printed three). Every other posture of the
    grid: how missing values pass through the gauge does not depend on how many postures there are."""
    import warnings

    ds = _turning_mode_dataset().isel(posture=slice(None, None, 2))
    ds["modal"].values[:3] = np.nan
    ds["phiL_1aY"].values[:3] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        out = PosturePredictor("stgp").fit(ds).predict([[1.6, 0.0, 0.0]])
    assert np.isfinite(out.modal.values).all()
