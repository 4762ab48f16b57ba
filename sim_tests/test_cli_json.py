"""Every ``--json`` of the command line, and every JSON file a command writes, is strict JSON: no
``NaN``, ``Infinity`` or ``-Infinity`` (JavaScript's ``JSON.parse``, ``jq`` and most parsers refuse
them). A value with nothing to report is ``null``, and where the null has a meaning a field beside
it says what (lobes: ``stable_to_m``, the largest depth searched)."""

import json

import numpy as np
import pytest

from rmbench.cli import main

CAMPAIGN = """
seed = 3
method = "linear"
[grid]
kind = "list"
postures = {postures}
"""
ONE = "[[1800, -200, 0]]"
THREE = "[[1800, -200, 0], [1800, 200, 60], [1700, -100, 0]]"     # the fewest a predictor learns from
SMALL_TRACKER = 'robot = "mh180"\nseed = 2\nn_identification = 40\nn_validation = 6\nrepeats = 2\n'
TUNE = 'axes = ["tangential"]\nevaluate = "linear"\nmode_ratios = [1.0]\n[weights]\nk_a = [20.0]\n'


def strict_loads(text: str):
    """``json.loads`` that refuses NaN, Infinity and -Infinity."""
    def refuse(name):
        raise ValueError(f"not strict JSON: {name}")

    return json.loads(text, parse_constant=refuse)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Small inputs the commands read: a three-posture linear campaign, its modal fit and a
    predictor trained on it, a tracker campaign's CSV, a controller and a tuning grid."""
    d = tmp_path_factory.mktemp("json")
    (d / "one.toml").write_text(CAMPAIGN.format(postures=ONE))
    (d / "three.toml").write_text(CAMPAIGN.format(postures=THREE))
    (d / "tracker.toml").write_text(SMALL_TRACKER)
    (d / "tune.toml").write_text(TUNE)
    assert main(["campaign", "run", str(d / "three.toml"), "--out", str(d / "c.nc"), "--workers", "0",
                 "--no-progress"]) == 0
    assert main(["modal", "fit", str(d / "c.nc"), "--out", str(d / "m.nc"), "--workers", "0"]) == 0
    assert main(["predict", "train", str(d / "m.nc"), "--model", "stgp", "--out", str(d / "p.npz")]) == 0
    assert main(["tracker", "run", str(d / "tracker.toml"), "--out", str(d / "r.csv")]) == 0
    assert main(["control", "design", "--axes", "tangential", "--out", str(d / "k.npz")]) == 0
    return d


COMMANDS = {
    "model-info": ["model", "info", "--posture", "1800,-200,0", "--json"],
    "campaign-dry-run": ["campaign", "run", "{d}/three.toml", "--dry-run", "--json"],
    "campaign-run": ["campaign", "run", "{d}/one.toml", "--out", "{tmp}/c.nc", "--workers", "0",
                     "--no-progress", "--json"],
    "modal-fit": ["modal", "fit", "{d}/c.nc", "--workers", "0", "--json"],
    "predict-cv": ["predict", "cv", "{d}/m.nc", "--model", "knn", "--folds", "3", "--json"],
    "predict-at": ["predict", "at", "{d}/p.npz", "--posture", "1800,0,30", "--json"],
    "rcsa-tool": ["rcsa", "tool", "--reference", "{d}/c.nc", "--target-tool", "endmill", "--json"],
    "lobes-benchmark": ["lobes", "--benchmark", "--speeds", "5000,25000,20", "--depths", "20", "--json"],
    "lobes-zoa": ["lobes", "--benchmark", "--method", "zoa", "--json"],
    "lobes-modal": ["lobes", "--modal", "{d}/m.nc", "--method", "zoa", "--speeds", "6000,12000,4", "--json"],
    "lobes-predictor": ["lobes", "--modal", "{d}/p.npz", "--posture", "1800,0,30", "--method", "zoa",
                        "--speeds", "6000,12000,4", "--json"],
    "mill": ["mill", "--speeds", "9000", "--depths", "1", "--periods", "20", "--json"],
    "rcsa-part": ["rcsa", "part", "--json"],
    "tracker-run": ["tracker", "run", "{d}/tracker.toml", "--out", "{tmp}/r.csv", "--json"],
    "invalidate-readings": ["invalidate", "readings", "{d}/r.csv", "--eta", "0.375", "--json"],
    "invalidate-run": ["invalidate", "run", "--eta", "0.375", "--max-per-location", "10", "--level", "--json"],
    "invalidate-benchmark": ["invalidate", "benchmark", "--seeds", "1", "--json"],
    "control-design": ["control", "design", "--axes", "tangential", "--out", "{tmp}/k.npz", "--json"],
    "control-run": ["control", "run", "{d}/k.npz", "--freqs", "5.6,5.9", "--workers", "0", "--json"],
    "control-tune": ["control", "tune", "{d}/tune.toml", "--workers", "0", "--json"],
    "gap-diagnose-readings": ["gap", "diagnose", "--readings", "{d}/r.csv", "--json"],
}


