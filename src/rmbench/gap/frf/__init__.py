"""Gap diagnosis from FRFs (impact campaigns, UFF58, modal tables): the effect library
(:mod:`.effects`), the model as tested (:mod:`.model`), the first-order and refined search
(:mod:`.search`, pairs in :mod:`.pairs`), its joint form on a calibrated model (:mod:`.joint`),
confirmation by recalibration (:mod:`.confirm`, and what the diagnosis makes of it:
:mod:`.confirmed`, :mod:`.picks`), the gap map (:mod:`.where`) and the diagnosis that runs them
(:mod:`.diagnosis`): its data (:mod:`.prepare`), settings (:mod:`.settings`), first calibration
(:mod:`.calibration`), verdict rules (:mod:`.rules`), evidence (:mod:`.evidence`), results
(:mod:`.result`) and files (:mod:`.files`). Model selection, significance and the bootstrap shrink
are :mod:`rmbench.gap.selection`'s, shared with the tracker engine.
"""

from rmbench.gap.frf.diagnosis import (Diagnosis, DiagnosisSettings, EffectResult, RemainingGap, diagnose, load_data,
                                       remaining_gap)
from rmbench.gap.frf.effects import KINDS, Change, Effect, Param, library
from rmbench.gap.frf.model import ModelBench, ModelModes
from rmbench.gap.frf.where import GapMap, gap_map

__all__ = ["diagnose", "Diagnosis", "DiagnosisSettings", "EffectResult", "load_data", "Effect", "Param",
           "Change", "library", "KINDS", "ModelBench", "ModelModes", "GapMap", "gap_map", "remaining_gap",
           "RemainingGap"]
