"""The quantities the commands print come from the library (issue 81): the worst location of judged
readings, a tracker campaign's identification errors, a posture suggestion's volume factors and
best-determined parameters, and the postures a calibration holds out."""

import numpy as np
import pytest

from rmbench.calibrate.split import held_out_postures, spread_held_out
from rmbench.calibrate.suggest import Suggestion
from rmbench.tracker import CampaignConfig, TrackerCampaign, judge_readings


def test_judged_readings_name_the_location_of_largest_mean_error_and_its_size():
    # location 7: mean (3, 4, 0) -> 5; location 2: mean (1, 0, 0)
    errors = np.array([[1.0, 0, 0], [3.0, 4.0, 0], [1.0, 0, 0], [3.0, 4.0, 0]])
    judged = judge_readings(np.array([2, 7, 2, 7]), errors, np.full((4, 3), 0.1), 10.0)
    label, error = judged.worst_location()
    assert (label, error) == (7, pytest.approx(5.0))


def test_a_campaigns_identification_summary_is_the_mean_and_max_of_its_errors():
    camp = TrackerCampaign.build(CampaignConfig(seed=0, n_identification=30, n_validation=3))
    e = camp.identification_errors()
    assert camp.identification_summary() == {"n": len(e), "mean": float(e.mean()), "max": float(e.max())}


def _suggestion(gain, before, after) -> Suggestion:
    return Suggestion(postures=(), gain=tuple(gain), skipped=(), sd_before=before, sd_after=after)


def test_a_suggestions_volume_factors_are_exp_of_minus_half_the_gain():
    s = _suggestion([2.0, 0.5], {}, {})
    assert s.volume_factors == pytest.approx((np.exp(-1.0), np.exp(-0.25)))


def test_a_suggestion_ranks_parameters_by_their_shrink_of_standard_deviation():
    s = _suggestion([], {"a": 1.0, "b": 0.5, "c": 0.8}, {"a": 0.9, "b": 0.1, "c": 0.4})
    assert s.best_determined(2) == ["b", "c"]


def test_the_calibrations_held_out_postures_are_the_spread_of_its_data():
    class Posture:
        def __init__(self, x, y, theta):
            self.x, self.y, self.theta = x, y, theta

    class Data:
        postures = tuple(Posture(x, y, t) for t in (0.0, 0.5) for x in (1.0, 1.2) for y in (-0.2, 0.2))

    xs, ys, ts = zip(*((p.x, p.y, p.theta) for p in Data.postures))
    assert held_out_postures(Data, 3) == spread_held_out(xs, ys, ts, 3)
    assert len(held_out_postures(Data, 3)) == 3
