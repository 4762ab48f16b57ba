"""Specification of the parameter kinds' registry (:mod:`rmbench.robot.kinds`): it covers every
parameter a set holds, each kind writes a compiled model and a specification alike, a fast kind's
matrix perturbation is the re-linearised model's change, and the model-form kinds (a bearing's
tilt, a link's bending, a counterbalance, a resonator) leave the model as it was at their nominal
and change it as their physics says when asked."""

import copy

import mujoco
import numpy as np
import pytest

from rmbench.calibrate.model import FAST_KINDS
from rmbench.errors import InputError
from rmbench.robot import Posture
from rmbench.robot.kinds import KINDS
from rmbench.robot.linear import linearize
from rmbench.robot.parameters import GROUPS, Parameter, ParameterSet, parameter_set, parse_groups

POSTURE = Posture.from_mm_deg(1800, -200, 0)      # the irb_op fixture's
TILT = "j2_flex.tilt_compliance"
BEND = "lower_arm.bending_compliance"
RING = ("upper_arm.resonator_mass", "upper_arm.resonance")
# every group, and a parameter of each structural form: a compliance, a stiffness, a bearing tilt,
# a link's bending, a body mass, a resonator's package and tuning
EVERY = ("base.lateral_compliance", "spindle.radial", "motor2.mass", TILT, BEND) + RING
_FIELDS = ("jnt_stiffness", "dof_damping", "actuator_gainprm", "actuator_biasprm", "body_mass", "body_inertia",
           "body_ipos", "tendon_stiffness", "tendon_lengthspring", "site_pos")


@pytest.fixture(scope="module")
def every(irb):
    return parameter_set(irb, GROUPS + ("counterbalance",), extra=EVERY)


@pytest.fixture(scope="module")
def tilted(irb):
    """The robot with its J2 bearing's tilt hinges (rigid), the tilt compliance last in the set."""
    return parameter_set(irb, ("joints",), extra=(TILT,))


def _with(robot, params, u):
    """``robot`` (a shallow copy) with the values at ``u`` written into a copy of its model."""
    model = copy.copy(robot.model)
    params.apply_model(model, u)
    shell = copy.copy(robot)
    shell.model = model
    return shell


def _draw(params, seed=0) -> np.ndarray:
    """Values inside the prior ranges, none at the nominal (a compliance's range starts at rigid)."""
    rng = np.random.default_rng(seed)
    return rng.uniform(0.2, 0.8, len(params)) * (params.upper() - params.lower()) + params.lower()


def test_registry_covers_every_kind_of_a_set(every):
    _, params = every
    assert {p.kind for p in params} == set(KINDS)
    assert all(name == kind.name for name, kind in KINDS.items())


def test_fast_kinds_are_those_that_leave_the_equilibrium():
    # a mass or a centre of mass moves the equilibrium and the gravity stiffness, a counterbalance
    # spring pushes the arm and acts through its posture's geometry, a package's weight sags its
    # springs: no C, K shortcut
    assert set(FAST_KINDS) == set(KINDS) - {"mass", "com", "spring", "foot", "head", "preload", "resonator"}


def test_parameter_of_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="unknown parameter kind 'spring_rate' of a.b"):
        Parameter("a.b", "joints", "spring_rate", ("a",), 0, 1.0, True, 1.0, -1.0, 1.0, "N·m/rad")


@pytest.mark.parametrize("kind", sorted(KINDS), ids=sorted(KINDS))
def test_spec_writes_the_model_the_model_writer_gives(every, kind):
    robot, params = every
    own = ParameterSet([p for p in params if p.kind == kind])
    u = _draw(own)
    model = _with(robot, own, u).model
    spec = robot.spec
    own.apply_spec(spec, u)
    compiled = spec.compile()
    for field in _FIELDS:
        np.testing.assert_allclose(getattr(compiled, field), getattr(model, field), rtol=1e-12, atol=1e-12,
                                   err_msg=field)


