"""UFF55 complex-mode export and the modal CSV table, checked through pyuff's reader."""

import csv
import math

import numpy as np
import pyuff
import pytest
import xarray as xr

from rmbench.errors import InputError
from rmbench.io import write_modal_csv, write_uff55

PARAMS = ["f_n", "zeta",
          "phiL_1X_re", "phiL_1X_im", "phiL_1aX_re", "phiL_1aX_im", "phiL_1Y_re", "phiL_1Y_im",
          "phiR_1X_re", "phiR_1X_im", "phiR_1aX_re", "phiR_1aX_im", "phiR_1Y_re", "phiR_1Y_im",
          "phiR_1aY_re", "phiR_1aY_im"]
# E13.5 keeps 6 significant digits: half a unit of the 6th is at most 5e-6 of the value
E13_RTOL = 5e-6


def modal_dataset(n_postures=3, seed=0):
    """4 modes (2 low, 2 high) at 3 postures; posture 1 failed; mode 2 not identified at posture 2."""
    rng = np.random.default_rng(seed)
    n_modes = 4
    shape = (n_postures, n_modes)
    modal = np.empty(shape + (16,))
    modal[..., 0] = np.array([11.3, 27.9, 612.4, 1033.7]) * rng.uniform(0.97, 1.03, shape)
    modal[..., 1] = rng.uniform(0.005, 0.08, shape)
    modal[..., 2:8] = rng.normal(0.0, 1.0, shape + (6,))  # φL, dimensionless
    modal[..., 8:16] = rng.normal(0.0, 1e-7, shape + (8,)) * 10 ** rng.uniform(-2, 0, shape + (8,))
    ok = np.ones(n_postures, bool)
    ok[1] = False
    modal[1] = np.nan
    modal[2, 2] = np.nan
    std = np.abs(modal) * 0.01
    return xr.Dataset(
        {"modal": (("posture", "mode", "param"), modal),
         "modal_std": (("posture", "mode", "param"), std)},
        coords={"posture": np.arange(n_postures), "mode": np.arange(n_modes),
                "mode_band": ("mode", ["low", "low", "high", "high"]), "param": PARAMS,
                "x": ("posture", rng.uniform(1.3, 1.9, n_postures)),
                "y": ("posture", rng.uniform(-0.3, 0.3, n_postures)),
                "theta": ("posture", rng.uniform(-1.0, 1.0, n_postures)),
                "ok": ("posture", ok)},
        attrs={"created": "2025-03-04T10:11:12"})


def shapes(prm):
    """φR and φL (1aY = 1) of one mode's parameters, in 1X 1aX 1Y 1aY order."""
    phi_l = np.append(prm[2:8:2] + 1j * prm[3:8:2], 1.0)
    phi_r = prm[8:16:2] + 1j * prm[9:16:2]
    return phi_r, phi_l


def read55(path):
    """All datasets of a file through pyuff's reader (it returns a lone dataset unwrapped)."""
    sets = pyuff.UFF(str(path)).read_sets()
    return sets if isinstance(sets, list) else [sets]


