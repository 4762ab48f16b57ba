"""Specification of the structural search on top of a calibration: the ordinary parameters follow
each candidate to first order, held-out postures are scored with the training fit's move, a
small shrink explains nothing, and a robot already on a foundation can still be found to slide."""

import numpy as np
import pytest

from rmbench.calibrate import TestDesign
from rmbench.gap.frf.diagnosis import DiagnosisSettings
from rmbench.gap.frf.rules import explains
from rmbench.gap.frf.effects import Change, library
from rmbench.gap.frf.joint import Ordinary
from rmbench.gap.frf.model import ModelBench
from rmbench.gap.frf.search import Fitted
from rmbench.impact import load_config
from rmbench.robot import Posture
from rmbench.robot.parameters import parameter_set


def test_the_ordinary_move_solves_the_regularised_least_squares():
    rng = np.random.default_rng(3)
    J, e, z = rng.normal(size=(40, 5)), rng.normal(size=40), rng.normal(size=5)
    dz = Ordinary({}, z, tuple("abcde")).step(e, J)
    # the augmented system [J; I] dz = -[e; z], solved by least squares
    ref = np.linalg.lstsq(np.vstack([J, np.eye(5)]), -np.concatenate([e, z]), rcond=None)[0]
    np.testing.assert_allclose(dz, ref, rtol=1e-10, atol=1e-12)


def test_at_the_calibrated_optimum_the_ordinary_parameters_stay():
    # at a MAP optimum the gradient Jᵀe + z vanishes: the joint fit must not move them
    rng = np.random.default_rng(4)
    J, z = rng.normal(size=(30, 4)), rng.normal(size=4)
    e = -np.linalg.pinv(J.T) @ z
    np.testing.assert_allclose(J.T @ e + z, 0, atol=1e-10)
    np.testing.assert_allclose(Ordinary({}, z, tuple("abcd")).step(e, J), 0, atol=1e-10)


def _fitted(chi2_held, n=400):
    return Fitted((), (), chi2_held, chi2_held, n, n, peak_held=1.0)


def test_a_small_shrink_is_no_explanation():
    settings = DiagnosisSettings()
    nominal = _fitted(600.0)
    # noise-level after (χ² ≈ n) but only 18 % of the rms gap closed: a small gap tidied up
    assert not explains(_fitted(400.0), nominal, settings)
    # the same noise level reached from a gap twice as large (rms): half of it closed
    assert explains(_fitted(400.0), _fitted(1700.0), settings)


def test_a_robot_on_a_calibrated_foundation_can_still_slide(irb):
    robot, _ = parameter_set(irb, ("joints", "base"))
    design = TestDesign.from_config(load_config("seed_full"))
    base = [e for e in library(robot, design) if e.kind == "base_compliance"]
    assert len(base) == 1 and [p.name for p in base[0].params] == ["lateral"]
    post = Posture.from_mm_deg(1800, -200, 0)
    bench = ModelBench(robot, design, np.array([irb.ik(post).q]))
    f0 = bench.modes(Change(), 0, "low").f_n
    f1 = bench.modes(base[0].change(np.array([50.0])), 0, "low").f_n
    # 50 µm/kN under a 3 t robot: a sway mode near 11 Hz joins the low band's first modes
    assert f1[1] < 0.95 * f0[1]
