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


def _quiet_spinning_campaign():
    """The demo campaign at 10 400 rev/min without noise and hit scatter, time domain."""
    import json

    from rmbench.impact import Campaign, CampaignConfig, load_config

    d = json.loads(load_config("demo").model_dump_json())
    d.update(noise_scale=0.0, method="time")
    d["robot"]["spindle_rpm"] = 10_400.0
    for b in d["bands"].values():
        b["hammer"].update(direction_scatter_deg=0.0, location_scatter_mm=0.0, force_scatter=0.0)
    return Campaign.build(CampaignConfig.model_validate(d))


def test_laser_band_simulation_keeps_the_spinning_rotor():
    c = _quiet_spinning_campaign()
    low = [n for n, b in c.config.bands.items() if b.sensor == "laser"]
    names = {c.sim_robots[n].model.joint(j).name for n in low for j in range(c.sim_robots[n].model.njnt)}
    assert "spindle_spin" in names and not names & {"spindle_x", "spindle_rx", "tool_x"}


def test_time_domain_laser_band_on_a_spinning_spindle_reproduces_the_exact_cross_entries():
    """The rotor's gyroscopic coupling moves the low band's X-Y cross entries by a few per cent
    of their peak at this posture: with the rotor welded they miss H_exact by that much, and
    without removing the held drive command's disturbance the direct entries miss by 20 %.
    Noiseless, one hit at 1X: RK4 at 1 ms and the quasi-static condensation leave ≤ 0.5 % of
    each entry's peak."""
    from rmbench.impact.measure import band_lines, exact_band, measure_band
    from rmbench.robot import seed_grid

    c = _quiet_spinning_campaign()
    band = next(n for n, b in c.config.bands.items() if b.sensor == "laser")
    cfg = c.config.bands[band]
    op = c.robot.at(seed_grid()[3])
    op_t = c.tested_robots[band].at(op.q_cmd)
    he, _, _, _ = exact_band(op_t, op, c.sensors[band], c.bands[band], band_lines(cfg))
    (h, _), _, _ = measure_band(c.sim_robots[band].at(op.q_cmd), op_t, c.sensors[band], cfg,
                                c.bands[band], 1.0, 1, ("1X",), np.random.default_rng(0),
                                noise_scale=0.0)
    err = np.abs(h[:, :, 0] - he[:, :, 0]).max(axis=0) / np.abs(he[:, :, 0]).max(axis=0)
    assert err.max() < 0.005


@pytest.mark.parametrize("index", [13, 41, 97, 101])
def test_a_spinning_robot_settles_where_round_off_exceeds_the_force_tolerance(index):
    """At 10 292 rev/min these seed postures leave the rotor's gyroscopic terms' round-off above
    the equilibrium's force tolerance (1e-12 N); Newton's steps have reached round-off, which is
    convergence: the posture is held, and in the same place as with the rotor at rest."""
    from rmbench.robot import seed_grid

    posture = seed_grid()[index]
    spinning = Robot.load("irb6660", spindle_rpm=10292.349).at(posture)
    still = Robot.load("irb6660").at(posture)
    np.testing.assert_allclose(spinning.data.qpos[:-1], still.data.qpos[:-1], atol=1e-9)