def test_files_per_measured_posture(tmp_path):
    ds = modal_dataset()
    written = write_uff55(ds, tmp_path / "out")
    names = [p.name for p in written]
    assert names == ["posture_0000_modes.uff", "posture_0000_left.uff",
                     "posture_0002_modes.uff", "posture_0002_left.uff"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == sorted(names)  # no temp files
    types = pyuff.UFF(str(written[2])).get_set_types()
    assert list(types) == [55, 55, 55]  # mode 2 not identified at posture 2: left out


@pytest.mark.parametrize("kind", ["modes", "left"], ids=["phiR", "phiL"])
def test_round_trip_through_pyuff(tmp_path, kind):
    ds = modal_dataset()
    write_uff55(ds, tmp_path)
    modal = ds["modal"].values
    for p in (0, 2):
        sets = read55(tmp_path / f"posture_{p:04d}_{kind}.uff")
        modes = [m for m in range(4) if np.all(np.isfinite(modal[p, m]))]
        assert [s["mode_n"] for s in sets] == [m + 1 for m in modes]
        for s, m in zip(sets, modes):
            prm = modal[p, m]
            assert (s["model_type"], s["analysis_type"], s["data_ch"], s["spec_data_type"],
                    s["data_type"], s["n_data_per_node"], s["load_case"]) == (1, 3, 2, 8, 5, 3, 1)
            # eigenvalue: f_n = |λ| / 2π, ζ = −Re λ / |λ|
            f_n, zeta = abs(s["eig"]) / (2 * np.pi), -s["eig"].real / abs(s["eig"])
            assert f_n == pytest.approx(prm[0], rel=E13_RTOL)
            assert zeta == pytest.approx(prm[1], rel=2 * E13_RTOL)
            assert s["modal_a"] == 1.0
            np.testing.assert_allclose(s["modal_b"], -s["eig"], rtol=0)
            # node 1 = tool tip, node 2 = point 1a; r1 = X, r2 = Y, r3 = Z
            phi_r, phi_l = shapes(prm)
            phi = phi_r if kind == "modes" else phi_l
            assert list(s["node_nums"]) == [1, 2]
            got = np.array([s["r1"][0], s["r1"][1], s["r2"][0], s["r2"][1]])  # 1X 1aX 1Y 1aY
            for part in (np.real, np.imag):
                assert np.all(np.abs(part(got) - part(phi)) <= E13_RTOL * np.abs(part(phi)))
            assert np.all(s["r3"] == 0)
            # full precision of f_n and ζ in ID line 5
            tag, mode, _, f_text, _, z_text = s["id5"].split()
            assert (tag, int(mode), float(f_text), float(z_text)) == ("rmbench-mode", m, prm[0], prm[1])
            assert s["id1"].startswith(f"rmbench mode {m} ({ds.mode_band.values[m]} band)")


def test_records_parse_as_pyuffs_own(tmp_path):
    """Our writer against pyuff's: the same mode written by both parses to the same values."""
    ds = modal_dataset()
    write_uff55(ds, tmp_path)
    ours = read55(tmp_path / "posture_0000_modes.uff")[1]
    prm = ds["modal"].values[0, 1]
    phi_r, _ = shapes(prm)
    omega = 2 * np.pi * prm[0]
    eig = -prm[1] * omega + 1j * omega * np.sqrt(1 - prm[1] ** 2)
    theirs_path = tmp_path / "pyuff.uff"
    pyuff.UFF(str(theirs_path)).write_sets(
        pyuff.prepare_55(model_type=1, analysis_type=3, data_ch=2, spec_data_type=8, data_type=5,
                         n_data_per_node=3, load_case=1, mode_n=2, eig=eig, modal_a=1.0 + 0j,
                         modal_b=-eig, node_nums=np.array([1, 2]), r1=phi_r[[0, 1]],
                         r2=phi_r[[2, 3]], r3=np.zeros(2, complex)), mode="overwrite")
    theirs = pyuff.UFF(str(theirs_path)).read_sets()
    for key in ("eig", "modal_a", "modal_b", "r1", "r2", "r3", "mode_n", "analysis_type", "data_ch"):
        np.testing.assert_array_equal(ours[key], theirs[key], err_msg=key)


def test_replaces_existing_files(tmp_path):
    (tmp_path / "posture_0000_modes.uff").write_text("old")
    write_uff55(modal_dataset(), tmp_path)
    assert len(read55(tmp_path / "posture_0000_modes.uff")) == 4


def test_without_optional_coordinates(tmp_path):
    ds = modal_dataset().drop_vars(["x", "y", "theta", "ok", "mode_band", "modal_std"])
    written = write_uff55(ds, tmp_path)
    # every posture counts as measured; posture 1 has no identified mode, so no files
    assert [p.name for p in written][::2] == ["posture_0000_modes.uff", "posture_0002_modes.uff"]
    s = read55(written[0])[0]
    assert s["id1"].startswith("rmbench mode 0 right eigenvector")
    assert "x=nan mm" in s["id4"]


@pytest.mark.parametrize("with_std", [True, False], ids=["with_std", "without_std"])
def test_modal_csv(tmp_path, with_std):
    ds = modal_dataset()
    if not with_std:
        ds = ds.drop_vars("modal_std")
    path = write_modal_csv(ds, tmp_path / "modes.csv")
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    header = ["posture", "x_mm", "y_mm", "theta_deg", "mode", "band", *PARAMS]
    if with_std:
        header += [f"{p}_std" for p in PARAMS]
    header += ["phiL_ref", "phiL_1aY_re", "phiL_1aY_im"]
    assert list(rows[0]) == header
    assert [(int(r["posture"]), int(r["mode"])) for r in rows] == [(p, m) for p in (0, 2) for m in range(4)]
    for r in rows:
        p, m = int(r["posture"]), int(r["mode"])
        assert float(r["x_mm"]) == ds.x.values[p] * 1000
        assert float(r["theta_deg"]) == math.degrees(ds.theta.values[p])
        assert r["band"] == ds.mode_band.values[m]
        got = np.array([float(r[c]) for c in PARAMS])
        np.testing.assert_array_equal(got, ds["modal"].values[p, m])  # exact, NaN included
        if with_std:
            np.testing.assert_array_equal([float(r[f"{c}_std"]) for c in PARAMS],
                                          ds["modal_std"].values[p, m])


def test_modal_csv_carries_the_fit_verdict(tmp_path):
    """Issue 12: where the dataset has them, each row says whether its band's fit at that posture
    is ok and whether the mode is uncertain."""
    ds = modal_dataset()
    fit_ok = np.array([[True, False], [False, False], [True, True]])
    uncertain = np.zeros((3, 4), bool)
    uncertain[0, 3] = True
    ds["fit_ok"] = (("posture", "fit_band"), fit_ok)
    ds = ds.assign_coords(fit_band=["low", "high"])
    ds["mode_uncertain"] = (("posture", "mode"), uncertain)
    path = write_modal_csv(ds, tmp_path / "modes.csv")
    with open(path, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0])[-2:] == ["fit_ok", "uncertain"]
    got = {(int(r["posture"]), int(r["mode"])): (r["fit_ok"], r["uncertain"]) for r in rows}
    assert got[(0, 0)] == ("true", "false") and got[(0, 2)] == ("false", "false")
    assert got[(0, 3)] == ("false", "true") and got[(2, 3)] == ("true", "false")


