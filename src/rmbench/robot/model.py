"""The virtual robot: load a model with its tool, command a posture, read off the exact dynamics.

>>> robot = Robot.load("irb6660", tool="dummy")
>>> op = robot.at(Posture.from_mm_deg(1800, -200, 0))
>>> table = op.modes("low")           # exact modal parameters in the seed's parameterisation
>>> h = op.frf(np.linspace(5, 40, 400), s_1a=0.0334)   # exact 4x4 receptance, m/N
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from rmbench.errors import ModelError, RmbenchError, UnreachablePosture
from rmbench.robot.catalog import resolve_robot, resolve_tool
from rmbench.robot.kinematics import IKSolution, Kinematics
from rmbench.robot.linear import LinearModel, equilibrium, linearize
from rmbench.robot.load_stiffness import (LOAD_STIFFNESS, check_load_stiffness, parse_load_stiffness,
                                          posture_stiffness, stiffened_spec)
from rmbench.robot.modes import ModeTable, mode_table
from rmbench.robot.posture import Posture, rz, seed_grid, validation_postures
from rmbench.robot.spec import custom_numeric, custom_text, graft_tool, load_spec, set_custom_text, spec_to_xml

__all__ = ["Robot", "OperatingPoint", "Band", "COORDS"]

#: The four measurement coordinates, in the FRF matrices' order: displacement along base X and Y
#: at the tool tip (1) and at point 1a, the band's ``s_1a`` (m) up the tool.
COORDS = ("1X", "1Y", "1aX", "1aY")
_DIRECTIONS = {"X": np.array([1.0, 0, 0]), "Y": np.array([0, 1.0, 0]), "Z": np.array([0, 0, 1.0])}


@dataclass(frozen=True)
class Band:
    """A measurement band.

    Attributes
    ----------
    name : str
        ``"low"`` or ``"high"``.
    f_min, f_max : float
        Frequency range, Hz.
    s_1a : float
        Distance of point 1a up the tool from the tip in this band, m (METHODS.md §1).
    """

    name: str
    f_min: float
    f_max: float
    s_1a: float


class Robot:
    """A flexible-joint robot model ready to be posed and linearised.

    Use :meth:`load`; the constructor takes an assembled MJCF text.

    Attributes
    ----------
    name : str
        Bundled name, or the file name of a user's MJCF.
    tool : str or None
        Name of the attached tool.
    xml : str
        MJCF text of the assembled robot (robot and tool), the single model source.
    model : mujoco.MjModel
    arm_joints : tuple of str
        Actuated joints commanded by inverse kinematics.
    limits : ndarray, shape (n_arm, 2), rad
    table_z : float
        Height of the tool tip for postures, m.
    bands : dict of str to Band
    spindle_rpm : float
        Spindle speed at the operating point (0: at rest, reciprocal dynamics).
    load_stiffness : dict of str to float
        α of each passive joint whose stiffness grows with its gravity load
        (:mod:`rmbench.robot.load_stiffness`); empty for a robot of constant stiffness.
    """

    def __init__(self, xml: str, *, name: str, tool: str | None, spindle_rpm: float = 0.0,
                 spec: mujoco.MjSpec | None = None):
        self.xml = xml
        self.name = name
        self.tool = tool
        try:
            self.model = mujoco.MjModel.from_xml_string(xml)
        except ValueError as err:
            raise ModelError(f"robot {name!r} does not compile: {str(err).splitlines()[0]}") from None
        self._spec = spec if spec is not None else mujoco.MjSpec.from_string(xml)
        if not np.isfinite(spindle_rpm):
            raise RmbenchError(f"spindle_rpm must be finite, got {spindle_rpm}")
        self.spindle_rpm = float(spindle_rpm)
        arm = (custom_text(self._spec, "rmbench_arm_joints") or "j1 j2 j3 j4 j5 j6").split()
        self.arm_joints = tuple(arm)
        for j in arm:
            if mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, j) < 0:
                raise ModelError(f"robot {name!r} has no arm joint {j!r}")
        self.limits = np.array([self.model.joint(j).range for j in arm])
        self.tcp = custom_text(self._spec, "rmbench_tcp") or "tool_tip"
        if mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, self.tcp) < 0:
            raise ModelError(f"robot {name!r} has no site {self.tcp!r} (tool tip); attach a tool")
        self.table_z = float(custom_numeric(self._spec, "rmbench_table_z", [0.5])[0])
        self.ik_seed = custom_numeric(self._spec, "rmbench_ik_seed", np.zeros(len(arm)))
        bands = custom_numeric(self._spec, "rmbench_bands", [5, 40, 600, 1400])
        s_1a = custom_numeric(self._spec, "rmbench_s_1a", [0.0334, 0.020])
        self.bands = {"low": Band("low", bands[0], bands[1], s_1a[0]),
                      "high": Band("high", bands[2], bands[3], s_1a[1])}
        self._held = np.array(sorted({int(self.model.jnt_dofadr[self.model.actuator_trnid[a, 0]])
                                      for a in range(self.model.nu)
                                      if self.model.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT}))
        try:
            self.load_stiffness = parse_load_stiffness(custom_text(self._spec, LOAD_STIFFNESS))
            check_load_stiffness(self.model, self.load_stiffness)
        except ModelError as err:
            raise ModelError(f"robot {name!r}: {err}") from None
        self._kin = None

    @classmethod
    def load(cls, robot: str | Path = "irb6660", *, tool: str | Path | None = None,
             spindle_rpm: float = 0.0) -> "Robot":
        """Load a bundled robot by name, or an MJCF file, and attach a tool.

        Parameters
        ----------
        robot : str or Path
            ``"irb6660"``, ``"mh180"`` or a path to an MJCF file (e.g. a saved variant).
        tool : str or Path, optional
            Bundled tool name (``"dummy"``, ``"endmill"``) or a tool MJCF path. By default the
            robot's own tool if its file carries one, else its declared default tool, if any.
            Naming the tool a file already carries (a saved variant) keeps that tool.
        spindle_rpm : float
            Spindle speed, rev/min; non-zero adds the rotor's gyroscopic coupling.
        """
        path = resolve_robot(robot)
        spec = load_spec(path)
        has_tool = any(b.name.startswith("tool_") for b in spec.bodies)
        tool_name = custom_text(spec, "rmbench_tool")
        if tool is None and not has_tool:
            tool = custom_text(spec, "rmbench_default_tool")
        if has_tool and tool is not None and _tool_name(tool) != tool_name:
            raise ModelError(f"{path} already carries the tool {tool_name!r}; ask for that tool or none, "
                             f"not {str(tool)!r}")
        if tool is not None and not has_tool:
            tool_path = resolve_tool(tool)
            graft_tool(spec, load_spec(tool_path))
            tool_name = _tool_name(tool)
            set_custom_text(spec, "rmbench_tool", tool_name)
        name = path.stem if str(robot).endswith(".xml") or "/" in str(robot) else str(robot)
        return cls(spec_to_xml(spec), name=name, tool=tool_name, spindle_rpm=spindle_rpm, spec=spec)

    # --- identity -----------------------------------------------------------------------------
    @property
    def fingerprint(self) -> str:
        """Short hash of the assembled MJCF text, to tell models apart in datasets."""
        return hashlib.sha256(self.xml.encode()).hexdigest()[:12]

    @property
    def spec(self) -> mujoco.MjSpec:
        """A fresh copy of the assembled specification, for deriving variants."""
        return mujoco.MjSpec.from_string(self.xml)

    @property
    def kinematics(self) -> Kinematics:
        """Forward and inverse kinematics of the arm's actuated joints to the tool tip (built on
        first use)."""
        if self._kin is None:
            self._kin = Kinematics(self.xml, self.arm_joints, self.limits, self.tcp)
        return self._kin

    # --- postures -----------------------------------------------------------------------------
    def grid(self) -> list[Posture]:
        """The robot's training posture grid: its own (``rmbench_grid_*`` in the MJCF, written by
        ``rmbench model build``), else the seed's 112 postures."""
        spec = self._spec
        axes = [custom_numeric(spec, f"rmbench_grid_{a}") for a in ("x_mm", "y_mm", "theta_deg")]
        if any(a is None for a in axes):
            return seed_grid()
        return [Posture.from_mm_deg(x, y, t) for x in axes[0] for y in axes[1] for t in axes[2]]

    def validation(self) -> list[Posture]:
        """The robot's three validation postures (``rmbench_validation``), else the seed's."""
        values = custom_numeric(self._spec, "rmbench_validation")
        if values is None:
            return validation_postures()
        if len(values) % 3:
            raise ModelError(f"robot {self.name!r}: rmbench_validation needs (x mm, y mm, theta deg) triples")
        return [Posture.from_mm_deg(*values[i:i + 3]) for i in range(0, len(values), 3)]

    def target(self, posture: Posture) -> pin.SE3:
        """Pose of the tool tip for a posture: at table height, tool axis down, θ about +Z."""
        return pin.SE3(rz(posture.theta), np.array([posture.x, posture.y, self.table_z]))

    def ik(self, posture: Posture) -> IKSolution:
        """Rigid-body inverse kinematics of a posture on the preferred branch.

        Raises
        ------
        UnreachablePosture
            With the posture in the message.
        """
        seed = np.array(self.ik_seed, float)
        seeds = [seed]
        base = seed.copy()
        base[0] = np.arctan2(posture.y, posture.x)
        seeds.append(base)
        for d4 in (-0.8, 0.8):
            s = base.copy()
            s[3] += d4
            s[5] -= d4
            seeds.append(s)
        try:
            sol = self.kinematics.solve(self.target(posture), seeds)
        except UnreachablePosture:
            raise UnreachablePosture(
                f"posture {posture.label()} (mm, mm, deg) is unreachable by {self.name}: "
                "no inverse-kinematics solution within the joint limits") from None
        return sol

    def at(self, posture: Posture | np.ndarray) -> "OperatingPoint":
        """Operating point: IK, deflected static equilibrium and exact linearisation.

        For a robot with load-dependent joint stiffness (:attr:`load_stiffness`) the operating
        point's robot is a per-posture copy (same name, tool and spindle speed) whose joints
        have the secant stiffness of this posture's gravity load, settled again with it; its
        model, equilibrium, linearisation and :attr:`xml` (from which time-domain simulations
        are built) all agree.

        Parameters
        ----------
        posture : Posture or ndarray of shape (n_arm,)
            A posture, or the arm joint commands directly (rad).
        """
        if isinstance(posture, Posture):
            sol = self.ik(posture)
            q_cmd = sol.q
        else:
            q_cmd = np.asarray(posture, float)
            if q_cmd.shape != (len(self.arm_joints),):
                raise RmbenchError(f"joint command must have {len(self.arm_joints)} values, got {q_cmd.shape}")
            sol, posture = None, None
        data = self.settle(q_cmd)
        robot = self
        if self.load_stiffness:
            robot = self.stiffened(posture_stiffness(self.model, data, self.load_stiffness))
            data = robot.settle(q_cmd)
        return OperatingPoint(robot, posture, q_cmd, sol, data, linearize(robot.model, data))

    def stiffened(self, stiffness: dict[str, float]) -> "Robot":
        """The robot with the given joint stiffnesses and no load-dependent stiffness left.

        Parameters
        ----------
        stiffness : dict of str to float
            Linear stiffness per joint, N·m/rad (hinge) or N/m (slide).

        Returns
        -------
        Robot
            Same name, tool and spindle speed. The MJCF writer keeps 6 significant digits, so
            the stiffness is rounded to those.
        """
        spec = stiffened_spec(self.spec, stiffness)
        return Robot(spec_to_xml(spec), name=self.name, tool=self.tool, spindle_rpm=self.spindle_rpm,
                     spec=spec)

    def settle(self, q_cmd: np.ndarray, data: mujoco.MjData | None = None) -> mujoco.MjData:
        """MjData at the deflected static equilibrium under the arm command ``q_cmd`` (rad).

        ``data``: an ``MjData`` of a model with this one's sizes to settle in, reset first (a
        calibration settles thousands of times: allocating one each time costs more than the
        reset); by default a new one."""
        if data is None:
            data = mujoco.MjData(self.model)
        else:
            mujoco.mj_resetData(self.model, data)      # as fresh: a reused one settles the same
        for name, q in zip(self.arm_joints, q_cmd):
            data.qpos[self.model.joint(name).qposadr[0]] = q
        spin = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, "spindle_spin")
        if spin >= 0:
            data.qvel[self.model.jnt_dofadr[spin]] = self.spindle_rpm * 2 * np.pi / 60
        equilibrium(self.model, data, self._held)
        return data