@pytest.mark.parametrize("kind", FAST_KINDS, ids=FAST_KINDS)
def test_matrix_perturbation_is_the_relinearised_change(every, kind):
    robot, params = every
    u0 = _draw(params, seed=1)
    op = _with(robot, params, u0).at(robot.ik(POSTURE).q)
    lin = op.linear
    dofs = list(lin.dof_names)
    for i, p in enumerate(params):
        if p.kind != kind:
            continue
        u1 = u0.copy()
        u1[i] += 0.2 if p.log else 30.0
        C, K = lin.C.copy(), lin.K.copy()
        KINDS[kind].perturb(op.robot.model, dofs, p, u0[i], u1[i], C, K)
        # the same settled state, linearised again with the new value
        model = _with(robot, params, u1).model
        data = mujoco.MjData(model)
        data.qpos[:], data.qvel[:], data.ctrl[:] = op.data.qpos, op.data.qvel, op.data.ctrl
        again = linearize(model, data)
        change = max(np.abs(again.K - lin.K).max(), np.abs(again.C - lin.C).max())
        assert change > 0, p.name
        # entrywise 1e-8 relative; entries the change leaves (zero included) to the differences' rounding
        np.testing.assert_allclose(K, again.K, rtol=1e-8, atol=1e-8 * change, err_msg=f"{p.name} K")
        np.testing.assert_allclose(C, again.C, rtol=1e-8, atol=1e-8 * change, err_msg=f"{p.name} C")


def test_rigid_bearing_tilt_leaves_the_modes(irb_op, tilted):
    robot, params = tilted
    assert params.params[-1].nominal == 0.0 and robot.model.njnt == irb_op.robot.model.njnt + 2
    nominal = irb_op.linear.modes()
    modes = robot.at(POSTURE).linear.modes()
    n = len(nominal.f_n)        # the two hinges' own modes are far above every other
    np.testing.assert_allclose(modes.f_n[:n], nominal.f_n, rtol=1e-6)
    np.testing.assert_allclose(modes.zeta[:n], nominal.zeta, rtol=1e-6)


def test_soft_bearing_tilt_lowers_the_lowest_modes(irb_op, tilted):
    robot, params = tilted
    u = np.zeros(len(params))
    u[-1] = 50.0        # µrad/(kN·m)
    soft = _with(robot, params, u).at(irb_op.q_cmd).linear.modes().f_n[:6]
    rigid = irb_op.linear.modes().f_n[:6]
    # freeing a constraint lowers every natural frequency (Rayleigh): the tilt is a spring in series
    # with the arm's bending across J2's axis, which the gearbox does not see; the side sway of the
    # whole arm, the lowest such mode, loses several per cent
    assert np.all(soft <= rigid * (1 + 1e-6))
    assert np.min(soft / rigid) < 0.98


def test_tilt_group_is_named_and_not_in_all(irb):
    assert "tilt" not in parse_groups("all") and parse_groups("all") == GROUPS
    _, params = parameter_set(irb, parse_groups("joints,tilt"))
    tilts = [p.name for p in params if p.kind == "tilt"]
    assert tilts == [f"j{i}_flex.tilt_compliance" for i in range(1, 7)]


def test_tilt_of_a_missing_joint_is_refused(irb):
    with pytest.raises(InputError, match="no hinge joint 'j9_flex' for j9_flex.tilt_compliance"):
        parameter_set(irb, ("joints",), extra=("j9_flex.tilt_compliance",))


@pytest.fixture(scope="module")
def bent(irb):
    """The robot with its bending links split at mid-length (rigid), the bending group alone."""
    return parameter_set(irb, ("bending",))


def test_bending_group_names_the_long_links_after_the_first_axis(irb, bent):
    # the carousel (a column on the first axis) tilts in its bearing; the lower arm (0.7 m) and the
    # forearm (0.89 m) bend; the upper arm's 0.28 m is a joint's neighbourhood
    assert "bending" not in parse_groups("all")
    assert bent[1].names == ("lower_arm.bending_compliance", "forearm.bending_compliance")


def test_splitting_a_link_keeps_its_mass_its_centre_and_its_inertia(irb, bent):
    robot, _ = bent
    before, after = mujoco.MjData(irb.model), mujoco.MjData(robot.model)
    mujoco.mj_forward(irb.model, before)
    mujoco.mj_forward(robot.model, after)
    for link in ("lower_arm", "forearm"):
        parts = [robot.model.body(n).id for n in (link, f"{link}_distal")]
        whole = irb.model.body(link).id
        assert sum(robot.model.body_mass[parts]) == pytest.approx(irb.model.body_mass[whole], rel=1e-12)
        centre = sum(robot.model.body_mass[i] * after.xipos[i] for i in parts) / irb.model.body_mass[whole]
        np.testing.assert_allclose(centre, before.xipos[whole], atol=1e-12)
        np.testing.assert_allclose(_inertia_about(robot.model, after, parts, centre),
                                   _inertia_about(irb.model, before, [whole], centre), atol=1e-9)
    # and everything after the split is where it was
    np.testing.assert_allclose(after.site_xpos, before.site_xpos, atol=1e-12)


