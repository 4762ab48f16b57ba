"""HTML reports: each kind renders in headless Chromium with a clean console and every plot drawn;
the page is self-contained; the data the page decodes are the file's; user strings cannot inject
markup; bad input gets one line."""

import json
import re
import warnings

import numpy as np
import pytest
import xarray as xr

from rmbench.impact import open_campaign, parse_config, run_campaign
from rmbench.impact.config import default_bands
from rmbench.report.page import Page, script_json


def _bands_at_half_density() -> str:
    """The default bands (:func:`rmbench.impact.config.default_bands`, the seed's) as TOML, their
    line spacing doubled."""
    out = []
    for name, band in default_bands().items():
        fields = band.model_dump(exclude_defaults=True) | {"line_spacing": 2 * band.line_spacing}
        tables = {k: fields.pop(k) for k in list(fields) if isinstance(fields[k], dict)}
        out += [f"[bands.{name}]"] + [f"{k} = {json.dumps(v)}" for k, v in fields.items()]
        for sub, values in tables.items():
            out += [f"[bands.{name}.{sub}]"] + [f"{k} = {json.dumps(v)}" for k, v in values.items()]
    return "\n".join(out) + "\n"


# The seed's two bands at half their line density (0.25 Hz, 4 Hz instead of 0.125 Hz, 2 Hz): what
# the reports draw and decode does not depend on the lines' count, and every mode keeps several
# lines in its half-power band (the first, 7.8 Hz at ζ = 4 %: 0.66 Hz, 2.6 lines; the high band's,
# ≥ 44 Hz: 11 lines), so the fits find the same 6 + 4 modes at every posture, all fit_ok, in about
# 40 % less time (the modal fits are this file's largest cost: here, and in the commands that fit).
SMALL = """
seed = 3
method = "linear"
[robot]
tool = "dummy"
[grid]
kind = "product"
x_mm = [1600, 1800]
y_mm = [-100, 100]
theta_deg = [0, 20]
""" + _bands_at_half_density()

