"""Gap diagnosis from laser-tracker readings: the structural error sources and the pose model
(:mod:`.sources`), and the calibration-then-search engine (:mod:`.diagnosis`). Model selection,
significance and the bootstrap shrink are :mod:`rmbench.gap.selection`'s, shared with the FRF
engine; the ordinary-parameter solver is :mod:`rmbench.calibrate.solver`'s.
"""

from rmbench.gap.tracker.diagnosis import (FittedPose, PoseErrorMap, SourceResult, TrackerData, TrackerDiagnosis,
                                           TrackerSettings, diagnose_tracker, tracker_data)
from rmbench.gap.tracker.sources import PoseModel, Source, source_library

__all__ = ["diagnose_tracker", "tracker_data", "TrackerData", "TrackerSettings", "TrackerDiagnosis",
           "SourceResult", "PoseErrorMap", "FittedPose", "PoseModel", "Source", "source_library"]
