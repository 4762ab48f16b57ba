"""What a tool-path plan is made with: the planner's settings (:class:`PlanSettings`) and the names
its options take (the cuts, feed directions, modes seen, speed choice).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.path.corners import REORIENTS
from rmbench.path.margin import ALL_MODES
from rmbench.stability.cutting import ALUMINIUM_6061, STEEL_C45, TI6AL4V

__all__ = ["PlanSettings", "CUTTINGS", "FEEDS", "RANGE_SPEEDS", "EXACT_MODES", "SPEED_BY"]

#: the cuts a plan is named for (``rmbench path plan --cutting``): aluminium 6061 slot (the seed's,
#: the default), steel C45 and titanium Ti-6Al-4V shoulder milling at low speed (issue 82)
CUTTINGS = {"aluminium": ALUMINIUM_6061, "steel": STEEL_C45, "titanium": TI6AL4V}
#: where the feed runs in the cut's model: ``"x"`` along base X everywhere (every plan before issue
#: 82), ``"path"`` along the path's own direction at each location (:meth:`ToolPath.heading`)
FEEDS = ("x", "path")
#: spindle speeds a named range (:data:`rmbench.stability.SPEED_RANGES`) is planned at, evenly
#: spread from its first to its last rev/min: 300, 600, ..., 3,000 for ``"low"``
RANGE_SPEEDS = 10
#: the modes the exact model's plan sees (``PlanSettings.exact_modes``): the measured bands' (every
#: plan before), or every mode of the linearised robot below ``PlanSettings.f_max``
EXACT_MODES = ("bands", ALL_MODES)
#: how the planner picks among several speeds (``PlanSettings.speed_by``): the largest smallest
#: critical depth, or the largest removal rate, that depth times the speed (feed per tooth, teeth
#: and width of cut fixed)
SPEED_BY = ("depth", "removal")


@dataclass(frozen=True)
class PlanSettings:
    """How a path is planned.

    Attributes
    ----------
    theta : ndarray, shape (m,), rad
        Candidate redundant angles.
    fixed_theta : float
        The fixed-θ schedule's angle, rad (the comparison).
    spacing : float
        Cutter-location spacing along cutting moves, m.
    eval_spacing : float
        Arc length between critical-depth evaluations, m.
    max_joint_rate : float
        Largest joint speed while cutting, rad/s (with the feed it bounds each joint's move between
        neighbouring locations).
    default_feed : float
        Feed where the path gives none, m/s.
    ramp_length : float
        Path length over which θ moves from one grid angle to the next, m (a cycloidal ramp,
        :func:`rmbench.path.plan.ramp_profile`; 0: within one move). 50 mm is one second at
        3000 mm/min.
    max_joint_accel, max_joint_jerk : float
        Largest joint acceleration (rad/s²) and jerk (rad/s³) the θ ramps may add to the path's own
        motion: a θ grid step taken within one 5 mm move at 3000 mm/min starts the joints at
        40-50 °/s from rest and threw the tool 0.8-3.7 mm off its path on the moving robot.
    feed : str
        Where the feed runs in the critical depth's cut (:data:`FEEDS`): ``"x"`` along base X
        everywhere (the default, every earlier plan's numbers), ``"path"`` along the path's own
        direction at each location (the tool tip's modes turned into the cut's frame,
        :func:`rmbench.stability.to_cut_frame`).
    reorient : str
        How θ changes (:data:`REORIENTS`): ``"ramps"`` only by the ramps above (the default, every
        earlier plan bit for bit); ``"corners"`` also by any number of grid steps at a corner,
        the feed stopped and the tool standing while the joints move rest to rest at
        ``max_joint_rate``, ``max_joint_accel`` and ``max_joint_jerk`` (:mod:`rmbench.path.corners`;
        the cost is the dwell, a standing tool rubbing the wall, reported in
        :attr:`PathPlan.reorientation`).
    corner_angle : float
        How far the feed heading must turn along a run of turning locations for a corner, rad
        (default 30°; a raster's pass end is two 90° corners, a rounded 90° corner one).
    exact_modes : str
        Which modes the exact model's plan (no predictor) sees (:data:`EXACT_MODES`): ``"bands"``
        the measured bands' (the default, every earlier plan bit for bit), ``"all"`` every mode of
        the linearised robot below ``f_max`` in one receptance
        (:func:`rmbench.path.margin.exact_modes` with ``bands="all"``): the tool's modes near 2.7 kHz
        and those between the bands take part, so the plan cannot pick a speed whose lobe the
        full model lacks. A predicted plan sees what its predictor was trained on.
    f_max : float
        The highest mode frequency ``exact_modes="all"`` keeps, Hz (default 8 kHz).
    speed_by : str
        Among several speeds (:data:`SPEED_BY`): ``"depth"`` keeps the one whose planned schedule
        keeps the largest smallest critical depth (the default), ``"removal"`` the one whose
        smallest depth times the speed is largest: the material-removal rate at that depth, where
        the feed per tooth, the teeth and the width of cut stay as they are.
    min_turn_gain : float
        With ``reorient="corners"``: the least relative rise of the smallest critical depth over
        the ramps-only schedule's that standing turns must buy, else none is taken (default 0.05;
        :func:`rmbench.path.plan_schedule`).
    """

    theta: tuple = tuple(np.radians(np.arange(-60.0, 61.0, 5.0)))
    fixed_theta: float = 0.0
    spacing: float = 5e-3
    eval_spacing: float = 20e-3
    max_joint_rate: float = np.radians(60.0)
    default_feed: float = 0.05
    ramp_length: float = 50e-3
    max_joint_accel: float = 1.0
    max_joint_jerk: float = 10.0
    feed: str = "x"
    reorient: str = "ramps"
    corner_angle: float = np.radians(30.0)
    exact_modes: str = "bands"
    f_max: float = 8000.0
    min_turn_gain: float = 0.05
    speed_by: str = "depth"

    def __post_init__(self):
        if self.speed_by not in SPEED_BY:
            raise InputError(f"the speed is chosen by {' or '.join(SPEED_BY)}, got {self.speed_by!r}")
        if not self.min_turn_gain >= 0:
            raise InputError(f"min_turn_gain must be a fraction >= 0, got {self.min_turn_gain!r}")
        if self.exact_modes not in EXACT_MODES:
            raise InputError(f"the exact plan sees the modes of {' or '.join(EXACT_MODES)}, got {self.exact_modes!r}")
        if not self.f_max > 0:
            raise InputError(f"f_max must be a frequency > 0 Hz, got {self.f_max!r}")
        if self.feed not in FEEDS:
            raise InputError(f"the feed runs along {' or '.join(FEEDS)}, got {self.feed!r}")
        if self.reorient not in REORIENTS:
            raise InputError(f"θ is re-oriented by {' or '.join(REORIENTS)}, got {self.reorient!r}")
        if not 0 < self.corner_angle <= np.pi:
            raise InputError(f"corner_angle must be in (0, π] rad, got {self.corner_angle!r}")
        th = np.asarray(self.theta, float)
        if th.ndim != 1 or len(th) < 1 or not np.all(np.isfinite(th)) or np.any(np.diff(th) <= 0):
            raise InputError("the candidate angles must be finite and increasing")
        for name in ("spacing", "eval_spacing", "max_joint_rate", "default_feed", "max_joint_accel",
                     "max_joint_jerk"):
            if not getattr(self, name) > 0:
                raise InputError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if not self.ramp_length >= 0:
            raise InputError(f"ramp_length must be >= 0, got {self.ramp_length!r}")

    @property
    def ramp_moves(self) -> int:
        """Moves between cutter locations one θ ramp takes (at least one)."""
        return max(1, int(round(self.ramp_length / self.spacing)))
