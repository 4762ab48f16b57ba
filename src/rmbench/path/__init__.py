"""Machining along a tool path with posture-dependent dynamics.

Tool paths come in through :mod:`rmbench.io.toolpath` (cutter-location CSV, a G-code subset; the
bundled ``pocket.ngc`` and ``contour.csv`` by :func:`example`). Along a path, :func:`reach_grid`
solves the robot's inverse kinematics at every cutter location and redundant angle θ, and
:func:`plan_schedule` chooses θ(s) to keep the most margin to chatter within joint-step limits::

    from rmbench.path import example, reach_grid, plan_schedule
    tp = example("pocket").resampled(5e-3)
    reach = reach_grid(robot, tp, np.radians(np.arange(-60, 61, 5)))
    plan = plan_schedule(margin, reach.theta, q=reach.q, max_step=1, max_dq=np.radians(2))

or all of it at once, with critical depths from a trained posture predictor
(:func:`predicted_depths`; the exact model's for reference, :func:`exact_depths`)::

    plan = plan_path(robot, predictor, example("pocket"), speed_rpm=15000, depth=3e-3)

and checked by milling in the simulator at locations along it (:func:`mill_schedule`)::

    cuts = mill_schedule(robot, plan, depth=3e-3, n=40)
    cuts.agreement        # share of cuts clear of the predicted limit that chatter as planned

The chain each posture of a path needs, seed 000's whole method composed from the stages below
it: predicted reference-tool dynamics (:mod:`rmbench.predict`) → the target tool put on by RCSA
(:mod:`rmbench.rcsa`) → its modes fitted (:mod:`rmbench.modal`) → stability lobes
(:mod:`rmbench.stability`)::

    from rmbench.path import predicted_lobes
    res = predicted_lobes(prediction, bands, reference_tool, target_tool, cutting, speeds, depths)
"""

from importlib import resources

from rmbench.errors import InputError
from rmbench.io.toolpath import ToolPath, read_toolpath
from rmbench.path.chain import ChainResult, predicted_lobes, predicted_tool_structures, tool_structures
from rmbench.path.margin import (DepthBand, DepthGrid, TipModes, depth_band, exact_depths, exact_modes, predicted_depths,
                                 predicted_modes)
from rmbench.path.plan import Schedule, best_fixed_schedule, fixed_schedule, plan_schedule, pointwise_schedule
from rmbench.path.milling import PathMilling, mill_schedule, sample_locations
from rmbench.path.planner import CUTTINGS, EXACT_MODES, FEEDS, RANGE_SPEEDS, SPEED_BY, REORIENTS, PathPlan, PlanSettings, plan_path, with_band
from rmbench.path.plan_file import load_plan, save_plan
from rmbench.path.reach import Reach, reach_grid

__all__ = ["ChainResult", "tool_structures", "predicted_tool_structures", "predicted_lobes", "EXAMPLES",
           "example", "Reach", "reach_grid", "Schedule", "plan_schedule", "fixed_schedule", "best_fixed_schedule", "pointwise_schedule",
           "DepthBand", "DepthGrid", "TipModes", "depth_band", "predicted_modes", "exact_modes", "predicted_depths", "exact_depths", "PathPlan", "PlanSettings", "plan_path", "with_band", "save_plan", "load_plan",
           "CUTTINGS", "FEEDS", "RANGE_SPEEDS", "REORIENTS", "EXACT_MODES", "SPEED_BY",
           "PathMilling", "mill_schedule", "sample_locations"]

#: the bundled tool paths, on the seed's workpiece plane
EXAMPLES = {"pocket": "pocket.ngc", "contour": "contour.csv"}


def example(name: str) -> ToolPath:
    """A bundled tool path: ``"pocket"`` (a 300 x 300 mm raster pocket, G-code) or ``"contour"``
    (a 400 x 400 mm contour with rounded corners, CSV), both inside the seed's posture grid."""
    if name not in EXAMPLES:
        raise InputError(f"no bundled tool path {name!r}; one of {', '.join(EXAMPLES)}")
    with resources.as_file(resources.files("rmbench.path").joinpath("data", EXAMPLES[name])) as p:
        return read_toolpath(p)
