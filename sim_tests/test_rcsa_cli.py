"""``rmbench rcsa``: tool change on campaign files, the supported part, and one-line errors."""

import json

import mujoco
import pytest

from rmbench.impact import load_config, run_campaign
from rmbench.robot import Posture, Robot
from rmbench.robot.catalog import models_dir

POSTURES = [[1800.0, -200.0, 0.0], [1800.0, 200.0, 0.0]]


def _campaign(path, tool, postures):
    cfg = load_config("seed_full").with_overrides(name=f"rcsa-{tool}", method="linear", robot_tool=tool,
                                                  grid={"kind": "list", "postures": postures})
    run_campaign(cfg, path, workers=1, progress=False)
    return path


@pytest.fixture(scope="module")
def campaigns(tmp_path_factory):
    d = tmp_path_factory.mktemp("rcsa")
    return (_campaign(d / "ref.nc", "dummy", POSTURES), _campaign(d / "tgt.nc", "endmill", POSTURES[:1]))


def test_tool_change_json_scores_every_peak_against_the_simulated_target(cli, campaigns):
    ref, tgt = campaigns
    code, out, _ = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--posture", "1800,200,0", "--calibration", str(tgt), "--json")
    assert code == 0
    d = json.loads(out)
    assert d["posture_index"] == 1 and d["contact_source"].startswith("identified")
    entries = {p["entry"] for p in d["peaks"]}
    assert entries == {"1X/1X", "1X/1Y", "1Y/1X", "1Y/1Y"}
    assert d["peak_amp_err_max"] < 0.10 and d["peak_freq_err_max"] < 0.01


def test_tool_change_writes_figure_and_receptances(cli, campaigns, tmp_path):
    ref, _ = campaigns
    fig, nc = tmp_path / "t.png", tmp_path / "t.nc"
    code, out, _ = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill", "--index", "0",
                       "--method", "beam", "--out", str(fig), "--save", str(nc))
    assert code == 0 and fig.stat().st_size > 10_000 and nc.is_file()
    assert "largest errors" in out


def test_unmeasured_posture_names_the_nearest(cli, campaigns):
    ref, _ = campaigns
    code, _, err = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--posture", "1700,0,0")
    assert code == 2 and "was not measured; nearest is index" in err and "Traceback" not in err


def test_calibration_with_the_wrong_tool_is_refused(cli, campaigns):
    ref, _ = campaigns
    code, _, err = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--calibration", str(ref))
    assert code == 2 and "not the target" in err


@pytest.fixture(scope="module")
def calibrations(tmp_path_factory):
    """The bundled tool calibration (validation posture 1, 600-3500 Hz, steel tip, time domain)
    run through the CLI with each tool."""
    from rmbench.cli import main

    d = tmp_path_factory.mktemp("cal")
    for tool in ("dummy", "endmill"):
        assert main(["campaign", "run", "tool_calibration", "--tool", tool, "--out", str(d / f"{tool}.nc"),
                     "--workers", "0", "--no-progress"]) == 0
    return d / "dummy.nc", d / "endmill.nc"


def test_campaign_tool_override_puts_the_named_tool_on(calibrations):
    import xarray as xr

    assert [xr.open_dataset(p).attrs["tool"] for p in calibrations] == ["dummy", "endmill"]


def test_tool_calibration_to_3p5_khz_identifies_the_contact_within_10_percent(cli, calibrations):
    """The contact's stiffness and damping set the tool-on-holder mode (2.7 kHz), which the
    calibration band holds: k_t and c_t come back within the issue's 10 % from measured FRFs
    (bench, 5 seeds: 1-2 %; from the seed's 600-1400 Hz band c_t is off by a factor of two)."""
    from rmbench.robot.tool import TOOLS

    ref, tgt = calibrations
    code, out, _ = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--calibration", str(tgt), "--calibration-reference", str(ref), "--json")
    assert code == 0
    d = json.loads(out)
    assert "calibration campaigns, 600-3500 Hz" in d["contact_source"]
    k = d["target_contact"]
    assert abs(k["k_t"] / TOOLS["endmill"].k_t - 1) < 0.10
    assert abs(k["c_t"] / TOOLS["endmill"].c_t - 1) < 0.10


