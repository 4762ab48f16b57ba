"""Simulated tracker campaigns: configuration files, the model under test, the robot test."""

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.tracker import CampaignConfig, TrackerCampaign, robot_test


def test_robot_test_scores_every_method_on_the_same_validation_set():
    res = robot_test(CampaignConfig(seed=1, n_identification=40, n_validation=12), n_truth=2000)
    rows = {name: (n, acc) for name, n, acc in res.rows()}
    # Largest Error and Outlier Rejection analyse the same single readings
    assert rows["Largest Error"][0] == rows["Outlier Rejection"][0] == 12
    assert rows["Largest Error"][1] >= rows["Outlier Rejection"][1]
    assert rows["Mean Error"][0] == 120 and res.true_max >= res.true_max_validation


def test_reading_sigma_combines_repeatability_and_tracker_noise():
    camp = TrackerCampaign.build(CampaignConfig(seed=0, n_identification=30, n_validation=3))
    q = camp.q_validation
    jac = camp.model.jacobian(q)
    rep = np.sum((jac * camp.simulator.joint_sigma) ** 2, axis=-1)
    track = camp.simulator.tracker.sigma(np.linalg.norm(camp.model.position(q), axis=1))
    assert np.allclose(camp.sigma(q) ** 2, rep + track[:, None] ** 2, rtol=1e-12)


def test_config_file_sets_nested_tracker_and_error_settings(tmp_path):
    path = tmp_path / "c.toml"
    path.write_text('seed = 4\nn_validation = 7\n[tracker]\nppm = 1e-5\n[errors]\n'
                    'gear_amplitude = [1e-5, 0.0]\n')
    cfg = CampaignConfig.from_toml(path)
    assert cfg.seed == 4 and cfg.n_validation == 7 and cfg.tracker.ppm == 1e-5
    assert cfg.errors.gear_amplitude == (1e-5, 0.0)


@pytest.mark.parametrize("data, message", [
    ({"colour": 3}, "unknown key"),
    ({"tracker": {"range": 3}}, r"\[tracker\]: unknown key"),
    ({"n_validation": 0}, "n_validation must be an integer >= 1"),
    ({"repeatability": -1e-4}, "repeatability must be finite and > 0"),
    ({"joint_lower": [0.0], "joint_upper": [-1.0]}, "lower < upper"),
    ({"errors": {"payload": [5.0, 1.0]}}, "payload must be"),
], ids=["unknown-key", "unknown-nested-key", "n-validation", "repeatability", "joint-box",
        "payload"])
def test_bad_config_values_are_refused_by_name(data, message):
    with pytest.raises(InputError, match=message):
        CampaignConfig.from_dict(data)