@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A small linear campaign, its modal fit, a predictor, a controller with its runs, a tracker
    gap diagnosis: every kind of file `rmbench report` reads."""
    tmp = tmp_path_factory.mktemp("report")
    campaign = tmp / "campaign.nc"
    run_campaign(parse_config(SMALL), campaign, toml=SMALL, workers=0, progress=False)
    from rmbench.impact.dataset import save
    from rmbench.modal.campaign_fit import fit_campaign

    fit = fit_campaign(open_campaign(campaign), workers=0)
    fit.attrs["upstream"] = str(campaign)
    save(fit, tmp / "modal.nc")
    # two of its postures: what a command that fits while it plots needs, at a quarter of the fits
    save(xr.load_dataset(campaign).isel(posture=[0, 1]), tmp / "two.nc")
    return {"dir": tmp, "campaign": campaign, "modal": tmp / "modal.nc", "two": tmp / "two.nc"}


@pytest.fixture(scope="module")
def predictor(files):
    from rmbench.predict import PosturePredictor

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")           # eight postures: the GP warns about its fit
        pred = PosturePredictor("mtgp-grouped").fit(xr.load_dataset(files["modal"]))
    return pred.save(files["dir"] / "pred.npz")


@pytest.fixture(scope="module")
def control_files(files, op, default_design):
    from rmbench.control import sine_sweep
    from rmbench.impact.dataset import save

    k = default_design.controller
    k.save(files["dir"] / "k.npz")
    f0 = default_design.plant.mode_hz[0]
    freqs = f0 * np.array([0.9, 1.0, 1.1])
    runs = [sine_sweep(op, c, "tangential", freqs, workers=0, progress=False) for c in (None, k)]
    both = xr.concat([r.drop_vars("reason") for r in runs], dim="case").assign_coords(case=["uncontrolled", "controlled"])
    save(both, files["dir"] / "runs.nc")
    return {"controller": files["dir"] / "k.npz", "runs": files["dir"] / "runs.nc", "f0": f0}


@pytest.fixture(scope="module")
def tracker_gap(files, mh180):
    """A tracker diagnosis of an MH180 whose j3 is 1 mrad off (120 readings)."""
    from rmbench.gap import diagnose_tracker
    from rmbench.gap.tracker.diagnosis import TrackerData, default_covariance
    from rmbench.gap.cases.tracker_blind import HiddenSource, TrueRobot
    from rmbench.tracker import MH180_JOINT_BOX, sobol_points

    rng = np.random.default_rng(7)
    truth = TrueRobot(mh180, (HiddenSource("joint_offset", "j3", (1e-3,)),), 1.0, rng)
    q = sobol_points(120, *MH180_JOINT_BOX, rng)
    y = truth.positions(q, None, q, noise=True, rng=rng)
    cov = default_covariance(mh180, q, y)
    data = TrackerData(q, y, np.arange(len(q)), np.sqrt(np.diagonal(cov, 0, 1, 2)), None,
                       tuple(mh180.arm_joints), covariance=cov)
    folder = files["dir"] / "tracker_gap"
    diagnose_tracker(mh180, data).save(folder)
    return folder


def _reports(files, predictor, control_files, tracker_gap, tmp):
    """(name, path) of one report of each kind, written through the command line."""
    from rmbench.cli import main

    jobs = {"campaign": [files["campaign"]], "modal": [files["modal"]],
            "predictor": [predictor, "--data", files["modal"], "--learners", "knn"],
            "controller": [control_files["controller"], "--runs", control_files["runs"]],
            "control_runs": [control_files["runs"]], "tracker_gap": [tracker_gap]}
    out = {}
    for name, argv in jobs.items():
        out[name] = tmp / f"{name}.html"
        assert main(["report", *map(str, argv), "--out", str(out[name])]) == 0
    out["lobes"] = tmp / "lobes.html"
    assert main(["lobes", "--benchmark", "--speeds", "5000,25000,40", "--depths", "40",
                 "--report", str(out["lobes"])]) == 0
    out["rcsa_tool"], out["rcsa_part"] = tmp / "rcsa_tool.html", tmp / "rcsa_part.html"
    assert main(["rcsa", "tool", "--reference", str(files["campaign"]), "--target-tool", "endmill", "--index", "0",
                 "--report", str(out["rcsa_tool"])]) == 0
    assert main(["rcsa", "part", "--report", str(out["rcsa_part"])]) == 0
    out["invalidation"] = tmp / "invalidation.html"
    assert main(["invalidate", "run", "--eta", "0.375", "--max-per-location", "10", "--json",
                 "--report", str(out["invalidation"])]) == 0
    return out


@pytest.fixture(scope="module")
def reports(files, predictor, control_files, tracker_gap):
    return _reports(files, predictor, control_files, tracker_gap, files["dir"])


@pytest.mark.parametrize("kind", ["campaign", "modal", "predictor", "controller", "control_runs", "tracker_gap", "lobes",
                                  "rcsa_tool", "rcsa_part", "invalidation"])
def test_each_report_renders_with_a_clean_console_and_every_plot_drawn(browser, reports, kind, tmp_path):
    r = browser.render(reports[kind], screenshot=tmp_path / f"{kind}.png")
    assert r.console_errors == ()
    assert r.dialogs == ()
    assert r.undrawn == ()
    assert r.n_plots >= 1
    assert (tmp_path / f"{kind}.png").stat().st_size > 10_000


@pytest.mark.parametrize("argv", [
    ["campaign", "plot", "{campaign}", "--index", "2", "--report", "{out}"],
    ["modal", "fit", "{two}", "--workers", "0", "--report", "{out}"],
    ["modal", "plot", "{campaign}", "--index", "1", "--report", "{out}"],
    ["predict", "cv", "{modal}", "--model", "knn", "--report", "{out}"],
], ids=["campaign-plot", "modal-fit", "modal-plot", "predict-cv"])
def test_commands_that_plot_also_write_a_report(browser, cli, files, argv, tmp_path):
    """--report takes the place of the PNG: a whole page with every plot drawn."""
    out = tmp_path / "r.html"
    code, _, err = cli(*[a.format(campaign=files["campaign"], two=files["two"], modal=files["modal"], out=out)
                         for a in argv])
    assert code == 0, err
    r = browser.render(out)
    assert r.n_plots >= 2 and r.console_errors == () and r.undrawn == ()


def test_a_report_needs_no_network(reports):
    """Self-contained: no script, style or image is fetched from anywhere."""
    html = reports["modal"].read_text()
    assert not re.search(r"""<(script|link|img)[^>]+(src|href)\s*=\s*["']?(https?:)?//""", html)


def test_the_page_decodes_the_files_magnitudes_exactly(browser, reports, files):
    """The FRF matrix travels as 0.01 dB integers, differenced along frequency and gzipped: what
    the page decodes is the campaign's |H| in dB to that quantum (0.005 dB)."""
    ds = open_campaign(files["campaign"])
    got = browser.evaluate(reports["campaign"], """rm.prepare(JSON.parse(document.querySelector('script[id$="-data"]').textContent))
                               .then(function (d) { return {mag: Array.from(d.mag), F: d.n_freq}; })""")
    F = got["F"]
    mag = np.array(got["mag"], float).reshape(ds.sizes["posture"], 4, 4, F) / 100
    want = 20 * np.log10(np.abs(ds.H.sel(out=["1X", "1Y", "1aX", "1aY"], inp=["1X", "1Y", "1aX", "1aY"]).values))
    np.testing.assert_allclose(mag, np.moveaxis(want, 1, -1), atol=0.0051)