def _inertia_about(model, data, bodies, point) -> np.ndarray:
    """Inertia tensor of ``bodies`` about ``point`` in the world frame (kg·m²)."""
    out = np.zeros((3, 3))
    for i in bodies:
        rot = data.ximat[i].reshape(3, 3)
        r = data.xipos[i] - point
        out += rot @ np.diag(model.body_inertia[i]) @ rot.T + model.body_mass[i] * (r @ r * np.eye(3) - np.outer(r, r))
    return out


def test_rigid_bending_leaves_the_modes(irb_op, bent):
    robot, _ = bent
    nominal = irb_op.linear.modes()
    modes = robot.at(POSTURE).linear.modes()
    n = len(nominal.f_n)        # the hinges' own modes are far above every other
    np.testing.assert_allclose(modes.f_n[:n], nominal.f_n, rtol=1e-6)


def test_a_bending_lower_arm_lowers_the_lowest_modes(irb_op, bent):
    robot, params = bent
    u = np.zeros(len(params))
    u[0] = 400.0        # µrad/(kN·m): a 0.7 m tube of EI 1.7 MN·m² turns its end by 410
    soft = _with(robot, params, u).at(irb_op.q_cmd).linear.modes().f_n[:6]
    rigid = irb_op.linear.modes().f_n[:6]
    # a spring in series with the gearboxes (Rayleigh): no mode rises, the arm's pitch falls most
    assert np.all(soft <= rigid * (1 + 1e-6))
    assert np.min(soft / rigid) < 0.95


@pytest.fixture(scope="module")
def balanced(irb):
    return parameter_set(irb, ("counterbalance",))


def test_an_absent_counterbalance_leaves_the_modes(irb_op, balanced):
    robot, params = balanced
    assert params.names == ("counterbalance.stiffness", "counterbalance.foot_angle", "counterbalance.head",
                            "counterbalance.preload")
    np.testing.assert_allclose(robot.at(POSTURE).linear.modes().f_n, irb_op.linear.modes().f_n, rtol=1e-9)


def test_a_counterbalance_moves_the_low_modes_by_posture(irb, balanced):
    # the spring's lever about J2, and the stiffness its preload adds through the geometry (negative
    # where the spring is compressed across its line), change with J2's angle: the low modes move
    # differently with the arm near and reaching far
    robot, params = balanced
    near, far = Posture.from_mm_deg(1300, 0, 0), Posture.from_mm_deg(2100, 0, 0)
    rise = []
    for posture in (near, far):
        stiff = _with(robot, params, np.array([50.0, 0.0, 0.0, 5.0])).at(robot.ik(posture).q).linear.modes().f_n[:4]
        free = robot.at(posture).linear.modes().f_n[:4]
        rise.append(np.max(np.abs(stiff / free - 1)))
    assert min(rise) > 0.002 and abs(rise[0] - rise[1]) > 0.2 * max(rise)


@pytest.fixture(scope="module")
def ringing(irb):
    return parameter_set(irb, ("joints",), extra=RING)


def test_an_absent_resonator_leaves_the_modes(irb_op, ringing):
    robot, _ = ringing
    n = len(irb_op.linear.modes().f_n)      # the absent package's own modes ring at 100 kHz
    np.testing.assert_allclose(robot.at(POSTURE).linear.modes().f_n[:n], irb_op.linear.modes().f_n, rtol=1e-6)


def test_a_package_on_springs_rings_at_its_tuning(irb_op, ringing):
    # a 10 kg package tuned to 15 Hz on the upper arm: a new mode near 15 Hz (the arm moves with it
    # and shifts it by a few per cent, the 13-17 Hz range), and none of the robot's modes rises
    robot, params = ringing
    u = np.zeros(len(params))
    u[-2], u[-1] = params.params[-2].to_u(10.0), params.params[-1].to_u(15.0)
    f = _with(robot, params, u).at(irb_op.q_cmd).modes("low").f_n
    rigid = irb_op.modes("low").f_n
    assert len(f) == len(rigid) + 1
    assert np.any(np.abs(f / 15.0 - 1) < 0.13)
    assert params.params[-2].value(u[-2]) == pytest.approx(10.0) and params.params[-1].value(u[-1]) == pytest.approx(15.0)