def test_calibration_lines_unlike_the_references_are_one_line(cli, campaigns, calibrations):
    ref, _ = campaigns
    code, _, err = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--calibration", str(calibrations[1]))
    assert code == 2 and "high-band lines differ" in err and "Traceback" not in err


def test_calibration_reference_alone_is_refused(cli, campaigns, calibrations):
    ref, _ = campaigns
    code, _, err = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--calibration-reference", str(calibrations[0]))
    assert code == 2 and "needs --calibration" in err


def test_missing_reference_file_is_one_line(cli, tmp_path):
    code, _, err = cli("rcsa", "tool", "--reference", str(tmp_path / "none.nc"), "--target-tool", "endmill")
    assert code == 2 and "not found" in err


def test_part_json_reports_low_mode_and_reductions(cli):
    code, out, _ = cli("rcsa", "part", "--json")
    assert code == 0
    d = json.loads(out)
    assert abs(d["low_mode_err"]) < 0.01 and d["reduction_err_pp"] < 0.1


def test_part_rejects_a_bad_contact_stiffness(cli):
    code, _, err = cli("rcsa", "part", "--k-x", "-5")
    assert code == 2 and "--k-x must be positive" in err


def test_shipped_scene_loads_and_holds_its_preload():
    # models/mjcf/scenes/plate_support_irb6660.xml = `rmbench rcsa part --scene` at the defaults
    xml = (models_dir() / "scenes" / "plate_support_irb6660.xml").read_text()
    robot = Robot(xml, name="scene", tool="dummy")
    q = Robot.load("irb6660").ik(Posture.from_mm_deg(1800, 0, 0)).q
    op = robot.at(q)
    t = mujoco.mj_name2id(robot.model, mujoco.mjtObj.mjOBJ_TENDON, "part_contact")
    force = robot.model.tendon_stiffness[t] * (op.data.ten_length[t] - robot.model.tendon_lengthspring[t, 0])
    assert abs(force - 100.0) < 1.0  # 6-digit joint coefficients in the file: well under 1 N
    assert sum(robot.model.joint(i).name.startswith("part_mode_") for i in range(robot.model.njnt)) == 6


def test_tool_model_and_free_parameters_reach_the_contact_fit(cli, calibrations):
    """``--tool-model lumped --free k_t,k_r,c_t`` fits the rotational stiffness too (reported with
    its standard error) on the simulator's own tool; k_t and c_t stay within the issue's 10 %. k_r
    itself is not held to 10 %: from measured FRFs it is off by 12-28 % (bench/results/rcsa.txt)."""
    from rmbench.robot.tool import TOOLS

    ref, tgt = calibrations
    code, out, _ = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--calibration", str(tgt), "--calibration-reference", str(ref), "--method", "beam",
                       "--tool-model", "lumped", "--free", "k_t,k_r,c_t", "--json")
    assert code == 0
    d = json.loads(out)
    assert d["tool_model"] == "lumped"
    assert set(d["contact_fit"]["rel_std"]) == {"k_t", "k_r", "c_t"}
    for name in ("k_t", "c_t"):
        assert abs(d["target_contact"][name] / getattr(TOOLS["endmill"], name) - 1) < 0.10, name


def test_unknown_free_contact_parameter_is_one_line(cli, calibrations):
    ref, tgt = calibrations
    code, _, err = cli("rcsa", "tool", "--reference", str(ref), "--target-tool", "endmill",
                       "--calibration", str(tgt), "--free", "k_t,k_z")
    assert code == 2 and "--free" in err and len(err.strip().splitlines()) == 1
