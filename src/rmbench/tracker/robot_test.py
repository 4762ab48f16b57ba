"""The robot test (the seed's Table 2) on a simulated tracker campaign.

The calibrated model is tested at new quasi-random configurations: model invalidation at the
seed's η = 0.375 mm (α = 0.9, at most 10 measurements per configuration), the smallest η it does
not reject, and the three baselines — each with the number of measurements it took — against
the truth the simulator knows: the model's noise-free error maximum over the workspace (100 000
quasi-random configurations of the same joint box) and over the validation configurations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.tracker.accuracy import AccuracyLevel, accuracy_level
from rmbench.tracker.baselines import largest_error, mean_error, outlier_rejection
from rmbench.tracker.campaign import CampaignConfig, TrackerCampaign
from rmbench.tracker.invalidation import InvalidationResult, invalidate
from rmbench.tracker.sampling import sobol_points

__all__ = ["RobotTest", "robot_test", "true_maximum", "workspace_errors"]


@dataclass(frozen=True)
class RobotTest:
    """Outcome of the robot test. Lengths in m.

    Attributes
    ----------
    identification_mean, identification_max : float
        Measured error of the calibrated model on its identification set.
    true_max : float
        Noise-free maximum error over ``n_truth`` quasi-random configurations (the workspace).
    true_max_validation : float
        Noise-free maximum error over the validation configurations.
    invalidation : InvalidationResult
        The test at ``eta``.
    level : AccuracyLevel
        Smallest η not rejected.
    baselines : dict of str to BaselineResult
    n_truth : int
    settings : dict
    """

    identification_mean: float
    identification_max: float
    true_max: float
    true_max_validation: float
    invalidation: InvalidationResult
    level: AccuracyLevel
    baselines: dict
    n_truth: int
    settings: dict

    def rows(self) -> list[tuple[str, int, float]]:
        """(method, measurements, identified accuracy in m), the seed's Table 2 rows."""
        out = [(name.replace("_", " ").title(), b.n_measurements, b.accuracy)
               for name, b in self.baselines.items()]
        out.append(("Model Invalidation", self.level.final.n_measurements, self.level.eta))
        return out

    def to_dict(self) -> dict:
        """Plain summary for JSON output (m)."""
        return {"identification_mean": self.identification_mean,
                "identification_max": self.identification_max,
                "true_max": self.true_max, "true_max_validation": self.true_max_validation,
                "n_truth": self.n_truth,
                "invalidation": self.invalidation.to_dict(),
                "accuracy_level": self.level.to_dict(),
                "baselines": {k: v.to_dict() for k, v in self.baselines.items()},
                "settings": dict(self.settings)}


def robot_test(config: CampaignConfig = CampaignConfig(), *, eta: float = 0.375e-3,
               alpha: float = 0.9, max_per_location: int = 10, n_mean: int = 10,
               n_truth: int = 100_000, refit_frames: bool = False, on_cap: str = "skip",
               search: str = "bisect", campaign: TrackerCampaign | None = None) -> RobotTest:
    """Run the robot test on a simulated campaign.

    Parameters
    ----------
    config : CampaignConfig
        Robot, seed, identification and validation set sizes.
    eta : float
        Accuracy level of the invalidation test, m (seed: 0.375 mm).
    alpha, max_per_location : float, int
        Confidence level and per-configuration cap (seed: 0.9, 10).
    n_mean : int
        Measurements per configuration of Mean Error.
    n_truth : int
        Quasi-random configurations on which the true maximum error is taken.
    refit_frames : bool
        Re-fit base and tool frames after each measurement, as the seed did (default off: the
        simulated tracker and tool do not move after the calibration registered them).
    on_cap, search : str
        Cap rule and η search (:func:`~rmbench.tracker.accuracy_level`).
    campaign : TrackerCampaign, optional
        An already built campaign for ``config``.

    Returns
    -------
    RobotTest
    """
    camp = campaign if campaign is not None else TrackerCampaign.build(config)
    q = camp.q_validation
    sigma = camp.sigma(q)

    def meter(key):
        return camp.error_meter(camp.rng(key))

    def correct():
        return camp.frame_refit(q) if refit_frames else None

    test = invalidate(meter(1), q, sigma, eta, alpha, max_per_location, on_cap=on_cap,
                      correct=correct())
    level = accuracy_level(meter(2), q, sigma, alpha, max_per_location, search=search,
                           on_cap=on_cap, eta_start=eta, correct=correct())
    single = _replaying(meter(3))  # one data set for Largest Error and Outlier Rejection
    baselines = {"largest_error": largest_error(single, q, correct=correct()),
                 "outlier_rejection": outlier_rejection(single, q, correct=correct()),
                 "mean_error": mean_error(meter(4), q, n_per_location=n_mean, correct=correct())}
    ident = camp.identification_errors()
    return RobotTest(
        identification_mean=float(ident.mean()) if len(ident) else float("nan"),
        identification_max=float(ident.max()) if len(ident) else float("nan"),
        true_max=true_maximum(camp, n_truth),
        true_max_validation=float(np.max(np.linalg.norm(camp.true_error(q), axis=1))),
        invalidation=test, level=level, baselines=baselines, n_truth=n_truth,
        settings={"eta": eta, "alpha": alpha, "max_per_location": max_per_location,
                  "n_mean": n_mean, "refit_frames": refit_frames, "on_cap": on_cap,
                  "search": search, "seed": camp.config.seed, "robot": camp.robot.name,
                  "n_identification": camp.config.n_identification,
                  "n_validation": len(q)})


def workspace_errors(campaign: TrackerCampaign, n: int = 100_000, *,
                     chunk: int = 20_000) -> np.ndarray:
    """Noise-free error magnitude of the model at ``n`` quasi-random configurations, shape (n,), m.

    The configurations are a scrambled Sobol sequence over the campaign's joint box (the same box
    the identification and validation configurations come from).
    """
    c = campaign.config
    q = sobol_points(n, c.joint_lower, c.joint_upper, campaign.rng(0))
    return np.concatenate([np.linalg.norm(campaign.true_error(q[k:k + chunk]), axis=1)
                           for k in range(0, n, chunk)])


def true_maximum(campaign: TrackerCampaign, n: int = 100_000, *, chunk: int = 20_000) -> float:
    """Noise-free maximum error magnitude of the model over ``n`` quasi-random configurations (m)."""
    return float(workspace_errors(campaign, n, chunk=chunk).max())


def _replaying(measure):
    """A measure that returns, at each location, the reading first taken there."""
    seen = {}

    def replay(location):
        key = np.asarray(location, float).tobytes()
        if key not in seen:
            seen[key] = measure(location)
        return seen[key]

    return replay
