"""Any arm as a bench robot: a URDF turned into a flexible-joint MJCF with spindle and metadata.

Each revolute joint ``N`` of the arm becomes the pair the stand-ins use (Spong's flexible joint):
a motor body ``motorN`` with hinge ``jN`` (rotor armature, held by the position servo ``aN``) and
the URDF link with hinge ``jN_flex`` (gearbox and arm compliance: spring and damper). Kinematics and
inertias are the URDF's, through MuJoCo's own URDF import. A light electro-spindle (the milling
robot's spindle scaled down, :func:`add_spindle`) is mounted on the flange, inline with the last
axis by default (or by a bracket, perpendicular to it, as on the milling robot), with the tool
site ``tool_mount`` on the rotor's nose. Inline, the redundant angle θ turns the last joint only:
the arm's modes hardly depend on it, the spindle's (whose bearings' axes turn) do.

URDFs carry no joint stiffness, damping or rotor inertia. The stiffness rule (:class:`FlexRule`):

* at the reference posture (the grid's centre) take the link-side mass matrix M of the flexible
  joints with the motors locked (MuJoCo's ``mj_fullM``);
* the diagonal joint stiffness K is the one whose eigenfrequencies with M are log-spaced from
  ``f_low`` to ``spread`` · ``f_low`` (:func:`assign_frequencies`), or, where the arm's coupling
  puts that spectrum out of reach, the closest in log-frequency least squares, scaled so the lowest
  is ``f_low``: well separated modes, as the modal fit needs and real arms show (a rule per joint
  alone, such as k_i ∝ M_ii, leaves coupled wrist modes within a per cent of each other);
* damping c_i = 2 ζ √(k_i M_ii); armature a_i = ρ M_ii; servo kp_i = κ k_i, kv_i = 2 ζ_s √(kp_i a_i).

The spindle bearings' four stiffnesses are then scaled together so that the lowest spindle mode,
with the bench's default (dummy) tool, lies at ``spindle_hz``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from rmbench.errors import ModelError
from rmbench.robot.catalog import resolve_tool
from rmbench.robot.posture import Posture
from rmbench.robot.spec import graft_tool, load_spec, spec_to_xml
from rmbench.robot.urdf import UrdfArm, find_urdf, read_urdf, urdf_spec
from rmbench.robot.workspace import WorkspaceGrid, find_workspace_grid

__all__ = ["FlexRule", "SpindleRule", "BuiltArm", "build_arm", "add_spindle", "campaign_toml", "assign_frequencies"]

HINGE = mujoco.mjtJoint.mjJNT_HINGE
SLIDE = mujoco.mjtJoint.mjJNT_SLIDE
_TINY = 1e-9   # kg and kg m²: the motor body itself; its inertia is the armature


@dataclass(frozen=True)
class FlexRule:
    """How joint stiffness, damping, rotor inertia and servo gains follow from the arm's inertia.

    Attributes
    ----------
    f_low : float
        Lowest natural frequency at the reference posture with the motors locked, Hz.
    spread : float
        Ratio of the highest of the arm's natural frequencies to the lowest (log-spaced between).
    zeta : float
        Damping ratio of each joint on its own.
    armature_ratio : float
        Rotor inertia reflected through the gearbox over the link-side inertia M_ii.
    servo_ratio : float
        Position-servo stiffness over the joint stiffness.
    servo_zeta : float
        Damping ratio of the servo on the rotor.
    """

    f_low: float = 9.0
    spread: float = 3.0
    zeta: float = 0.03
    armature_ratio: float = 0.3
    servo_ratio: float = 20.0
    servo_zeta: float = 0.5

    def __post_init__(self):
        checks = {"f_low": self.f_low > 0, "spread": self.spread >= 1, "zeta": 0 <= self.zeta < 1,
                  "armature_ratio": self.armature_ratio > 0, "servo_ratio": self.servo_ratio > 0,
                  "servo_zeta": self.servo_zeta > 0}
        for name, ok in checks.items():
            if not (ok and math.isfinite(getattr(self, name))):
                raise ModelError(f"flexible-joint rule: {name} = {getattr(self, name)!r} is out of range")


@dataclass(frozen=True)
class SpindleRule:
    """The spindle on the flange.

    Attributes
    ----------
    mass : float or None
        Spindle mass (housing and rotor), kg; None: 10 % of the arm's moving mass.
    spindle_hz : float
        Lowest spindle (bearing) mode with the dummy tool, Hz.
    mount : str
        ``"inline"``: the tool on the last joint's axis (how spindles go on light arms);
        ``"bracket"``: perpendicular to it, offset, as on the milling robot (a UR10's wrist holds
        it over θ ±40°; the Panda's over no grid at all).
    """

    mass: float | None = None
    spindle_hz: float = 850.0
    mount: str = "inline"

    def __post_init__(self):
        if self.mount not in ("bracket", "inline"):
            raise ModelError(f"spindle mount must be 'bracket' or 'inline', got {self.mount!r}")
        if self.mass is not None and not (math.isfinite(self.mass) and self.mass > 0):
            raise ModelError(f"spindle mass must be > 0 kg, got {self.mass!r}")
        if not (math.isfinite(self.spindle_hz) and self.spindle_hz > 0):
            raise ModelError(f"spindle frequency must be > 0 Hz, got {self.spindle_hz!r}")


@dataclass(frozen=True)
class BuiltArm:
    """A generated bench robot.

    Attributes
    ----------
    xml : str
        The MJCF text (without tool; the dummy tool is its default).
    arm : UrdfArm
    grid : WorkspaceGrid
    stiffness, damping, armature : ndarray, shape (n_arm,)
        Joint values, N m/rad, N m s/rad, kg m².
    f_low : ndarray
        Exact natural frequencies in the low band at the grid's centre, Hz.
    f_high : ndarray
        Exact spindle-mode frequencies at the grid's centre, Hz.
    bands : tuple of float
        (low min, low max, high min, high max), Hz.
    """

    xml: str
    arm: UrdfArm
    grid: WorkspaceGrid
    stiffness: np.ndarray
    damping: np.ndarray
    armature: np.ndarray
    f_low: np.ndarray
    f_high: np.ndarray
    bands: tuple[float, float, float, float]
    rule: FlexRule = field(default_factory=FlexRule)
    spindle: SpindleRule = field(default_factory=SpindleRule)


def build_arm(source: str | Path, *, rule: FlexRule = FlexRule(), spindle: SpindleRule = SpindleRule(),
              flange: str | None = None, name: str | None = None, progress=None) -> BuiltArm:
    """Turn an example-robot-data name or a URDF path into a bench robot.

    Parameters
    ----------
    source : str or Path
        ``"ur10"``, ``"panda"`` … or a URDF file.
    rule, spindle : FlexRule, SpindleRule
    flange : str, optional
        The flange link (see :func:`rmbench.robot.urdf.read_urdf`).
    name : str, optional
        Model name; the robot's name by default.
    progress : callable, optional
        Called with a short message at each step.
    """
    say = progress or (lambda msg: None)
    path, robot_name = find_urdf(source)
    arm = read_urdf(path, robot_name, flange=flange)
    name = name or robot_name
    src = urdf_spec(arm)
    n = len(arm.joints)
    m_spindle = spindle.mass if spindle.mass is not None else 0.10 * arm.mass
    # placeholders of the right order of magnitude until the grid's centre gives the rule its inertia
    k = np.full(n, 1e4)
    armature = np.full(n, 0.1)
    bearing = 1.0
    say(f"{arm.name}: {n} axes {', '.join(arm.joints)}; flange {arm.flange}; spindle {m_spindle:.2f} kg")
    spec = _flexify(src, arm, name, k, 0.05 * k, armature, rule)
    add_spindle(spec, arm.flange, m_spindle, bearing_scale=bearing, mount=spindle.mount)
    _metadata(spec, arm, None, (4.0, 40.0, 600.0, 1400.0))
    say("searching the workspace for a posture grid")
    grid = find_workspace_grid(_with_tool(spec, name, grid=None))
    robot = _with_tool(spec, name, grid)
    q_ref = robot.ik(_centre(grid)).q
    m_ff = _link_mass_matrix(robot, q_ref)
    diag = np.diag(m_ff)
    targets = rule.f_low * rule.spread ** (np.arange(n) / max(n - 1, 1))
    k = assign_frequencies(m_ff, targets)
    c = 2 * rule.zeta * np.sqrt(k * diag)
    armature = rule.armature_ratio * diag
    say("tuning joint stiffness and spindle bearings")
    for _ in range(4):
        spec = _flexify(src, arm, name, k, c, armature, rule)
        add_spindle(spec, arm.flange, m_spindle, bearing_scale=bearing, mount=spindle.mount)
        _metadata(spec, arm, grid, (4.0, 40.0, 600.0, 1400.0))
        f_low, f_sp = _natural_frequencies(_with_tool(spec, name, grid), grid)
        if not len(f_sp):
            raise ModelError("no spindle mode found; the spindle rule is out of range")
        ratio = spindle.spindle_hz / f_sp[0]
        if abs(ratio - 1) < 1e-3:
            break
        bearing *= ratio ** 2   # the bearings' modes scale with √k: the arm barely takes part
    else:
        raise ModelError(f"the spindle's lowest mode does not settle at {spindle.spindle_hz:g} Hz")
    bands = (min(4.0, 0.5 * f_low[0]), max(40.0, 1.3 * f_low[-1]), min(600.0, 0.8 * f_sp[0]),
             max(1400.0, 1.2 * f_sp[min(1, len(f_sp) - 1)]))
    spec = _flexify(src, arm, name, k, c, armature, rule)
    add_spindle(spec, arm.flange, m_spindle, bearing_scale=bearing, mount=spindle.mount)
    _metadata(spec, arm, grid, bands)
    xml = _with_header(spec_to_xml(spec), arm, rule, spindle, m_spindle, grid, k, f_low, f_sp)
    return BuiltArm(xml=xml, arm=arm, grid=grid, stiffness=k, damping=c, armature=armature, f_low=f_low,
                    f_high=f_sp[:4], bands=bands, rule=rule, spindle=spindle)


def campaign_toml(built: BuiltArm, mjcf: str | Path) -> str:
    """A starter campaign on the built robot's own grid, its bands and hammer forces scaled to it.

    The hammer's peak force is the milling robot's (300 N low band, 400 N high band) times the ratio
    of that robot's largest direct receptance in the band to this one's, so the responses stay
    within the sensors' ranges as they do on the stand-in; the low band's pulse is short enough to
    excite the band's top (a half-sine of T ms has its first spectral zero at 1.5/T kHz).
    """
    from rmbench.robot.model import Robot

    lo0, lo1, hi0, hi1 = built.bands
    ref = Robot.load("irb6660", tool="dummy")
    ref_op = ref.at(ref.validation()[0])
    op = _with_tool(mujoco.MjSpec.from_string(built.xml), built.arm.name, built.grid).at(_centre(built.grid))

    def peak(o, f0, f1):
        h = o.frf(np.linspace(f0, f1, 2000))
        return float(np.abs(h[:, [0, 1], [0, 1]]).max())

    force_low = 300.0 * peak(ref_op, 4.0, 40.0) / peak(op, lo0, lo1)
    force_high = 400.0 * peak(ref_op, 600.0, 1400.0) / peak(op, hi0, hi1)
    rate_low = max(1024.0, 2.0 ** math.ceil(math.log2(2.56 * lo1)))
    pulse_low = min(8.0, 600.0 / lo1)
    return f"""# Impact campaign on {built.arm.name}'s own posture grid, written by `rmbench model build`.
# Run it with: rmbench campaign run THIS.toml --out DATA.nc   (units as in the bundled configs)
name = "{built.arm.name}"
seed = 0
method = "time"

[robot]
name = "{Path(mjcf).as_posix()}"
tool = "dummy"

[grid]
kind = "robot"          # the robot's 4 x 4 x 7 grid; "validation" for its three validation postures

[hits]
points = ["1X", "1Y", "1aX", "1aY"]
averages = 3

[bands.low]
f_min = {lo0:.4g}
f_max = {lo1:.4g}
sensor = "laser"
s_1a_mm = 33.4
sample_rate = {rate_low:g}
line_spacing = 0.125
[bands.low.hammer]
pulse_ms = {pulse_low:.3g}
peak_n = {force_low:.3g}

[bands.high]
f_min = {hi0:.4g}
f_max = {hi1:.4g}
sensor = "accelerometer"
s_1a_mm = 20.0
sample_rate = 12800.0
line_spacing = 2.0
[bands.high.hammer]
pulse_ms = 0.6
peak_n = {force_high:.3g}
"""


def _centre(grid: WorkspaceGrid) -> Posture:
    return Posture(float(np.mean(grid.x)), float(np.mean(grid.y)), 0.0)


def _with_tool(spec: mujoco.MjSpec, name: str, grid):
    """A Robot of the spec with the dummy tool (and the grid's table height and IK seed)."""
    from rmbench.robot.model import Robot

    s = mujoco.MjSpec.from_string(spec_to_xml(spec))
    graft_tool(s, load_spec(resolve_tool("dummy")))
    robot = Robot(spec_to_xml(s), name=name, tool="dummy", spec=s)
    if grid is not None:
        robot.table_z, robot.ik_seed = grid.table_z, grid.ik_seed
    return robot


def _link_mass_matrix(robot, q_ref):
    """Mass matrix of the flexible joints (link side, motors locked) at the command ``q_ref``."""
    m, d = robot.model, mujoco.MjData(robot.model)
    for jn, q in zip(robot.arm_joints, q_ref):
        d.qpos[m.joint(jn).qposadr[0]] = q
    mujoco.mj_forward(m, d)
    full = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, full)
    dofs = np.array([m.joint(j + "_flex").dofadr[0] for j in robot.arm_joints])
    return full[np.ix_(dofs, dofs)]


def assign_frequencies(m: np.ndarray, f_target: np.ndarray) -> np.ndarray:
    """Diagonal stiffness K (N m/rad) whose eigenfrequencies with the mass matrix ``m`` are ``f_target``,
    or the closest reachable.

    The inverse eigenvalue problem in least squares on ln(f / f_target) over ln k (a diagonal K has n
    values for n frequencies, but an arm's coupling can put a spectrum out of reach: two joint axes
    nearly in line share one inertia, and their two modes cannot both be low). The result is then
    scaled so that the lowest frequency is exactly ``f_target[0]``.

    Parameters
    ----------
    m : ndarray, shape (n, n)
        Link-side mass matrix, kg m².
    f_target : ndarray, shape (n,)
        Frequencies in ascending order, Hz.
    """
    from scipy.linalg import eigh
    from scipy.optimize import least_squares

    lam_t = (2 * np.pi * np.asarray(f_target, float)) ** 2

    def residual(u):
        return 0.5 * np.log(eigh(np.diag(np.exp(u)), m, eigvals_only=True) / lam_t)

    # start: each joint alone at its target
    fit = least_squares(residual, np.log(np.diag(m) * lam_t), xtol=1e-13, ftol=1e-13, gtol=1e-13)
    k = np.exp(fit.x)
    return k * lam_t[0] / eigh(np.diag(k), m, eigvals_only=True)[0]


def _natural_frequencies(robot, grid) -> tuple[np.ndarray, np.ndarray]:
    """Undamped natural frequencies (Hz) of the arm's and of the spindle's modes at the grid's centre.

    A mode is the arm's where most of its kinetic energy is in the flexible joints, the spindle's
    where most is in the bearings (the servo-held rotors and the spindle drive have their own modes).
    """
    from scipy.linalg import eigh

    lin = robot.at(_centre(grid)).linear
    w2, v = eigh(lin.K, lin.M)
    share = v * (lin.M @ v)            # kinetic-energy share of each dof in each mass-normalised mode
    names = np.array(lin.dof_names).astype(str)
    flex = np.char.endswith(names, "_flex")
    bearing = np.isin(names, ["spindle_x", "spindle_y", "spindle_rx", "spindle_ry"])
    f = np.sqrt(np.clip(w2, 0, None)) / (2 * np.pi)
    return f[share[flex].sum(0) > 0.5], f[share[bearing].sum(0) > 0.5]


def _flexify(src: mujoco.MjSpec, arm: UrdfArm, name: str, k, c, armature, rule: FlexRule) -> mujoco.MjSpec:
    """A new spec: the URDF's bodies, each arm joint split into motor and link hinges."""
    out = mujoco.MjSpec()
    out.modelname = name
    out.compiler.degree = False   # a fresh MjSpec counts angles in degrees
    out.compiler.autolimits = True
    out.option.timestep = 1e-5
    out.option.integrator = mujoco.mjtIntegrator.mjINT_RK4
    out.option.gravity = [0.0, 0.0, -9.81]
    out.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    index = {jn: i for i, jn in enumerate(arm.joints)}

    def inertial(body, s):
        body.explicitinertial = True
        body.mass = max(s.mass, 0.0)
        body.ipos = s.ipos   # assigned always: the writer drops <inertial> otherwise
        body.iquat = s.iquat
        if s.fullinertia is not None and not np.isnan(s.fullinertia[0]):
            body.fullinertia = s.fullinertia
        else:
            body.inertia = s.inertia

    def walk(s, parent):
        mine = [j for j in s.joints if j.name in index]
        other = [j for j in s.joints if j.name not in index and j.name not in arm.frozen]
        if other:
            raise ModelError(f"URDF link {s.name!r}: joint {other[0].name!r} is neither on the arm nor frozen")
        if mine:
            j = mine[0]
            i = index[j.name]
            if j.type != HINGE or np.any(np.abs(j.pos) > 0):
                raise ModelError(f"URDF joint {j.name!r}: only revolute joints at the link origin are supported")
            lim = np.array(j.range) if j.range[1] > j.range[0] else np.array([-2 * np.pi, 2 * np.pi])
            motor = parent.add_body(name=f"motor{i + 1}", pos=s.pos, quat=s.quat)
            motor.explicitinertial = True
            motor.mass, motor.ipos, motor.iquat, motor.inertia = _TINY, [0, 0, 0], [1, 0, 0, 0], [_TINY] * 3
            motor.add_joint(name=f"j{i + 1}", type=HINGE, axis=j.axis, range=lim, armature=float(armature[i]))
            body = motor.add_body(name=s.name)
            body.add_joint(name=f"j{i + 1}_flex", type=HINGE, axis=j.axis, stiffness=float(k[i]),
                           damping=float(c[i]))
        else:
            body = parent.add_body(name=s.name, pos=s.pos, quat=s.quat)
        if s.mass > 0:
            inertial(body, s)
        for g in s.geoms:
            if g.type != mujoco.mjtGeom.mjGEOM_MESH:
                body.add_geom(type=g.type, size=g.size, pos=g.pos, quat=g.quat, contype=0, conaffinity=0,
                              group=1, mass=0, density=0)
        for child in s.bodies:
            walk(child, body)

    for child in src.worldbody.bodies:
        walk(child, out.worldbody)
    for i, jn in enumerate(arm.joints):
        a = out.add_actuator(name=f"a{i + 1}", target=f"j{i + 1}", trntype=mujoco.mjtTrn.mjTRN_JOINT)
        kp = rule.servo_ratio * float(k[i])
        a.set_to_position(kp=kp, kv=2 * rule.servo_zeta * math.sqrt(kp * float(armature[i])))
        a.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE
    _link_visuals(out, arm)
    return out


def _link_visuals(spec: mujoco.MjSpec, arm: UrdfArm) -> None:
    """Capsules from each link body to its children, so the arm can be seen (meshes are dropped)."""
    for body in spec.bodies:
        if body.name.startswith(("motor", "spindle", "world")) or not body.name:
            continue
        for child in body.bodies:
            tip = np.array(child.pos)
            if np.linalg.norm(tip) > 0.02:
                body.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[0, 0, 0, *tip], size=[0.025, 0, 0],
                              contype=0, conaffinity=0, group=1, mass=0, density=0, rgba=[0.6, 0.6, 0.65, 1])


