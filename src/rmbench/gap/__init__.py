"""Sim-to-real gap diagnosis (METHODS.md §11): where a model departs from measurements, which
unmodelled effect causes it, and how far the gap shrinks once that effect is in the model.

::

    from rmbench.gap import diagnose
    dg = diagnose("irb6660", "measured.nc")   # or a UFF58 directory
    dg.verdict, dg.effects[0].name, dg.effects[0].shrink
    dg.save("diagnosis/")                      # figures, tables, the updated variant MJCF

    from rmbench.gap import diagnose_tracker, tracker_data   # laser-tracker readings
    dg = diagnose_tracker("mh180", tracker_data(read_tracker_csv("readings.csv"), robot=...))
    dg.verdict, [s.name for s in dg.chosen], dg.heldout_before, dg.heldout_after

Layout: one engine per data kind, :mod:`rmbench.gap.frf` and :mod:`rmbench.gap.tracker`, around
the selection engine they share (:mod:`rmbench.gap.selection`: significance, information criteria,
bootstrap shrink and confidence); the blind cases and the real robot in :mod:`rmbench.gap.cases`;
figures in :mod:`rmbench.gap.plot`.
"""

from rmbench.calibrate.design import SensorOffset, TestDesign
from rmbench.calibrate.measured import GapDataWarning, MeasuredModes, measured_data
from rmbench.gap.frf import (KINDS, Change, Diagnosis, DiagnosisSettings, Effect, EffectResult, GapMap, ModelBench,
                             ModelModes, Param, RemainingGap, diagnose, gap_map, library, load_data,
                             remaining_gap)
from rmbench.gap.tracker import (FittedPose, PoseErrorMap, PoseModel, Source, SourceResult, TrackerData,
                                 TrackerDiagnosis, TrackerSettings, diagnose_tracker, source_library, tracker_data)

__all__ = ["diagnose", "Diagnosis", "DiagnosisSettings", "EffectResult", "load_data",
           "TestDesign", "SensorOffset", "Effect", "Param", "Change", "library", "KINDS",
           "GapDataWarning", "MeasuredModes", "measured_data", "ModelBench", "ModelModes",
           "GapMap", "gap_map", "diagnose_tracker", "tracker_data", "TrackerData", "TrackerSettings",
           "TrackerDiagnosis", "SourceResult", "PoseErrorMap", "FittedPose", "PoseModel", "Source",
           "source_library", "remaining_gap", "RemainingGap"]
