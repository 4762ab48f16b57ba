"""Model updating (METHODS.md §11): a nominal robot's ordinary parameters fitted to measured modes.

::

    from rmbench.calibrate import calibrate, load_modal_data, CalibrationSettings
    data = load_modal_data("measured.nc")                  # campaign, UFF58 dir, modal fit or table CSV
    cal = calibrate(Robot.load("irb6660", tool="dummy"), data, held=[3, 7],
                    settings=CalibrationSettings(groups=("joints", "damping", "masses")))
    [(p.name, p.value, p.interval, p.identifiability) for p in cal.params]
    cal.heldout_summary()                                  # held-out errors before and after
    print(cal.summary())                                   # χ² before/after, held-out errors, identifiable
    cal.plot()                                             # each estimate over its nominal, 95 % interval
    Path("calibrated.xml").write_text(cal.xml)             # a robot every command accepts

The measurement side (test design, measured modes, pairing and residuals, :class:`ModalData`) and the
model as a test sees it (:mod:`rmbench.calibrate.modes`) live here too: the gap diagnosis builds on
both.
"""

from rmbench.calibrate.data import ModalData, load_modal_data, read_modal_table
from rmbench.calibrate.design import SensorOffset, TestDesign
from rmbench.calibrate.fit import CalibrationSettings, calibrate, linearisation
from rmbench.calibrate.measured import MeasuredModes
from rmbench.calibrate.model import ModalModel
from rmbench.calibrate.modes import ModelModes, modes_seen
from rmbench.calibrate.result import Calibration, ParameterEstimate, error_summary, mode_errors
from rmbench.calibrate.split import spread_held_out

__all__ = ["calibrate", "Calibration", "CalibrationSettings", "ParameterEstimate", "mode_errors", "error_summary",
           "linearisation", "ModalData", "load_modal_data", "read_modal_table", "TestDesign", "SensorOffset",
           "MeasuredModes", "ModalModel", "ModelModes", "modes_seen", "spread_held_out"]