def add_spindle(spec: mujoco.MjSpec, flange: str, mass: float, *, bearing_scale: float = 1.0,
                mount: str = "inline") -> None:
    """Mount an electro-spindle of ``mass`` kg on the body ``flange`` (its +z out of the flange face).

    The milling robot's spindle (9 kg rotor, 1 kg spinning part, bearings with radial and tilt
    compliance whose principal axes turn 30° about the tool axis) scaled: masses by ``mass`` (70 %
    housing, 30 % rotor), lengths by the cube root of the rotor mass ratio, bearing stiffness by
    ``bearing_scale`` on top of the mass scaling. ``mount="inline"`` (default) puts the tool on
    the last axis; ``"bracket"`` holds it perpendicular to that axis, offset from it, as the
    milling robot's bracket does, so that the redundant angle θ moves the whole wrist. Adds the sites ``flange_face`` and ``tool_mount``, the body ``spindle_housing``, the
    joints ``spindle_x``, ``spindle_y``, ``spindle_rx``, ``spindle_ry``, ``spindle_spin`` and the
    spindle drive ``a_spin`` (the names the gap diagnosis looks for).
    """
    if mount not in ("bracket", "inline"):
        raise ModelError(f"spindle mount must be 'bracket' or 'inline', got {mount!r}")
    flange = spec.body(flange)
    m_rotor = 0.3 * mass
    r = m_rotor / 10.0                    # rotor mass ratio to the milling robot's (9 + 1 kg)
    s = r ** (1 / 3)                      # length scale
    length = 0.38 * s
    m_house = 0.7 * mass
    radius = 0.085 * s
    flange.add_site(name="flange_face", pos=[0, 0, 0], size=[0.005, 0, 0])
    if mount == "inline":   # housing from the flange face along its axis
        house = flange.add_body(name="spindle_housing", pos=[0, 0, length / 2])
    else:                   # spindle axis along the flange's +x, crossing its axis 1.2 radii out
        half = math.sqrt(0.5)
        house = flange.add_body(name="spindle_housing", pos=[0, 0, 1.2 * radius], quat=[half, 0, half, 0])
        flange.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, pos=[0, 0, 0.6 * radius], size=[radius, radius, 0.6 * radius],
                        contype=0, conaffinity=0, group=1, mass=0, density=0, rgba=[0.5, 0.5, 0.5, 1])
    house.explicitinertial = True
    house.mass, house.ipos, house.iquat = m_house, [0, 0, 0], [1, 0, 0, 0]
    i_lat = m_house * (3 * radius ** 2 + length ** 2) / 12
    house.inertia = [i_lat, i_lat, m_house * radius ** 2 / 2]
    house.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, fromto=[0, 0, -length / 2, 0, 0, length / 2],
                   size=[radius, 0, 0], contype=0, conaffinity=0, group=1, mass=0, density=0,
                   rgba=[0.75, 0.75, 0.8, 1])
    # rotor frame: z back into the spindle (the tool hangs along -z), turned 30° about it
    flip = np.array([0.0, 1.0, 0.0, 0.0])
    turn = np.array([math.cos(math.radians(15)), 0, 0, math.sin(math.radians(15))])
    quat = np.zeros(4)
    mujoco.mju_mulQuat(quat, flip, turn)
    rotor = house.add_body(name="spindle_rotor", pos=[0, 0, length / 2], quat=quat)
    bearing = [0, 0, 0.05 * s]
    m_r, i_r = 0.9 * m_rotor, np.array([0.07, 0.07, 0.004]) / 9 * 0.9 * m_rotor * s ** 2
    # stiffness of the milling robot's bearings, scaled to keep their frequencies with the mass
    k_t = np.array([3.0e8, 2.57e8]) * r * bearing_scale
    k_r = np.array([2.72e6, 2.85e6]) * r * s ** 2 * bearing_scale
    m_eff = m_rotor + 0.45                # with the dummy tool (0.45 kg)
    c_t = 2 * 0.035 * np.sqrt(k_t * m_eff)
    c_r = 2 * 0.02 * np.sqrt(k_r * (i_r[0] + m_eff * (0.1 * s) ** 2))
    for jn, kind, axis, kk, cc in (("spindle_x", SLIDE, [1, 0, 0], k_t[0], c_t[0]),
                                   ("spindle_y", SLIDE, [0, 1, 0], k_t[1], c_t[1]),
                                   ("spindle_rx", HINGE, [1, 0, 0], k_r[0], c_r[0]),
                                   ("spindle_ry", HINGE, [0, 1, 0], k_r[1], c_r[1])):
        rotor.add_joint(name=jn, type=kind, axis=axis, pos=bearing, stiffness=float(kk), damping=float(cc))
    rotor.explicitinertial = True
    rotor.mass, rotor.ipos, rotor.iquat, rotor.inertia = m_r, [0, 0, 0.06 * s], [1, 0, 0, 0], i_r
    rotor.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, fromto=[0, 0, 0.3 * s, 0, 0, -0.05 * s],
                   size=[0.03 * s, 0, 0], contype=0, conaffinity=0, group=1, mass=0, density=0)
    rotor.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, fromto=[0, 0, -0.05 * s, 0, 0, -0.13 * s],
                   size=[0.025 * s, 0, 0], contype=0, conaffinity=0, group=1, mass=0, density=0)
    back = np.array([math.cos(math.radians(15)), 0, 0, -math.sin(math.radians(15))])
    rotor.add_site(name="tool_mount", pos=[0, 0, -0.13 * s], quat=back, size=[0.004, 0, 0])
    spin = rotor.add_body(name="spindle_spin", pos=[0, 0, 0.10 * s])
    spin.add_joint(name="spindle_spin", type=HINGE, axis=[0, 0, 1])
    m_spin = 0.1 * m_rotor
    i_spin = np.array([0.004, 0.004, 0.006]) * m_spin * s ** 2
    spin.explicitinertial = True
    spin.mass, spin.ipos, spin.iquat, spin.inertia = m_spin, [0, 0, 0], [1, 0, 0, 0], i_spin
    # the spindle drive in position (C-axis) mode, as on the milling robot, gains scaled with the inertia
    a = spec.add_actuator(name="a_spin", target="spindle_spin", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    a.set_to_position(kp=2.1e4 * i_spin[2] / 0.006, kv=16 * i_spin[2] / 0.006)
    a.ctrllimited = mujoco.mjtLimited.mjLIMITED_FALSE


def _metadata(spec: mujoco.MjSpec, arm: UrdfArm, grid: WorkspaceGrid | None, bands) -> None:
    """rmbench's custom fields: arm joints, tool, table, IK seed, bands, grid."""
    n = len(arm.joints)
    spec.add_text(name="rmbench_arm_joints", data=" ".join(f"j{i + 1}" for i in range(n)))
    spec.add_text(name="rmbench_urdf_joints", data=" ".join(arm.joints))
    spec.add_text(name="rmbench_default_tool", data="dummy")
    spec.add_text(name="rmbench_tcp", data="tool_tip")
    spec.add_numeric(name="rmbench_bands", data=[float(b) for b in bands])
    spec.add_numeric(name="rmbench_s_1a", data=[0.0334, 0.020])
    if grid is None:
        spec.add_numeric(name="rmbench_table_z", data=[0.0])
        spec.add_numeric(name="rmbench_ik_seed", data=[0.0] * n)
        return
    spec.add_numeric(name="rmbench_table_z", data=[grid.table_z])
    spec.add_numeric(name="rmbench_ik_seed", data=[float(v) for v in grid.ik_seed])
    spec.add_numeric(name="rmbench_grid_x_mm", data=[1000 * float(v) for v in grid.x])
    spec.add_numeric(name="rmbench_grid_y_mm", data=[1000 * float(v) for v in grid.y])
    spec.add_numeric(name="rmbench_grid_theta_deg", data=[math.degrees(float(v)) for v in grid.theta])
    spec.add_numeric(name="rmbench_validation", data=[v for p in grid.validation for v in p.as_mm_deg()])


def _with_header(xml: str, arm: UrdfArm, rule: FlexRule, spindle: SpindleRule, m_spindle: float,
                 grid: WorkspaceGrid, k, f_low, f_sp) -> str:
    """The MJCF text with a comment naming the source URDF and the stiffness rule."""
    from rmbench._version import __version__

    joints = ", ".join(f"j{i + 1} = {jn}" for i, jn in enumerate(arm.joints))
    stiff = ", ".join(f"{v:.4g}" for v in k)
    xs, ys = (f"{1000 * grid.x[0]:.0f} to {1000 * grid.x[-1]:.0f}", f"{1000 * grid.y[0]:.0f} to {1000 * grid.y[-1]:.0f}")
    body = f"""  rmbench bench robot generated by `rmbench model build` (rmbench {__version__}) from the URDF
    {arm.path.name} ({arm.name}); kinematics and inertias as in the URDF (MuJoCo's URDF import,
    meshes dropped), flange link {arm.flange}. Frozen (held at zero): {', '.join(arm.frozen) or 'none'}.
  Axes: {joints}. Each is a flexible joint: motor body motorN with hinge jN (rotor armature),
  held by the position servo aN; the URDF link with hinge jN_flex (spring and damper).
  Stiffness rule (rmbench.robot.flexible_arm.FlexRule): at the grid's centre, with M the link-side
    mass matrix (motors locked), the diagonal K whose eigenfrequencies with M are log-spaced from
    {rule.f_low:g} to {rule.f_low * rule.spread:g} Hz (or the closest reachable, least squares in
    log-frequency, lowest at {rule.f_low:g} Hz); c_i = 2 {rule.zeta:g} sqrt(k_i M_ii);
    armature {rule.armature_ratio:g} M_ii; servo kp = {rule.servo_ratio:g} k_i, kv = 2 {rule.servo_zeta:g} sqrt(kp armature).
    k = [{stiff}] N m/rad.
  Spindle: {m_spindle:.3g} kg electro-spindle, {spindle.mount} mount (rmbench.robot.flexible_arm.add_spindle), bearings
    tuned so the lowest spindle mode with the dummy tool is {spindle.spindle_hz:g} Hz.
  Exact natural frequencies at the grid's centre: {', '.join(f'{v:.1f}' for v in f_low)} Hz (arm),
    {', '.join(f'{v:.0f}' for v in f_sp[:4])} Hz (spindle).
  Posture grid (rmbench.robot.workspace): table z = {1000 * grid.table_z:.0f} mm, x {xs} mm, y {ys} mm,
    theta {np.degrees(grid.theta[0]):.0f}..{np.degrees(grid.theta[-1]):.0f} deg; worst joint-limit margin
    {np.degrees(grid.worst_margin):.1f} deg, worst sigma_min {grid.worst_sigma:.3f}.
"""
    comment = "  <!--\n" + re.sub(r"-{2,}", "-", body) + "  -->\n"   # '--' may not appear in a comment
    head, rest = xml.split("\n", 1)
    return head + "\n" + comment + rest
