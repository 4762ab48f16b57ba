"""The exact reference with every mode of the linearised robot (issue 82).

By default :func:`rmbench.path.exact_modes` takes the tool tip's modes as the two measured bands
see them (4-40 Hz and 600-1,400 Hz on the IRB6660). ``bands="all"`` takes every mode below
``f_max`` as one band instead: the modes between the bands and the tool's above them, all adding to
one receptance. At low spindle speed that sets the limit above about 800 rev/min (chatter at the
tool's modes near 2.7 kHz, or between the bands), where the bands alone can be twice too high.
"""

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.path import exact_depths, exact_modes
from rmbench.path.margin import ALL_MODES
from rmbench.robot import Posture, Robot
from rmbench.stability import STEEL_C45

XY = np.array([[1.8, 0.2], [1.6, -0.3]])           # m
THETA = np.deg2rad([-30.0, 30.0])
AT = Posture.from_mm_deg(1800, 200, 30)             # the study's pose, XY[0] at THETA[1]


@pytest.fixture(scope="module")
def endmill():
    return Robot.load("irb6660", tool="endmill")


@pytest.fixture(scope="module")
def at_pose(endmill):
    """One pose, (1800 mm, 200 mm, 30°): the bands' modes and every mode below 8 kHz."""
    xy, th = [[1.8, 0.2]], np.deg2rad([30.0])
    return exact_modes(endmill, xy, th), exact_modes(endmill, xy, th, bands="all")


def test_default_takes_each_bands_mode_table_as_before(endmill):
    # the reference as it was built before the option: per band, the mode table's poles and its
    # 1X/1Y residues, padded with NaN; the default must give these numbers bit for bit
    tm = exact_modes(endmill, XY, THETA)
    assert tuple(tm.poles) == ("low", "high")
    for row, (i, j) in enumerate((i, j) for i in range(len(XY)) for j in range(len(THETA))):
        op = endmill.at(Posture(*XY[i], THETA[j]))
        for b in ("low", "high"):
            t = op.modes(b)
            k = len(t.poles)
            assert np.array_equal(tm.poles[b][row, :k], t.poles)
            assert np.array_equal(tm.residues[b][row, :k], t.phi_r[:, :2, None] * t.phi_l[:, None, :2])
            assert np.all(np.isnan(tm.poles[b][row, k:]))


def test_default_depths_equal_the_named_bands(endmill):
    a = exact_depths(endmill, XY, THETA, STEEL_C45, 1500.0)
    b = exact_depths(endmill, XY, THETA, STEEL_C45, 1500.0, bands=("low", "high"), f_max=100.0)
    assert np.array_equal(a.a_lim, b.a_lim)


def test_all_modes_limit_well_below_the_bands_at_1500_rpm(at_pose):
    # the study (zero-order, 8,000 chatter-frequency lines): bands 2.74 mm, every mode below
    # 8 kHz 1.20 mm; the planner's 800 lines give 1.216 mm (1 % above: the grid), hence 3 %;
    # virtual milling chatters at 1.8 mm and is stable at 0.8 mm
    bands, every = (tm.depths(STEEL_C45, 1500.0).a_lim[0, 0] for tm in at_pose)
    assert bands == pytest.approx(2.74e-3, rel=0.01)
    assert every == pytest.approx(1.20e-3, rel=0.03)
    assert every < 0.5 * bands


def test_all_modes_keep_the_limit_where_the_low_band_sets_it(at_pose):
    # at 300 rev/min the low band's modes chatter (0.124 mm); the other modes move it < 1 %
    bands, every = (tm.depths(STEEL_C45, 300.0).a_lim[0, 0] for tm in at_pose)
    assert every == pytest.approx(bands, rel=0.01)


def test_all_modes_add_the_modes_between_the_bands_and_the_tools(at_pose):
    bands, every = at_pose
    f_bands = np.concatenate([np.abs(p[0]) for p in bands.poles.values()]) / (2 * np.pi)
    f_all = np.abs(every.poles[ALL_MODES][0]) / (2 * np.pi)
    extra = f_all[~np.isin(np.round(f_all, 6), np.round(f_bands, 6))]
    assert np.sum((extra > 100) & (extra < 400)) >= 6       # six near 116-139 Hz, one near 298 Hz
    assert np.any((extra > 2500) & (extra < 3000))          # the tool on its holder, near 2.7 kHz
    assert f_all.max() < 8000.0


def test_all_modes_hold_each_bands_mode_with_its_residue(at_pose):
    # the same modes in the same convention: a band's mode table rescales φR and φL by one complex
    # number, which cancels in the residue (round-off only)
    bands, every = at_pose
    p_all, r_all = every.poles[ALL_MODES][0], every.residues[ALL_MODES][0]
    for b in bands.poles:
        for p, r in zip(bands.poles[b][0], bands.residues[b][0]):
            k = np.argmin(np.abs(p_all - p))
            assert abs(p_all[k] - p) <= 1e-9 * abs(p)
            assert np.abs(r_all[k] - r).max() <= 1e-9 * np.abs(r).max()


def test_all_modes_superpose_to_the_direct_receptance(endmill):
    # with every mode (f_max inf) the residues give the tip's receptance that solving the dynamic
    # stiffness gives, at frequencies off the resonances (relative 1e-6: round-off of the eigen-
    # solution). Below 8 kHz alone the modes near 11 and 34 kHz are missing: their static
    # compliance is up to a quarter of the tip's receptance at 4 kHz (a 1-2 % higher limit)
    tm = exact_modes(endmill, [[1.8, 0.2]], np.deg2rad([30.0]), bands="all", f_max=np.inf)
    p, r = tm.poles[ALL_MODES][0], tm.residues[ALL_MODES][0]
    op = endmill.at(AT)
    rows = op.coordinate_map(("1X", "1Y"))
    freq = np.array([2.0, 60.0, 200.0, 450.0, 1800.0, 4000.0])
    direct = op.linear.frf(freq, rows, rows)
    s = 2j * np.pi * freq[:, None, None, None]
    synth = (r / (s - p[:, None, None]) + r.conj() / (s - p.conj()[:, None, None])).sum(axis=1)
    err = np.abs(synth - direct).max(axis=(1, 2)) / np.abs(direct).max(axis=(1, 2))
    assert np.all(err < 1e-6)


def test_all_modes_takes_f_max_in_hz(endmill):
    tm = exact_modes(endmill, [[1.8, 0.2]], np.deg2rad([30.0]), bands="all", f_max=1000.0)
    f = np.abs(tm.poles[ALL_MODES][0]) / (2 * np.pi)
    assert f.max() < 1000.0 and np.sum(f > 600) == 4          # the high band's four, not the tool's


def test_all_modes_refuse_a_frequency_limit_not_above_zero(endmill):
    with pytest.raises(InputError, match="f_max"):
        exact_modes(endmill, [[1.8, 0.2]], [0.0], bands="all", f_max=0.0)
