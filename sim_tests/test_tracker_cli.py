"""``rmbench tracker`` and ``rmbench invalidate``: tables or JSON, bad input as one line, exit 2."""

import json

import pytest

from rmbench.cli import main

SMALL = 'robot = "mh180"\nseed = 2\nn_identification = 40\nn_validation = 6\nrepeats = 2\n'


@pytest.fixture(scope="module")
def campaign_csv(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tracker")
    (folder / "c.toml").write_text(SMALL)
    assert main(["tracker", "run", str(folder / "c.toml"), "--out", str(folder / "r.csv")]) == 0
    return folder / "r.csv"


def test_tracker_run_writes_repeated_readings(campaign_csv):
    lines = [ln for ln in campaign_csv.read_text().splitlines() if not ln.startswith("#")]
    assert lines[0].startswith("location,q_j1,") and len(lines) == 1 + 6 * 2


def test_invalidate_readings_prints_one_json_object(cli, campaign_csv):
    code, out, _ = cli("invalidate", "readings", campaign_csv, "--eta", "0.375", "--json")
    data = json.loads(out)
    assert code == 0 and data["n_measurements"] == 12 and data["verdict"] in ("rejected", "not rejected")


def test_invalidate_run_reports_verdict_and_measurements(cli):
    code, out, _ = cli("invalidate", "run", "--eta", "0.375", "--alpha", "0.9",
                       "--max-per-location", "10", "--json")
    data = json.loads(out)
    assert code == 0 and data["n_measurements"] >= data["n_explored"] > 0
    assert data["units"] == "m" and data["eta"] == pytest.approx(0.375e-3)


def test_invalidate_benchmark_prints_table1_beside_the_seed(cli):
    code, out, _ = cli("invalidate", "benchmark", "--seeds", "1")
    assert code == 0 and "Model Invalidation" in out and "/ 1.06" in out


@pytest.mark.parametrize("argv, message", [
    (["invalidate", "readings", "CSV", "--eta", "0.375", "--alpha", "1.5"],
     "alpha must lie strictly between 0 and 1"),
    (["invalidate", "readings", "CSV", "--eta", "-1"], "--eta must be a finite accuracy level"),
    (["invalidate", "readings", "MISSINGCOL", "--eta", "0.375"], "z_nom"),
    (["invalidate", "readings", "NAN", "--eta", "0.375"], "not finite"),
    (["invalidate", "readings", "NOSIGMA", "--eta", "0.375", "--repeatability", "0"],
     "--repeatability must be > 0 mm"),
    (["invalidate", "readings", "nowhere.csv", "--eta", "0.375"], "not found"),
    (["invalidate", "run", "--eta", "0.375", "--config", "BADKEY"], "unknown key"),
    (["tracker", "run", "BADTOML", "--out", "x.csv"], "not valid TOML"),
], ids=["alpha", "eta", "missing-column", "nan", "repeatability", "missing-file", "config-key",
        "bad-toml"])
def test_bad_input_gives_one_line_and_exit_2(cli, tmp_path, campaign_csv, argv, message):
    rows = [r.split(",") for r in campaign_csv.read_text().splitlines() if not r.startswith("#")]
    nan = [r[:] for r in rows]
    nan[1][rows[0].index("x")] = "nan"
    files = {"MISSINGCOL": [[c.replace("z_nom", "zz") for c in rows[0]]] + rows[1:],
             "NAN": nan, "NOSIGMA": [r[:-3] for r in rows]}
    texts = {"BADKEY": SMALL + "colour = 3\n", "BADTOML": "robot = \n"}
    args = []
    for a in argv:
        if a == "CSV":
            a = campaign_csv
        elif a in files or a in texts:
            path = tmp_path / f"{a}.{'toml' if a in texts else 'csv'}"
            path.write_text(texts[a] if a in texts else "\n".join(",".join(r) for r in files[a]))
            a = path
        args.append(a)
    code, _, err = cli(*args)
    assert code == 2 and message in err and err.count("\n") == 1
