"""Specification of the parameter kinds' registry (:mod:`rmbench.robot.kinds`): it covers every
parameter a set holds, each kind writes a compiled model and a specification alike, a fast kind's
matrix perturbation is the re-linearised model's change, and the bearing tilt kind is rigid at its
nominal and soft when asked."""

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
# every group, and a parameter of each structural form: a compliance, a stiffness, a bearing tilt,
# a body mass
EVERY = ("base.lateral_compliance", "spindle.radial", "motor2.mass", TILT)
_FIELDS = ("jnt_stiffness", "dof_damping", "actuator_gainprm", "actuator_biasprm", "body_mass", "body_inertia",
           "body_ipos")


@pytest.fixture(scope="module")
def every(irb):
    return parameter_set(irb, "all", extra=EVERY)


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
    # a mass or a centre of mass moves the equilibrium and the gravity stiffness: no C, K shortcut
    assert set(FAST_KINDS) == set(KINDS) - {"mass", "com"}


def test_parameter_of_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="unknown parameter kind 'spring' of a.b"):
        Parameter("a.b", "joints", "spring", ("a",), 0, 1.0, True, 1.0, -1.0, 1.0, "N·m/rad")


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
