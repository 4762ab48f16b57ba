"""A spinning spindle in the time domain: the drive turns with the rotor, the arm stays at rest."""

import numpy as np
import pytest

from rmbench.robot import Posture, Robot
from rmbench.robot.simulate import hold_commands, simulate, stable_step


@pytest.fixture(scope="module")
def spinning():
    robot = Robot.load("irb6660", tool="dummy", spindle_rpm=10_000)
    return robot.at(Posture.from_mm_deg(1500, 100, 20))


def test_unforced_spinning_robot_stays_at_its_equilibrium(spinning):
    """20 ms with no force: the rotor turns Ω t (20.9 rad), every other joint stays within 1e-7 rad
    of equilibrium (the settle tolerance and RK4's error; a drive held at its start angle pulls
    the rotor back and shakes the arm by milliradians)."""
    m = spinning.robot.model
    dt = stable_step(spinning)
    n = int(0.02 / dt)
    spin = m.jnt_qposadr[m.joint("spindle_spin").id]
    q = simulate(spinning, np.zeros((n, m.nv)), dt=dt)
    others = np.setdiff1d(np.arange(m.nq), [spin])
    assert np.abs(q[:, others] - spinning.data.qpos[others]).max() < 1e-7
    np.testing.assert_allclose(q[-1, spin] - spinning.data.qpos[spin], 10_000 / 60 * 2 * np.pi * n * dt,
                               rtol=1e-6)


def test_only_the_spindle_drive_command_turns(spinning):
    m = spinning.robot.model
    u = hold_commands(spinning, 3, 1e-3)
    moving = np.flatnonzero(np.ptp(u, axis=0) > 0)
    assert [m.actuator(a).name for a in moving] == ["a_spin"]
    np.testing.assert_allclose(np.diff(u[:, moving[0]]), 10_000 / 60 * 2 * np.pi * 1e-3)



def test_a_time_domain_campaign_on_a_spinning_spindle_warns_of_the_welded_rotor():
    """The laser band's condensed simulation welds the rotor: its gyroscopic coupling is lost
    there, and the user is told so, not left to find cross entries a few per cent off; the
    linear method and a spindle at rest have nothing to warn of."""
    from rmbench.impact import load_config
    from rmbench.impact.campaign import campaign_warnings

    cfg = load_config("demo")
    spinning = cfg.with_overrides(robot_spindle_rpm=10_000.0)
    assert len(campaign_warnings(spinning)) == 1 and "gyroscopic" in campaign_warnings(spinning)[0]
    assert campaign_warnings(spinning.with_overrides(method="linear")) == []
    assert campaign_warnings(cfg) == []
