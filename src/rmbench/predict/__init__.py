"""Posture-dependent dynamics from a modal dataset (METHODS.md §5, §9; issue 15).

Learners of the modal parameters over the posture (x, y, θ): single- and multi-task Gaussian
processes (gpytorch, float64; the seed's grouped MTGPs, one Kronecker model of all parameters and its
low-rank variant) and the learning baselines of seed 003 (inverse-distance k nearest neighbours,
random forest, gradient boosting, elastic net); their cross-validated scores per parameter (random
folds, or all postures of one redundant angle held out); a trained predictor that gives the
parameters with standard deviations and the FRF matrix at any posture, saved as plain arrays::

    from rmbench.predict import training_set, cross_validate, PosturePredictor, predicted_frf
    ts = training_set(xr.open_dataset("modal.nc"))
    cv = cross_validate(ts, "mtgp-grouped", folds=5)        # cv.r2_mean, cv.r2_std per task
    pred = PosturePredictor("mtgp-grouped").fit(xr.open_dataset("modal.nc"))
    out = pred.predict([[1.8, 0.2, 0.0]])                    # modal, modal_std like a modal fit
    H = predicted_frf(out, freq)                             # (posture, freq, 4, 4) m/N
"""

from rmbench.predict.baselines import LEARNERS, MULTI_TASK, IDWNeighbours, PerTask, make_learner
from rmbench.predict.cv import CVScores, cross_validate, folds_of, validate_predictor
from rmbench.predict.data import TrainingSet, training_set
from rmbench.predict.gp import MTGP, STGP
from rmbench.predict.mtgp import GroupedMTGP, seed_groups
from rmbench.predict.predictor import (SAVEABLE, ExtrapolationWarning, PosturePredictor, frf_lines, predicted_frf,
                                      predicted_frf_dataset)

__all__ = ["training_set", "TrainingSet", "cross_validate", "CVScores", "folds_of", "validate_predictor",
           "IDWNeighbours", "PerTask", "make_learner", "LEARNERS", "MULTI_TASK", "STGP", "MTGP",
           "GroupedMTGP", "seed_groups", "PosturePredictor", "predicted_frf", "predicted_frf_dataset", "frf_lines",
           "ExtrapolationWarning",
           "SAVEABLE"]