def test_json_text_writes_null_inside_arrays_and_numpy_scalars():
    """Every ``--json`` prints :func:`rmbench.io.strict_json.strict_dumps` of its result."""
    from rmbench.io.strict_json import strict_dumps

    text = strict_dumps({"a": np.array([1.0, np.nan, np.inf]), "s": np.float32("nan"), "n": np.int64(2)})
    assert strict_loads(text) == {"a": [1.0, None, None], "s": None, "n": 2}


@pytest.mark.parametrize("argv", COMMANDS.values(), ids=COMMANDS.keys())
def test_json_output_is_strict(cli, files, tmp_path, argv):
    code, out, _ = cli(*[a.format(d=files, tmp=tmp_path) for a in argv])
    assert code == 0
    assert isinstance(strict_loads(out), (dict, list))


def test_lobes_say_null_where_stable_up_to_the_depth_searched(cli):
    """With 3 mm searched, the benchmark's lobes peak above the range between their troughs
    (about 1.7 mm): those speeds are null, with ``stable_to_m`` naming the 3 mm."""
    code, out, _ = cli("lobes", "--benchmark", "--speeds", "5000,25000,20", "--depths", "20",
                       "--depth-max", "3", "--json")
    d = strict_loads(out)
    assert code == 0 and d["stable_to_m"] == pytest.approx(3e-3)
    a = d["a_lim_m"]
    assert None in a and any(v is not None for v in a)
    assert all(0 < v <= d["stable_to_m"] for v in a if v is not None)


def test_lobes_bands_share_the_depth_searched(cli):
    code, out, _ = cli("lobes", "--robot", "irb6660", "--tool", "endmill", "--band", "both",
                       "--method", "zoa", "--speeds", "6000,12000,4", "--depth-max", "0.5", "--json")
    d = strict_loads(out)
    assert code == 0 and set(d["bands"]) == {"low", "high"} and d["stable_to_m"] == pytest.approx(5e-4)
    assert all(v is None or 0 < v <= d["stable_to_m"] for b in d["bands"].values() for v in b)


def test_predicted_parameters_name_the_ones_not_predicted(cli, files):
    """A parameter the predictor has no value for is null, and its mode lists it."""
    code, out, _ = cli("predict", "at", files / "p.npz", "--posture", "1800,0,30", "--json")
    assert code == 0
    for m in strict_loads(out)["postures"][0]["modes"]:
        assert m["not_predicted"] == [p for p, v in m["params"].items() if v is None]


def test_tracker_gap_bins_name_the_empty_ones(cli, files, tmp_path):
    """A joint-angle bin without a reading has rms null, and ``empty`` lists it; the saved
    diagnosis.json is strict JSON too."""
    code, out, _ = cli("gap", "diagnose", "--readings", files / "r.csv", "--out", tmp_path / "g", "--json")
    assert code == 0
    for d in (strict_loads(out), strict_loads((tmp_path / "g" / "diagnosis.json").read_text())):
        for b in d["where"]["bins"].values():
            assert b["empty"] == [i for i, v in enumerate(b["rms"]) if v is None]


def test_mill_out_file_is_strict_and_a_runaway_resumes_unbounded(tmp_path):
    """A runaway cut's metric and growth are infinite: null in the JSON-lines file, inf again
    when a rerun resumes from it. A runaway threshold of 1 nm (below the static deflection) runs
    away at the first step; the rerun, at the default 5 mm, would not give that cut again: it
    reads it back rather than simulating it."""
    from rmbench.robot import Posture
    from rmbench.stability import ALUMINIUM_6061
    from rmbench.stability.milling import mill_grid

    out = tmp_path / "m.jsonl"
    p = Posture.from_mm_deg(1800, 200, 0)
    first = mill_grid("irb6660", "endmill", p, ALUMINIUM_6061, [9000.0], [1e-3], out=out, runaway=1e-9)
    assert first[0].kind == "runaway"
    line = strict_loads(out.read_text())
    assert line["metric"] is None and line["growth"] is None

    again = mill_grid("irb6660", "endmill", p, ALUMINIUM_6061, [9000.0], [1e-3], out=out)
    assert again[0].metric == again[0].growth == np.inf and again == first


def test_gap_blind_case_lines_are_strict_and_read_back():
    """A blind case whose visibility could not be probed (NaN) is written null and read back NaN."""
    from rmbench.gap.cases.blind import CaseResult, Hidden, case_from_dict, dumps

    case = CaseResult(index=0, method="linear", hidden=(Hidden("joint_stiffness", "j3_flex", {"factor": 1.3}),),
                      verdict="explained", ranked=(("joint_stiffness@j3_flex", 1.0),), equivalent=(),
                      shrink=0.9, top1=True, top3=True, top1_class=True, top3_class=True, pair_in_top3=None,
                      seconds={"campaign": 1.0}, visible_db=float("nan"), scale=1.0)
    d = strict_loads(dumps(case))
    assert d["visible_db"] is None and np.isnan(case_from_dict(d).visible_db)
