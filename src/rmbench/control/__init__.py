"""H∞ proof-mass vibration suppression, designed on the robot and run closed loop in MuJoCo.

::

    from rmbench.robot.suppressor import reference_point
    from rmbench.control import robot_plant, design, sine_sweep, eccentric_test

    op = reference_point()                                    # MH180 stand-in, reference posture
    plant = robot_plant(op, ("tangential", "axial"), order=24)  # exact linearisation, 2x2 (METHODS §8)
    d = design(plant)                                         # mixed-sensitivity H∞, MIMO
    d.controller.save("ctrl.npz")                             # plain npz + JSON, never pickle
    sweep = sine_sweep(op, d.controller, "tangential", freqs)   # closed loop in MuJoCo

Signals in SI (N, m, m/s²); frequencies in Hz. Sign convention ``u = K y`` (hinfsyn's).
"""

from rmbench.control.axes import AxesDesign, design_axes
from rmbench.control.analysis import (amplification_db, closed_loop_matrix, fullband_ratio, is_stable, peak_near,
                                      reduction, rms_ratio, sensitivity)
from rmbench.control.closed_loop import Hardware, LoopDiverged, LoopRecord, eccentric_force_amplitude, run_loop
from rmbench.control.controller import CONTROLLER_VERSION, Controller
from rmbench.control.design import (Design, DesignError, achieves_gamma, controller_order, design, generalized_plant,
                                    modify, plant_order, robust_design)
from rmbench.control.experiments import (eccentric_test, excitation_frequencies, measure_accelerance, measured_plant,
                                         reduction_at, settle_time, sine_sweep)
from rmbench.control.identify import (MatrixModes, ModeFit, fit_mode, fit_modes, fit_modes_matrix, plant_from_frf,
                                      plant_from_frf_matrix)
from rmbench.control.plant import AXES, Plant, ReactionMass, reaction_mass, robot_plant, two_mass_plant
from rmbench.control.postures import posture_for_mode_ratio
from rmbench.control.robust import (RobustCertificate, certify_robust, certify_schedule_robust, draw_modes,
                                    draw_plants, measured_modes, scenario_draws, scenario_epsilon)
from rmbench.control.sampled import SampledCertificate, certify_sampled, sampled_loop, sampled_radius, sampled_stable
from rmbench.control.suppression import SuppressionTest, suppression_frequencies, suppression_test
from rmbench.control.weights import Weights

__all__ = ["AXES", "Plant", "ReactionMass", "reaction_mass", "robot_plant", "two_mass_plant",
           "ModeFit", "fit_mode", "fit_modes", "plant_from_frf", "measure_accelerance", "measured_plant",
           "Weights", "Design", "DesignError", "design", "achieves_gamma", "generalized_plant", "modify", "robust_design",
           "Controller", "CONTROLLER_VERSION", "closed_loop_matrix", "is_stable", "sensitivity",
           "reduction", "peak_near", "amplification_db", "rms_ratio", "fullband_ratio",
           "Hardware", "LoopRecord", "LoopDiverged", "run_loop",
           "eccentric_force_amplitude", "sine_sweep", "eccentric_test", "excitation_frequencies",
           "reduction_at", "settle_time", "posture_for_mode_ratio",
           "SuppressionTest", "suppression_test", "suppression_frequencies",
           "AxesDesign", "design_axes", "plant_order", "controller_order",
           "sampled_loop", "sampled_radius", "sampled_stable", "SampledCertificate", "certify_sampled",
           "MatrixModes", "fit_modes_matrix", "plant_from_frf_matrix",
           "scenario_epsilon", "scenario_draws", "draw_modes", "draw_plants", "measured_modes",
           "RobustCertificate", "certify_robust", "certify_schedule_robust"]
