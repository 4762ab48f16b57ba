"""Campaigns commanded by a nominal robot's inverse kinematics (``[robot] commands_from``)."""

import mujoco
import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.impact import open_campaign, parse_config, run_campaign
from rmbench.robot import Posture, Robot
from rmbench.robot.spec import spec_to_xml
from rmbench.robot.variant import make_variant

POSTURES = [(1800, -200, 0), (1500, 100, 20)]
SHIFT = np.array([0.002, 0.0, 0.003])  # axis 4 moved in the upper arm's frame, m

CONFIG = """
seed = 4
method = "linear"
[robot]
name = "{robot}"
{commands}
[grid]
kind = "list"
postures = {postures}
[hits]
points = ["1X", "1aY"]
averages = 1
"""


def _run(path, robot, commands_from=None, postures=POSTURES):
    commands = f'commands_from = "{commands_from}"' if commands_from else ""
    text = CONFIG.format(robot=robot, commands=commands, postures=[list(p) for p in postures])
    run_campaign(parse_config(text), path, workers=0, progress=False)
    return open_campaign(path)


@pytest.fixture(scope="module")
def variants(tmp_path_factory, irb):
    """Saved variants: two with the nominal kinematics, one with axis 4 moved by a few mm."""
    d = tmp_path_factory.mktemp("variants")
    out = {}
    for name, kw in (("stiffness", {"edits": ["j2_flex.stiffness*=0.8"]}),
                     ("compliant-base", {"compliant_base": (5e8, 5e8)}),
                     ("moved-axis", {"edits": [f"motor4.pos+={','.join(map(str, SHIFT))}"]})):
        out[name] = d / f"{name}.xml"
        out[name].write_text(make_variant(irb, **kw))
    return out


@pytest.fixture(scope="module")
def moved(tmp_path_factory, variants):
    """The moved-axis variant's campaign, commanded by itself and by the nominal IRB6660."""
    d = tmp_path_factory.mktemp("moved")
    return {"own": _run(d / "own.nc", variants["moved-axis"]),
            "nominal": _run(d / "nominal.nc", variants["moved-axis"], "irb6660")}


@pytest.mark.parametrize("variant", ["stiffness", "compliant-base"])
def test_nominal_commands_equal_own_commands_for_nominal_kinematics(tmp_path, variants, variant):
    # same kinematic chain (the base's passive freedoms are no IK variables): same commands, same test
    own = _run(tmp_path / "own.nc", variants[variant])
    nominal = _run(tmp_path / "nominal.nc", variants[variant], "irb6660")
    np.testing.assert_allclose(nominal.q_cmd.values, own.q_cmd.values, rtol=0, atol=1e-12)
    np.testing.assert_allclose(nominal.H.values, own.H.values, rtol=1e-9, equal_nan=True)


def test_moved_axis_misses_the_posture_by_its_kinematic_offset_at_nominal_commands(moved, irb):
    variant = Robot.load(moved["nominal"].attrs["robot"])
    for i, p in enumerate(POSTURES):
        q = moved["nominal"].q_cmd.values[i]
        target = irb.target(Posture.from_mm_deg(*p))
        np.testing.assert_allclose(q, irb.ik(Posture.from_mm_deg(*p)).q, rtol=0, atol=1e-12)
        # the moved subtree is translated by SHIFT in the upper arm's frame; nothing upstream moved
        data = mujoco.MjData(irb.model)
        for name, qj in zip(irb.arm_joints, q):
            data.qpos[irb.model.joint(name).qposadr[0]] = qj
        mujoco.mj_kinematics(irb.model, data)
        offset = data.xmat[irb.model.body("upper_arm").id].reshape(3, 3) @ SHIFT
        tip = variant.kinematics.fk(q)
        # IK converges to 1e-10; the MJCF writer keeps the shifted position exactly (0.283 m)
        np.testing.assert_allclose(tip.translation - target.translation, offset, atol=1e-9)
        np.testing.assert_allclose(tip.rotation, target.rotation, atol=1e-9)


def test_own_inverse_kinematics_puts_the_moved_variant_back_on_the_posture(moved, irb):
    variant = Robot.load(moved["own"].attrs["robot"])
    for i, p in enumerate(POSTURES):
        q = moved["own"].q_cmd.values[i]
        target = irb.target(Posture.from_mm_deg(*p))
        np.testing.assert_allclose(variant.kinematics.fk(q).translation, target.translation, atol=1e-9)
        # a few mm of offset on a ~1.5 m arm: the commands differ by mrad
        assert np.abs(q - moved["nominal"].q_cmd.values[i]).max() > 1e-4


def test_dataset_records_where_the_commands_came_from(moved):
    assert moved["nominal"].attrs["commands_from"] == "irb6660"
    assert moved["own"].attrs["commands_from"] == moved["own"].attrs["robot"]


def test_posture_the_nominal_cannot_reach_is_a_per_posture_failure(tmp_path, variants):
    ds = _run(tmp_path / "far.nc", variants["stiffness"], "irb6660", postures=[(1800, -200, 0), (4000, 0, 0)])
    assert list(ds.ok.values) == [True, False]
    assert "unreachable by irb6660" in str(ds.reason.values[1])


def test_nominal_robot_with_other_arm_joints_is_rejected(tmp_path, irb):
    spec = irb.spec
    spec.add_text(name="rmbench_arm_joints", data="j1 j2 j3 j4 j5")
    odd = tmp_path / "five_axes.xml"
    odd.write_text(spec_to_xml(spec))
    with pytest.raises(InputError, match="commands joints j1 j2 j3 j4 j5"):
        _run(tmp_path / "x.nc", "irb6660", odd)
