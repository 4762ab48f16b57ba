"""Posture-dependent dynamics from a modal dataset (METHODS.md §5, §9; issue 15, in progress).

In place: the training set of a modal dataset, the learning baselines of seed 003 (inverse-distance
k nearest neighbours, random forest, gradient boosting, elastic net) and their cross-validated
scores per modal parameter (random folds, or all postures of one redundant angle held out)::

    from rmbench.predict import training_set, cross_validate
    ts = training_set(xr.open_dataset("modal.nc"))
    cv = cross_validate(ts, "knn", folds=5)          # cv.r2_mean, cv.r2_std per task
"""

from rmbench.predict.baselines import LEARNERS, IDWNeighbours, make_learner
from rmbench.predict.cv import CVScores, cross_validate, folds_of
from rmbench.predict.data import TrainingSet, training_set

__all__ = ["training_set", "TrainingSet", "cross_validate", "CVScores", "folds_of",
           "IDWNeighbours", "make_learner", "LEARNERS"]
