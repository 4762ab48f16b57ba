"""Laser-tracker campaigns and model invalidation (issue 5; METHODS.md §7, seed 004 Paper I).

The public API::

    result = invalidate(measure, locations, sigma, eta, alpha=0.9, max_per_location=10)
    level = accuracy_level(measure, locations, sigma, alpha=0.9, max_per_location=100, rng=rng)
    largest_error(measure, locations), outlier_rejection(...), mean_error(...)

``measure(location) -> error`` takes one new noisy measurement (a float for the 1-D test, an xyz
vector for the 3-D test) from any source — a simulator or a real tracker. The simulated MH180
campaign: :class:`TrackerCampaign`, :func:`robot_test`; the 1-D benchmark: :func:`table1`.
"""

from rmbench.tracker.accuracy import AccuracyLevel, accuracy_level
from rmbench.tracker.baselines import (BaselineResult, largest_error, mean_error,
                                       outlier_rejection)
from rmbench.tracker.benchmark import (METHODS, SEED_TABLE1, ErrorProfile, NoisyMeasure, Table1,
                                       accuracy_vs_measurements, sine_profile, table1)
from rmbench.tracker.calibration import CalibratedModel, GeometricCalibration
from rmbench.tracker.campaign import (MH180_CALIBRATION_BOX, MH180_JOINT_BOX, CampaignConfig,
                                      TrackerCampaign)
from rmbench.tracker.chain import SerialChain
from rmbench.tracker.invalidation import InvalidationResult, invalidate
from rmbench.tracker.readings import ReadingsJudgement, judge_readings, reading_errors, register_readings
from rmbench.tracker.registration import FrameRefit, kabsch
from rmbench.tracker.rejection import p_star, rejection_statistic
from rmbench.tracker.repeatability import iso9283_rp, joint_sigma_for_rp
from rmbench.tracker.robot_test import RobotTest, robot_test, true_maximum, workspace_errors
from rmbench.tracker.sampling import quasi_random_order, sobol_points
from rmbench.tracker.simulator import ErrorDistribution, HiddenErrors, TrackerSimulator, TrackerSpec

__all__ = [
    "invalidate", "InvalidationResult", "accuracy_level", "AccuracyLevel",
    "largest_error", "outlier_rejection", "mean_error", "BaselineResult",
    "p_star", "rejection_statistic",
    "table1", "Table1", "accuracy_vs_measurements", "ErrorProfile", "NoisyMeasure",
    "sine_profile", "METHODS", "SEED_TABLE1",
    "SerialChain", "TrackerSimulator", "TrackerSpec", "ErrorDistribution", "HiddenErrors",
    "GeometricCalibration", "CalibratedModel", "kabsch", "FrameRefit",
    "CampaignConfig", "TrackerCampaign", "MH180_JOINT_BOX", "MH180_CALIBRATION_BOX", "robot_test", "RobotTest",
    "true_maximum", "workspace_errors", "judge_readings", "register_readings", "reading_errors", "ReadingsJudgement",
    "iso9283_rp", "joint_sigma_for_rp", "sobol_points", "quasi_random_order",
]
