"""Real robots for the blind benches, built apart from the method they score.

Plain ElementTree edits of the nominal MJCF: the ordinary spread (:mod:`_truth_edits`), a
foundation of its own mass and damping, and the model-form errors no calibrated model holds
(:mod:`truth.form`), composed by :func:`truth.robot.draw_real_robot`. Nothing here imports
rmbench's parameter, variant, calibration, diagnosis or identification code
(``sim_tests/test_truth_independence.py``).
"""

from truth.form import FORM_KINDS, RANGES, FormError, apply_form, draw_form, median_form
from truth.robot import RealRobot, draw_real_robot

__all__ = ["FORM_KINDS", "RANGES", "FormError", "apply_form", "draw_form", "median_form", "RealRobot",
           "draw_real_robot"]