class OperatingPoint:
    """A robot at the deflected static equilibrium of one posture, with its exact linear dynamics.

    Attributes
    ----------
    robot : Robot
    posture : Posture or None
    q_cmd : ndarray, shape (n_arm,), rad
        Commanded arm joints (rigid-body IK).
    ik : IKSolution or None
    data : mujoco.MjData
        State at equilibrium, with ``ctrl`` holding the servo commands that keep it there.
    linear : LinearModel
    """

    def __init__(self, robot, posture, q_cmd, ik, data, linear: LinearModel):
        self.robot = robot
        self.posture = posture
        self.q_cmd = q_cmd
        self.ik = ik
        self.data = data
        self.linear = linear

    def point_jacobian(self, site: str, offset_up: float = 0.0) -> np.ndarray:
        """Translational Jacobian of a point, shape (3, n_dof).

        The point is ``site``, moved ``offset_up`` metres along the site's +z axis (up the tool for
        the tool tip) and carried by the body on which that spot of the tool lies.
        """
        m, d = self.robot.model, self.data
        sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
        if sid < 0:
            raise ModelError(f"unknown site {site!r}")
        point, body = tool_point(m, d, sid, offset_up)
        jacp = np.zeros((3, m.nv))
        mujoco.mj_jac(m, d, jacp, None, point, body)
        return jacp

    def coordinate_map(self, coords=COORDS, *, s_1a: float | None = None) -> np.ndarray:
        """Rows mapping generalised displacements to coordinates, shape (n_coords, n_dof).

        Coordinates are ``"1X"``, ``"1Y"`` (tool tip), ``"1aX"``, ``"1aY"`` (point ``s_1a`` up the
        tool), ``"1rX"``, ``"1rY"`` (rotation of the tool tip, rad), or ``"SITE:D"`` for any site and
        base direction D in X, Y, Z. The same rows map forces in those coordinates to generalised
        forces (transposed); for a rotation that force is the conjugate moment (N·m).

        A rotation ``1rD`` is the slope of the D-displacement along the tool axis, positive when
        the tip moves further along +D than the points above it (METHODS.md §3:
        ``θ_D ≈ (u_D,1 − u_D,1a)/S``); its moment is the couple of +F at the tip and −F above it.
        In right-handed rotations φ about the base axes, with the tool axis a pointing up the tool,
        ``θ_D = (e_D × a)·φ``: for a vertical tool ``θ_X = −φ_Y`` and ``θ_Y = +φ_X``.
        """
        s = self.robot.bands["high"].s_1a if s_1a is None else float(s_1a)
        rows = []
        for c in coords:
            if c in ("1rX", "1rY"):
                rows.append(self._slope_row(c[-1]))
                continue
            if c in ("1X", "1Y", "1Z"):
                site, off, axis = self.robot.tcp, 0.0, c[-1]
            elif c in ("1aX", "1aY", "1aZ"):
                site, off, axis = self.robot.tcp, s, c[-1]
            elif ":" in c:
                site, axis = c.rsplit(":", 1)
                off = 0.0
            else:
                raise RmbenchError(f"unknown coordinate {c!r}; use 1X, 1Y, 1aX, 1aY or SITE:X|Y|Z")
            if axis not in _DIRECTIONS:
                raise RmbenchError(f"unknown direction in coordinate {c!r}; use X, Y or Z")
            rows.append(_DIRECTIONS[axis] @ self.point_jacobian(site, off))
        return np.array(rows)

    def _slope_row(self, axis: str) -> np.ndarray:
        m, d = self.robot.model, self.data
        sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, self.robot.tcp)
        jacr = np.zeros((3, m.nv))
        mujoco.mj_jac(m, d, None, jacr, d.site_xpos[sid], int(m.site_bodyid[sid]))
        tool_axis = d.site_xmat[sid].reshape(3, 3)[:, 2]
        return np.cross(_DIRECTIONS[axis], tool_axis) @ jacr

    def frf(self, freq, coords=COORDS, *, s_1a: float | None = None) -> np.ndarray:
        """Exact receptance matrix, m/N, shape (n_freq, n_coords, n_coords): row response, column force."""
        t = self.coordinate_map(coords, s_1a=s_1a)
        return self.linear.modes().frf(np.asarray(freq, float), t, t)

    def modes(self, band: str = "low", *, s_1a: float | None = None, threshold: float = 0.01) -> ModeTable:
        """Exact modal parameters of the modes visible in a band (METHODS.md §2, DATA.md).

        A mode is listed when its natural frequency lies in the band and its largest contribution
        to the band's 4x4 receptance matrix exceeds ``threshold`` times the band's peak.
        """
        if band not in self.robot.bands:
            raise RmbenchError(f"unknown band {band!r}; use low or high")
        b = self.robot.bands[band]
        s = b.s_1a if s_1a is None else s_1a
        t = self.coordinate_map(COORDS, s_1a=s)
        return mode_table(self.linear.modes(), t, t, b, threshold=threshold)


def tool_point(model: mujoco.MjModel, data: mujoco.MjData, site: int, s_up: float):
    """World position of the point ``s_up`` (m) up the site's +z axis, and the body carrying it.

    Walks up the tool's segments from the site's body until the body's origin (its hinge) lies
    above the point.
    """
    axis = data.site_xmat[site].reshape(3, 3)[:, 2]
    point = data.site_xpos[site] + s_up * axis
    body = int(model.site_bodyid[site])
    while s_up > 0 and body > 0 and (data.xpos[body] - data.site_xpos[site]) @ axis < s_up - 1e-12:
        body = int(model.body_parentid[body])
    return point, body


def _tool_name(tool: str | Path) -> str:
    return Path(tool).stem if str(tool).endswith(".xml") else str(tool)

