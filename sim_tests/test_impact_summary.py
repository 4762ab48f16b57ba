"""A campaign run's account: postures measured and failed, steps, time per posture; its text,
JSON and figure; finding a posture in a dataset."""

from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from rmbench.errors import InputError
from rmbench.impact import CampaignSummary
from rmbench.impact.dataset import find_posture
from rmbench.robot import Posture


def _dataset(ok=(True, False, True, False), reasons=("", "unreachable", "", "unreachable")):
    n = len(ok)
    return xr.Dataset({"ok": ("posture", np.array(ok)), "reason": ("posture", np.array(reasons)),
                       "steps": ("posture", np.arange(n) * 100), "seconds": ("posture", np.linspace(1, 2, n)),
                       "x": ("posture", np.linspace(1.4, 1.7, n)), "y": ("posture", np.zeros(n)),
                       "theta": ("posture", np.zeros(n))})


@pytest.fixture
def summary():
    return CampaignSummary.from_dataset(_dataset(), "run.nc")


def test_summary_counts_measured_postures_steps_and_distinct_failures(summary):
    assert (summary.n_postures, summary.n_ok, summary.steps_total) == (4, 2, 600)
    assert summary.failed == ["unreachable"]


def test_summary_text_names_the_file_the_counts_and_each_failure(summary):
    assert summary.summary().splitlines() == [
        "wrote run.nc: 2 of 4 postures measured, 600 steps simulated", "  failed: unreachable"]


def test_a_kept_run_says_nothing_was_simulated():
    s = CampaignSummary.from_dataset(_dataset(ok=(True,), reasons=("",)), "run.nc", kept=True)
    assert s.summary() == ("run.nc is a finished run of this configuration: kept, nothing simulated "
                           "(--force runs it again)")


def test_to_dict_is_strict_json_with_the_counts(summary):
    d = json.loads(json.dumps(summary.to_dict(), allow_nan=False))
    assert d == {"out": "run.nc", "postures": 4, "ok": 2, "failed": ["unreachable"], "steps": 600, "kept": False}


def test_plot_draws_a_bar_per_posture_on_the_axes_given(summary):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    assert summary.plot(ax=ax) is ax
    assert len(ax.patches) == 4
    plt.close(fig)


def test_a_dataset_without_the_run_account_is_an_input_error():
    with pytest.raises(InputError, match="no 'seconds'"):
        CampaignSummary.from_dataset(_dataset().drop_vars("seconds"), "x.nc")


def test_find_posture_gives_the_position_of_a_measured_posture_and_none_elsewhere():
    ds = _dataset()
    assert find_posture(ds, Posture(1.5, 0.0, 0.0)) == 1
    assert find_posture(ds, Posture(1.55, 0.0, 0.0)) is None
