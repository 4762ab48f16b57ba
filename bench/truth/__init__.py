"""Real robots for the benches, built apart from the method they score: every truth the benches
draw, one module per concern and data kind.

==================  ===========================================================================
module              what it holds
==================  ===========================================================================
``ordinary``        the ordinary spread: plain ElementTree edits of the nominal MJCF (joints,
                    servos, links, the tool holder, a foundation)
``robot``           FRF real robots: the spread, a foundation of their own, form errors
                    (:func:`draw_real_robot`); the in-model benches' spread robots
                    (:func:`truth.robot.draw_truth`)
``form``            model-form errors no calibrated model holds
``structural``      FRF structural effects, in and outside the diagnosis's library
``visibility``      whether an FRF effect shows beyond the campaign's noise
``tracker``         tracker real robots, their readings, spread, campaigns and visibility
``tracker_spread``  the tracker bench's spread robots read through the tracker simulator
``control``         the scheduled-control bench's real MH180s
``score``           the blind benches' scores
==================  ===========================================================================

Nothing here imports rmbench's parameter, variant, calibration, diagnosis or identification code
(``sim_tests/test_truth_independence.py``, over every module of the package). Sizes are never
enlarged to make an effect visible: an invisible draw is counted apart.
"""

from truth.form import FORM_KINDS, RANGES, FormError, apply_form, draw_form, median_form
from truth.robot import RealRobot, draw_real_robot

__all__ = ["FORM_KINDS", "RANGES", "FormError", "apply_form", "draw_form", "median_form", "RealRobot",
           "draw_real_robot"]
