"""``rmbench campaign``: run (dry and real), export/import through UFF58, plot; errors as one line."""

import json

import pytest


TINY = """
seed = 3
method = "linear"
[grid]
kind = "list"
postures = [[1800, -200, 0], [1800, 200, 60]]
"""


@pytest.fixture
def tiny(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


def test_dry_run_lists_postures_and_estimates(cli, tiny):
    code, out, _ = cli("campaign", "run", tiny, "--dry-run", "--method", "time", "--json")
    est = json.loads(out)
    assert code == 0 and est["n_postures"] == 2
    assert est["steps_total"] > 0 and est["estimated_core_seconds"] > 0


@pytest.mark.slow
def test_run_export_import_plot(cli, tiny, tmp_path):
    data = tmp_path / "tiny.nc"
    code, out, _ = cli("campaign", "run", tiny, "--out", data, "--workers", 0, "--no-progress", "--json")
    assert code == 0 and json.loads(out)["ok"] == 2
    code, _, _ = cli("campaign", "export", data, "--uff", tmp_path / "uff", "--binary")
    assert code == 0
    code, _, _ = cli("campaign", "import", tmp_path / "uff", "--out", tmp_path / "back.nc")
    assert code == 0
    from rmbench.impact import open_campaign
    import numpy as np

    a, b = open_campaign(data), open_campaign(tmp_path / "back.nc")
    np.testing.assert_array_equal(a.H.values, b.H.values)  # binary UFF58b is exact
    assert "H_exact" not in b  # an imported test has no ground truth
    code, _, _ = cli("campaign", "plot", data, "--posture", "1800,200,60", "--out", tmp_path / "f.png")
    assert code == 0 and (tmp_path / "f.png").stat().st_size > 10_000


def test_run_again_keeps_a_finished_dataset_and_says_so(cli, tiny, tmp_path):
    data = tmp_path / "tiny.nc"
    args = ("campaign", "run", tiny, "--out", data, "--workers", 0, "--no-progress")
    assert cli(*args, "--json")[0] == 0
    code, out, _ = cli(*args)
    assert code == 0 and "kept, nothing simulated" in out
    code, out, _ = cli(*args, "--force", "--json")
    assert code == 0 and json.loads(out)["kept"] is False


def test_run_commands_a_variant_file_with_the_nominal_robot(cli, tiny, tmp_path):
    from rmbench.impact import open_campaign
    from rmbench.robot import Robot
    from rmbench.robot.variant import make_variant

    variant = tmp_path / "soft.xml"  # a saved variant carries its tool, the config's "dummy"
    variant.write_text(make_variant(Robot.load("irb6660", tool="dummy"), ["j2_flex.stiffness*=0.8"]))
    data = tmp_path / "soft.nc"
    code, out, _ = cli("campaign", "run", tiny, "--robot", variant, "--commands-from", "irb6660",
                       "--out", data, "--workers", 0, "--no-progress", "--json")
    assert code == 0 and json.loads(out)["ok"] == 2
    ds = open_campaign(data)
    assert ds.attrs["robot"] == str(variant) and ds.attrs["commands_from"] == "irb6660"


@pytest.mark.parametrize("argv, message", [
    (["campaign", "run", "missing.toml", "--out", "x.nc"], "config file not found"),
    (["campaign", "run", "TINY", "--commands-from", "kuka", "--out", "x.nc"], "unknown robot 'kuka'"),
    (["campaign", "plot", "missing.nc", "--index", "0", "--out", "f.png"], "dataset not found"),
    (["campaign", "import", "no_such_dir", "--out", "x.nc"], ""),
], ids=["missing-config", "unknown-nominal-robot", "missing-dataset", "missing-uff-dir"])
def test_bad_input_is_one_line_and_exit_2(cli, tiny, argv, message):
    code, _, err = cli(*[tiny if a == "TINY" else a for a in argv])
    assert code == 2 and message in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_bad_config_fails_before_anything_runs(cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[hits]\naverages = 0\n")
    code, _, err = cli("campaign", "run", bad, "--out", tmp_path / "x.nc")
    assert code == 2 and "hits.averages" in err
    assert not (tmp_path / "x.nc").exists() and not (tmp_path / "x.nc.parts").exists()
