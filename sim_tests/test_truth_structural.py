"""The blind benches' structural effects (bench/truth/structural.py): each kind is physics the
nominal robot lacks, made by plain MJCF edits or on the measured signals, and sized against the
nominal for scoring."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
import xarray as xr

from _bench_path import bench_on_path

with bench_on_path():
    from truth.structural import IN_LIBRARY, OUT_OF_LIBRARY, Effect, apply_effect, draw_effect, turned_signals
    from truth.visibility import visibility

from rmbench.robot import Robot, seed_grid  # noqa: E402

POSTURE = 40                  # mid-reach of the seed grid
BANDS = ((4.0, 40.0), (600.0, 1400.0))     # Hz, the test design's bands
MJCF_KINDS = [k for k in IN_LIBRARY + OUT_OF_LIBRARY if k not in ("sensor_misalignment", "non_reciprocity")]


@pytest.fixture(scope="module")
def nominal():
    return Robot.load("irb6660", tool="dummy")


def _drawn(kind, seed=0) -> Effect:
    rng = np.random.default_rng(seed)
    for _ in range(200):
        e = draw_effect(rng, in_library=kind in IN_LIBRARY)
        if e.kind == kind:
            return e
    raise AssertionError(f"{kind} never drawn")


def _tested_modes(robot, band) -> np.ndarray:
    f = robot.at(seed_grid()[POSTURE]).linear.modes().f_n
    return np.sort(f[(f > band[0]) & (f < band[1])])


@pytest.mark.parametrize("kind", MJCF_KINDS)
def test_each_mjcf_effect_moves_or_adds_a_tested_mode(nominal, kind):
    # a structural effect the bench hides must change what an impact test sees: a mode of a tested
    # band moved by more than the campaign's 0.1-0.3 % scatter, or one more in it (a hose's own)
    root, ref = ET.fromstring(nominal.xml), ET.fromstring(nominal.xml)
    apply_effect(root, _drawn(kind), ref)
    real = Robot(ET.tostring(root, encoding="unicode"), name="real", tool="dummy")
    moved = []
    for band in BANDS:
        f0, f = _tested_modes(nominal, band), _tested_modes(real, band)
        n = min(len(f0), len(f))
        moved.append(len(f) != len(f0) or np.max(np.abs(f[:n] / f0[:n] - 1)) > 0.003)
    assert any(moved)


def test_a_holders_size_is_its_stiffness_over_the_nominals_spread_included(nominal):
    # the spread has already scaled the holder: the size scored is the real robot's against the
    # nominal, which is what a model corrected by the diagnosis must reach
    root, ref = ET.fromstring(nominal.xml), ET.fromstring(nominal.xml)
    joint = next(j for j in root.iter("joint") if j.get("name") == "tool_contact_x")
    joint.set("stiffness", str(1.1 * float(joint.get("stiffness"))))
    effect = apply_effect(root, Effect("tool_contact_stiffness", "tool_contact", {"factor": 4.0}), ref)
    assert effect.size == pytest.approx(4.4)


def test_an_added_masss_size_is_the_kilograms_over_the_nominal(nominal):
    root, ref = ET.fromstring(nominal.xml), ET.fromstring(nominal.xml)
    effect = apply_effect(root, Effect("added_mass", "wrist", {"fraction": 0.5}), ref)
    assert effect.size == pytest.approx(0.5 * 35.0)      # the IRB6660 wrist's 35 kg


def _frfs() -> xr.Dataset:
    coords = ["1X", "1Y", "1aX", "1aY"]
    h = np.zeros((2, 3, 4, 4), complex)
    h[:, :, 0, :] = 1.0          # 1X reads 1
    h[:, :, 1, :] = 2.0          # 1Y reads 2
    return xr.Dataset({"H": (("posture", "freq", "out", "inp"), h)},
                      coords={"freq": [10.0, 20.0, 800.0], "band": ("freq", ["low", "low", "high"]),
                              "out": coords, "inp": coords})


def test_a_turned_sensor_mixes_in_the_perpendicular_signal_in_its_band_alone():
    ds = _frfs()
    turned = turned_signals(ds, Effect("sensor_misalignment", "low:1X", {"angle_deg": 10.0}))
    d = np.radians(10.0)
    np.testing.assert_allclose(turned.H.sel(out="1X").values[:, :2], np.cos(d) * 1 + np.sin(d) * 2)
    np.testing.assert_array_equal(turned.H.sel(out="1X").values[:, 2], 1.0)     # the high band's
    np.testing.assert_array_equal(turned.H.sel(out="1Y").values, ds.H.sel(out="1Y").values)
    np.testing.assert_array_equal(ds.H.sel(out="1X").values, 1.0)               # the input untouched


def test_a_turned_y_sensor_takes_the_x_signal_with_the_opposite_sign():
    # a reading direction (cos(a + δ), sin(a + δ)) at a = 90°: cos δ·Y − sin δ·X
    turned = turned_signals(_frfs(), Effect("sensor_misalignment", "low:1Y", {"angle_deg": 10.0}))
    d = np.radians(10.0)
    np.testing.assert_allclose(turned.H.sel(out="1Y").values[:, :2], np.cos(d) * 2 - np.sin(d) * 1)


def test_effects_are_drawn_reproducibly_with_sizes_in_their_stated_ranges():
    a = [draw_effect(np.random.default_rng([5, i]), in_library=True) for i in range(40)]
    b = [draw_effect(np.random.default_rng([5, i]), in_library=True) for i in range(40)]
    assert a == b
    assert {e.kind for e in a} == set(IN_LIBRARY)
    for e in a:
        if e.kind == "base_compliance":
            assert 30 <= e.size <= 100
        elif e.kind == "sensor_misalignment":
            assert 6 <= abs(e.size) <= 12
        elif e.kind == "non_reciprocity":
            assert 12000 <= e.size <= 24000


def test_a_sensor_turned_by_its_smallest_draw_is_visible_on_two_postures(nominal):
    # the bench's visibility rule sees a turned sensor through its signals, as the campaign does:
    # 6° mixes a tenth of the perpendicular response into the reading, far above the noise
    effect = Effect("sensor_misalignment", "low:1X", {"angle_deg": 6.0})
    postures = [seed_grid()[i] for i in (0, 90)]
    seen = visibility(nominal.xml, nominal.xml, postures, 11, signals=lambda ds: turned_signals(ds, effect))
    assert seen["visible"] and seen["effect_chi2"] > 10 * seen["threshold"]
