"""The virtual robots resemble the seeds' robots (issue 2, item 4), at representative postures.

The full 112-posture statistics are in bench/modes.py; these checks keep the models in band.
"""

import numpy as np
import pytest

from rmbench.robot import validation_postures
from rmbench.robot.suppressor import reference_modes, reference_point


def test_irb_low_and_high_modes_lie_in_the_seed_bands(irb):
    for p in validation_postures():
        op = irb.at(p)
        lo, hi = op.modes("low"), op.modes("high")
        assert np.sum((lo.f_n >= 5) & (lo.f_n <= 30)) >= 5
        assert np.sum((hi.f_n >= 700) & (hi.f_n <= 1100)) >= 4
        zeta = np.concatenate([lo.zeta, hi.zeta])
        assert np.all((zeta > 0.005) & (zeta < 0.20))


def test_irb_tool_tip_cross_coupling_at_a_low_mode(irb_op):
    f = irb_op.modes("low").f_n
    h = irb_op.frf(f, ("1X", "1Y"))
    assert np.max(np.abs(h[:, 0, 1]) / np.abs(h[:, 0, 0])) >= 0.10


def test_mh180_reference_modes_and_coupling(mh180):
    m = reference_modes(reference_point(mh180))
    assert 5.0 <= m["tangential_hz"] <= 7.0
    assert 10.0 <= m["axial_hz"] <= 14.0
    assert m["cross_tangential"] >= 0.10 and m["cross_axial"] >= 0.10


def test_mh180_suppressor_hardware(mh180):
    model = mh180.model
    for axis in ("tangential", "axial", "radial"):
        j = model.joint(f"pm_{axis}")
        np.testing.assert_allclose(j.range, [-0.0125, 0.0125])
        assert model.body(f"pm_{axis}_mass").mass[0] == 3.0
        np.testing.assert_allclose(model.actuator(f"vc_{axis}").ctrlrange, [-180, 180])
        assert model.actuator(f"shaker_{axis}").id >= 0
        assert model.sensor(f"enc_{axis}").id >= 0
    # eccentric mass: m e = 0.2 kg x 0.05 m = 0.01 kg m
    assert model.body("eccentric").mass[0] * np.linalg.norm(model.body("eccentric").pos) == pytest.approx(0.01)


def test_mh180_voice_coils_hold_their_masses_centred_at_equilibrium(mh180):
    op = reference_point(mh180)
    for axis in ("tangential", "axial", "radial"):
        assert abs(op.data.qpos[mh180.model.joint(f"pm_{axis}").qposadr[0]]) < 1e-12
    # the axial coil carries its 3 kg reaction mass against gravity: about 29.4 N
    assert abs(op.data.ctrl[mh180.model.actuator("vc_axial").id]) == pytest.approx(3 * 9.81, rel=1e-3)
