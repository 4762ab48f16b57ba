"""Gap diagnosis from laser-tracker readings: the structural error sources and the pose model
(:mod:`.sources`), the least-squares engine (:mod:`.engine`), the calibration-then-search
diagnosis (:mod:`.diagnosis`), where the nominal's error lies (:mod:`.where`), the result
(:mod:`.result`) and its folder (:mod:`.files`). Model selection, significance and the bootstrap
shrink are :mod:`rmbench.gap.selection`'s, shared with the FRF engine; the ordinary-parameter
solver is :mod:`rmbench.calibrate.solver`'s.
"""

from rmbench.gap.tracker.data import TrackerData, tracker_data
from rmbench.gap.tracker.diagnosis import TrackerSettings, diagnose_tracker
from rmbench.gap.tracker.result import FittedPose, SourceResult, TrackerDiagnosis
from rmbench.gap.tracker.sources import PoseModel, Source, source_library
from rmbench.gap.tracker.where import PoseErrorMap

__all__ = ["diagnose_tracker", "tracker_data", "TrackerData", "TrackerSettings", "TrackerDiagnosis",
           "SourceResult", "PoseErrorMap", "FittedPose", "PoseModel", "Source", "source_library"]