def test_param_order_does_not_matter(tmp_path):
    ds = modal_dataset()
    shuffled = ds.isel(param=np.random.default_rng(1).permutation(16)).transpose("param", "mode", "posture")
    write_modal_csv(ds, tmp_path / "a.csv")
    write_modal_csv(shuffled, tmp_path / "b.csv")
    assert (tmp_path / "a.csv").read_text() == (tmp_path / "b.csv").read_text()


def _renamed(ds, old, new):
    return ds.assign_coords(param=[new if p == old else p for p in PARAMS])


@pytest.mark.parametrize("edit, match", [
    (lambda ds: ds.drop_vars("modal"), "no variable 'modal'"),
    (lambda ds: _renamed(ds, "phiR_1aY_im", "phiL_1aY_im"),
     r"missing \['phiR_1aY_im'\], unexpected \['phiL_1aY_im'\]"),
    (lambda ds: ds.isel(param=slice(0, 14)), r"missing \['phiR_1aY_re', 'phiR_1aY_im'\]"),
    (lambda ds: ds.drop_vars("param"), "has no param coordinate"),
    (lambda ds: ds.assign(modal=ds["modal"].isel(posture=0)), r"dimensions \(posture, mode, param\)"),
    (lambda ds: ds.assign(modal=ds["modal"] + 0j), "real numbers"),
    (lambda ds: ds.assign(modal_std=ds["modal_std"].isel(mode=0)), r"modal_std must have dimensions"),
    (lambda ds: ds.to_array(), "needs an xarray Dataset"),
], ids=["no_modal", "wrong_label", "missing_labels", "no_param_coord", "wrong_dims", "complex",
        "std_dims", "not_dataset"])
@pytest.mark.parametrize("writer", [write_uff55, write_modal_csv], ids=["uff55", "csv"])
def test_malformed_dataset(tmp_path, writer, edit, match):
    with pytest.raises(InputError, match=match):
        writer(edit(modal_dataset()), tmp_path / "out")


@pytest.mark.parametrize("zeta", [1.0, -1.5], ids=["critical", "negative_overdamped"])
def test_no_complex_pole(tmp_path, zeta):
    ds = modal_dataset()
    ds["modal"][2, 1, 1] = zeta
    with pytest.raises(InputError, match=r"posture 2, mode 1: .*\|zeta\| < 1"):
        write_uff55(ds, tmp_path)


def test_unwritable_directory(tmp_path):
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="cannot create the UFF directory"):
        write_uff55(modal_dataset(), tmp_path / "file" / "sub")


def test_renormalised_mode_keeps_its_phil_1ay(tmp_path):
    """A mode that fixes φL at 1X (METHODS.md §2 fallback) writes its true 1aY element, not 1."""
    ds = modal_dataset()
    phi_1ay = np.full((ds.sizes["posture"], ds.sizes["mode"]), 1.0 + 0j)
    phi_1ay[:, 1] = 0.02 - 0.01j
    ds = ds.assign(phiL_1aY=(("posture", "mode"), phi_1ay)).assign_coords(
        phiL_ref=("mode", ["1aY", "1X", "1aY", "1aY"]))
    with open(write_modal_csv(ds, tmp_path / "m.csv"), newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["mode"] == "1"]
    assert all(r["phiL_ref"] == "1X" for r in rows)
    assert all(complex(float(r["phiL_1aY_re"]), float(r["phiL_1aY_im"])) == 0.02 - 0.01j for r in rows)
    left = (tmp_path / "uff")
    write_uff55(ds, left)
    text = (left / "posture_0000_left.uff").read_text()
    assert "left eigenvector phiL, 1X = 1" in text