def test_user_strings_cannot_inject_markup(browser, files, tmp_path):
    """A file name and config carrying markup show as text: no element, no script, no dialog."""
    ds = xr.load_dataset(files["campaign"])
    ds.attrs["config"] = '</script><script>alert("config")</script>'
    ds.attrs["robot"] = '<img src=x onerror=alert("robot")>'
    evil = tmp_path / 'x"><img src=x onerror=alert(1)>.nc'
    from rmbench.cli import main
    from rmbench.impact.dataset import save

    save(ds, evil)

    out = tmp_path / "evil.html"
    assert main(["report", str(evil), "--out", str(out)]) == 0
    html = out.read_text()
    assert "<img src=x" not in html
    assert '<script>alert("config")' not in html
    assert "&lt;img src=x onerror=alert(1)&gt;" in html           # shown, escaped
    r = browser.render(out)
    assert r.dialogs == () and r.console_errors == ()


def test_a_failed_posture_shows_as_a_gap_not_an_error(browser, files, tmp_path):
    """A posture the robot could not hold has no FRF (NaN): the report still draws, the posture
    table says why, and the stabilisation diagram moves to a measured posture."""
    from rmbench.impact.dataset import save
    from rmbench.report.files import write_report

    ds = xr.load_dataset(files["campaign"])
    for v in ("H", "H_exact", "H_exact_bare", "coherence"):
        if v in ds:
            ds[v][0] = np.nan
    reason = ds.reason.values.astype(object)
    reason[0] = "unreachable"
    ok = ds.ok.values.copy()
    ok[0] = False
    ds = ds.assign_coords(ok=("posture", ok), reason=("posture", reason.astype(str)))
    save(ds, tmp_path / "c.nc")
    fit = xr.load_dataset(files["modal"])
    fit.attrs["upstream"] = str(tmp_path / "c.nc")
    save(fit, tmp_path / "m.nc")
    out = write_report(tmp_path / "m.nc", tmp_path / "m.html")
    html = out.read_text()
    assert "FRF matrix" in html and "unreachable" in html
    r = browser.render(out)
    assert r.console_errors == () and r.undrawn == ()


def test_a_page_without_plots_opens(browser, tmp_path):
    page = Page("text only")
    page.section("s").text("nothing to plot").figure({"data": [], "layout": {}})
    path = page.write(tmp_path / "t.html")
    r = browser.render(path, timeout_s=20)
    assert r.n_plots == 0 and r.console_errors == ()


def test_diagnosis_strings_from_a_folder_are_escaped(tmp_path):
    """Effect names and descriptions read from diagnosis.json are shown as text."""
    from rmbench.report.files import write_report

    bad = "<script>alert('effect')</script>"
    doc = {"verdict": "explained", "where": {"localisation": bad, "bands": {}, "modes": []},
           "effects": [{"name": bad, "description": bad, "chosen": True, "confidence": 1.0, "shrink": 0.9,
                        "shrink_interval": [0.8, 0.95], "heldout_before": {"gap": 2.0, "f_err": 0.01, "frf_db": 1},
                        "heldout_after": {"gap": 0.2, "f_err": 0.001, "frf_db": 0.3}}], "notes": [bad]}
    (tmp_path / "diagnosis.json").write_text(json.dumps(doc))
    html = write_report(tmp_path, tmp_path / "r.html").read_text()
    assert "<script>alert(" not in html


def test_script_json_cannot_end_its_script_element():
    s = script_json({"a": "</script><!-- \u2028", "b": [float("nan"), 1.0]})
    assert "<" not in s and ">" not in s and "\u2028" not in s
    assert json.loads(s) == {"a": "</script><!-- \u2028", "b": [None, 1.0]}


def test_page_is_written_whole_or_not_at_all(tmp_path):
    page = Page("t")
    page.section("s").text("x")
    path = page.write(tmp_path / "r.html")
    assert path.read_text().startswith("<!DOCTYPE html>")
    assert [p.name for p in tmp_path.iterdir()] == ["r.html"]


@pytest.mark.parametrize("argv, message", [
    (["report", "{missing}", "--out", "{out}"], "file not found"),
    (["report", "{campaign}", "--out", "{dir}/r.png"], "must name an .html file"),
    (["report", "{campaign}", "--out", "{dir}/nowhere/r.html"], "does not exist"),
    (["report", "{campaign}", "--out", "{out}", "--runs", "{campaign}"], "applies to controller"),
    (["report", "{dir}", "--out", "{out}"], "without diagnosis.json"),
    (["report", "{modal}", "--out", "{out}", "--posture", "99"], "outside"),
    (["report", "{notnc}", "--out", "{out}"], "not a readable netCDF"),
    (["lobes", "--benchmark", "--report", "{dir}/l.txt"], "must name an .html file"),
], ids=["missing-file", "png-out", "missing-folder", "runs-on-campaign", "folder-without-diagnosis",
        "posture-outside", "not-netcdf", "lobes-txt-report"])
def test_bad_input_gets_one_line(cli, files, argv, message, tmp_path):
    (tmp_path / "notnc.nc").write_text("hello")
    fmt = {"missing": tmp_path / "missing.nc", "out": tmp_path / "r.html", "dir": tmp_path,
           "campaign": files["campaign"], "modal": files["modal"], "notnc": tmp_path / "notnc.nc"}
    code, _, err = cli(*[a.format(**fmt) for a in argv])
    assert code == 2
    assert message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "r.html").exists()
