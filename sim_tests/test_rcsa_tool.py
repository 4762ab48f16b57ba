"""RCSA tool change (METHODS.md §3-4): finite differences, tool substructures, Eq. 4, contact fit."""

import warnings

import numpy as np
import pytest

from rmbench.errors import InputError
from rmbench.rcsa import (FULL_COORDS, POINT_COORDS, Contact, IllConditionedWarning, change_tool,
                          couple_tool, full_receptance, identify_contact, shank_mass_matrix,
                          tool_receptance)
from rmbench.rcsa.coupling import with_shank_change
from rmbench.robot import Robot, validation_postures
from rmbench.robot.tool import TOOLS

HIGH = np.arange(600.0, 1400.1, 4.0)  # the high band, where the tool and holder modes live
REF, TGT = TOOLS["dummy"], TOOLS["endmill"]


@pytest.fixture(scope="module")
def posture2():
    p = validation_postures()[1]
    return (Robot.load("irb6660", tool="dummy").at(p), Robot.load("irb6660", tool="endmill").at(p))


def _rel(a, b):
    """Largest error of each entry relative to that entry's largest exact magnitude, shape (4, 4)."""
    return np.max(np.abs(a - b), axis=0) / np.max(np.abs(b), axis=0)


def test_finite_differences_equal_exact_rotations_when_1a_lies_on_the_rigid_tip_segment(posture2):
    # S = 10 mm keeps 1 and 1a on the tool's tip segment (bending hinge 13.8 mm up): a rigid
    # piece, on which the first-order difference is exact in the linear model.
    ref, _ = posture2
    s = 0.010
    t = full_receptance(ref.frf(HIGH, POINT_COORDS, s_1a=s), s)
    assert np.all(_rel(t, ref.frf(HIGH, FULL_COORDS)) < 1e-6)


def test_exact_rotation_of_a_vertical_tool_is_minus_phi_y_for_x_slopes(posture2):
    # θ_X = −φ_Y, θ_Y = +φ_X (METHODS.md §3 slope convention) for the tool pointing down
    ref, _ = posture2
    rows = ref.coordinate_map(("1rX", "1rY"))
    import mujoco
    m, d = ref.robot.model, ref.data
    sid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "tool_tip")
    jacr = np.zeros((3, m.nv))
    mujoco.mj_jac(m, d, None, jacr, d.site_xpos[sid], int(m.site_bodyid[sid]))
    # to 1e-2: under gravity the tool hangs 0.4° off vertical at its deflected equilibrium
    assert np.allclose(rows[0], -jacr[1], atol=1e-2 * np.abs(jacr).max())
    assert np.allclose(rows[1], jacr[0], atol=1e-2 * np.abs(jacr).max())


def test_spacing_trades_truncation_against_noise(posture2):
    # 5e-6 complex noise (of each entry's peak) on every measured entry: rotations divide it by S
    # and P by S², so a small S drowns in noise; a large S reaches across the tool's bending hinge
    # (truncation). P is the fragile entry: at S = 10 mm it needs noise below ~1e-5 for 5 %.
    ref, _ = posture2
    exact = ref.frf(HIGH, FULL_COORDS)
    rotational = np.ones((4, 4), bool)
    rotational[0::2, 0::2] = False  # L, N and P entries
    rng = np.random.default_rng(0)
    err = {}
    for s in (0.001, 0.010, 0.0334):
        h = ref.frf(HIGH, POINT_COORDS, s_1a=s)
        scale = np.abs(h).max(axis=0)
        noisy = h + 5e-6 * scale * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
        err[s] = _rel(full_receptance(noisy, s), exact)[rotational].max()
    assert err[0.010] < 0.05  # every rotation and moment entry within 5 % at a good spacing
    assert err[0.001] > 10 * err[0.010]  # noise / S²
    assert err[0.0334] > 5 * err[0.010]  # truncation across the hinge


def test_free_free_overhang_moves_as_a_rigid_body_far_below_its_bending_modes():
    # at 1 Hz the free-free overhang's receptance is −(ω² M_rigid)⁻¹ about the holder end
    a = tool_receptance(REF, np.array([1.0]))
    m = REF.mass_per_length * REF.overhang
    big_l = REF.overhang
    rigid = np.array([[m, m * big_l / 2], [m * big_l / 2, m * big_l**2 / 3 + m * REF.diameter**2 / 16]])
    omega2 = (2 * np.pi) ** 2
    assert np.allclose(np.linalg.inv(-omega2 * a.t22[0, :2, :2]).real, rigid, rtol=1e-4)


def test_tool_receptances_are_reciprocal():
    a = tool_receptance(TGT, HIGH)
    assert np.allclose(a.t12, np.swapaxes(a.t21, 1, 2), rtol=1e-9, atol=0)


def test_tool_change_is_exact_on_the_coupled_model_itself():
    # Couple the reference tool to a robot side, change tools: the result equals the target
    # tool coupled to the same side with its shank (Eq. 4 and the shank step are exact algebra).
    freq = HIGH
    omega = 2 * np.pi * freq
    k = np.diag([3e7, 2e5, 2.5e7, 1.5e5])
    mass = np.array([[8.0, 0.1, 0, 0], [0.1, 0.05, 0, 0], [0, 0, 8.0, 0.1], [0, 0, 0.1, 0.05]])
    r33 = np.linalg.inv(k[None] * (1 + 0.02j) - omega[:, None, None] ** 2 * mass[None])
    r33_ref = np.linalg.inv(np.linalg.inv(r33) - omega[:, None, None] ** 2 * shank_mass_matrix(REF))
    r33_tgt = np.linalg.inv(np.linalg.inv(r33) - omega[:, None, None] ** 2 * shank_mass_matrix(TGT))
    t_ref, _ = couple_tool(r33_ref, tool_receptance(REF, freq), Contact.of(REF))
    t_tgt, _ = couple_tool(r33_tgt, tool_receptance(TGT, freq), Contact.of(TGT))
    pred = change_tool(t_ref, freq, REF, TGT)
    assert np.max(np.abs(pred.t - t_tgt) / np.abs(t_tgt).max(axis=(0, 1))) < 1e-8


def test_without_shank_change_only_the_contact_difference_matters():
    # Eq. 4: with the shank step off, K_1 cancels; any reference contact gives the same result
    # once the target contact keeps K_2⁻¹ − K_1⁻¹ fixed.
    freq = HIGH
    omega = 2 * np.pi * freq
    r33 = np.linalg.inv(np.diag([3e7, 2e5, 2.5e7, 1.5e5])[None] * (1 + 0.02j)
                        - omega[:, None, None] ** 2 * np.diag([8.0, 0.05, 8.0, 0.05])[None])
    t_ref, _ = couple_tool(r33, tool_receptance(REF, freq), Contact.of(REF))
    a = change_tool(t_ref, freq, REF, TGT, shank=False)
    k1 = Contact(1e8, 1e7)
    k2 = Contact(1 / (1 / TGT.k_t - 1 / REF.k_t + 1 / k1.k_t), 1 / (1 / TGT.k_r - 1 / REF.k_r + 1 / k1.k_r),
                 0, 0)
    b = change_tool(t_ref, freq, REF, TGT, shank=False, reference_contact=Contact(k1.k_t, k1.k_r, REF.c_t, REF.c_r),
                    target_contact=Contact(k2.k_t, k2.k_r, TGT.c_t, TGT.c_r))
    assert np.max(np.abs(a.t[:, 0, 0] - b.t[:, 0, 0]) / np.abs(a.t[:, 0, 0]).max()) < 2e-2


def test_tool_change_predicts_the_simulated_target_tool_at_validation_posture_2(posture2):
    # exact reference receptances in: what is left is the beam model of the tool against the
    # simulator's lumped tool, and the tools' weight on the robot's equilibrium (< 0.5 %)
    ref, tgt = posture2
    pred = change_tool(ref.frf(HIGH, FULL_COORDS), HIGH, REF, TGT)
    truth = tgt.frf(HIGH, FULL_COORDS)
    for i, j in ((0, 0), (0, 2), (2, 0), (2, 2)):
        p, t = np.abs(pred.t[:, i, j]), np.abs(truth[:, i, j])
        assert HIGH[np.argmax(p)] == HIGH[np.argmax(t)]
        assert abs(p.max() / t.max() - 1) < 0.01


def test_shank_change_moves_the_holder_modes(posture2):
    # the end mill's shank is 43 g lighter: leaving it out shifts the holder modes by ~0.7 %
    ref, tgt = posture2
    truth = np.abs(tgt.frf(HIGH, ("1X",))[:, 0, 0])
    off = np.abs(change_tool(ref.frf(HIGH, FULL_COORDS), HIGH, REF, TGT, shank=False).t[:, 0, 0])
    assert HIGH[np.argmax(off)] < HIGH[np.argmax(truth)]


def test_near_singular_lines_are_reported_and_left_out():
    freq = HIGH
    a = tool_receptance(REF, freq)
    t_ref = a.t11 * 1.5
    t_ref[10:13] = a.t11[10:13]  # reference tip equal to the free tool: A11 − C singular there
    with pytest.warns(IllConditionedWarning, match=f"{freq[10]:g}-{freq[12]:g} Hz"):
        pred = change_tool(t_ref, freq, REF, TGT)
    assert pred.ill_conditioned[10:13].all() and np.isnan(pred.t[10:13]).all()
    assert np.isfinite(pred.t[~pred.ill_conditioned]).all()


def test_contact_fit_recovers_the_translational_stiffness_within_2_percent():
    # exact receptances at validation posture 1 (the calibration posture). k_t sets the holder
    # modes' frequencies, which the fit matches to a fraction of a line; the rotational contact
    # stays at its start (its compliance is ~2 % of the overhang's bending compliance, so the tip
    # FRFs cannot tell it from a 0.1 % beam-model error), and the damping c_t absorbs that
    # mismatch (+14 % here), so only k_t is held to the truth.
    p = validation_postures()[0]
    ref = Robot.load("irb6660", tool="dummy").at(p)
    tgt = Robot.load("irb6660", tool="endmill").at(p)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = identify_contact(ref.frf(HIGH, FULL_COORDS), tgt.frf(HIGH, ("1X", "1Y")), HIGH, REF, TGT)
    got, want = fit.contact, Contact.of(TGT)
    assert abs(got.k_t / want.k_t - 1) < 0.02
    assert fit.rms < 0.1 * fit.rms_start


def test_contact_fit_rejects_unknown_parameters():
    with pytest.raises(InputError, match="free contact parameters"):
        identify_contact(np.zeros((10, 4, 4)), np.ones((10, 2, 2)), HIGH[:10], REF, TGT, free=("k_x",))


def test_contact_strings_are_checked():
    assert Contact.parse("4.5e7,4.19e6").k_r == 4.19e6
    with pytest.raises(InputError, match="k_t,k_r"):
        Contact.parse("4.5e7")
    with pytest.raises(InputError, match="k_t must be positive"):
        Contact.parse("-1,2")


def test_wrong_reference_shape_is_a_clear_error():
    with pytest.raises(InputError, match="shape"):
        change_tool(np.zeros((3, 2, 2)), HIGH[:3], REF, TGT)


def test_shank_step_is_its_own_inverse():
    freq = HIGH[:5]
    r = np.linalg.inv(np.diag([3e7, 2e5, 2.5e7, 1.5e5]) - 1e4 * np.eye(4))[None].repeat(5, 0)
    there, _ = with_shank_change(r, freq, REF, TGT)
    back, _ = with_shank_change(there, freq, TGT, REF)
    assert np.allclose(back, r, rtol=1e-10)


def test_lumped_and_beam_overhangs_agree_far_below_their_bending_modes():
    # same mass, first moment and rotary inertia, and the same static flexibility: at 10-100 Hz
    # (the first free-free bending mode is above 10 kHz) only the damping models differ (1e-5)
    freq = np.array([10.0, 100.0])
    for tool in (REF, TGT):
        b, lumped = tool_receptance(tool, freq), tool_receptance(tool, freq, model="lumped")
        for name in ("t11", "t12", "t22"):
            a, c = getattr(b, name), getattr(lumped, name)
            assert np.max(np.abs(c - a)) < 1e-4 * np.max(np.abs(a))


def test_lumped_tool_receptances_are_reciprocal_at_the_points_too():
    a = tool_receptance(TGT, HIGH, model="lumped", s_1a=0.02)
    assert np.allclose(a.t12, np.swapaxes(a.t21, 1, 2), rtol=1e-9, atol=0)
    assert np.allclose(a.points[1], np.swapaxes(a.points[2], 1, 2), rtol=1e-9, atol=0)


def test_coupling_the_simulators_own_tools_rebuilds_the_simulated_target_tool(posture2):
    # exact reference receptances and the exact substructures: what is left is the tools' weight
    # on the robot's equilibrium and the dampers' series approximation, below 0.1 % of the peak
    # (the beam model leaves 0.5 %)
    ref, tgt = posture2
    truth = tgt.frf(HIGH, FULL_COORDS)
    pred = change_tool(ref.frf(HIGH, FULL_COORDS), HIGH, REF, TGT, tool_model="lumped")
    err = _rel(pred.t, truth)[0::2, 0::2]
    assert err.max() < 1e-3


def test_with_the_simulators_own_tool_the_rotational_contact_stiffness_is_identified():
    # the rotational contact's compliance is ~2 % of the root bending's, so k_r shows only once the
    # substructure's root compliance is exact; the calibration band (to 3.5 kHz) holds the
    # tool-on-holder mode at 2.7 kHz. Exact FRFs: the fit returns k_t, k_r and c_t to 1 %.
    p = validation_postures()[0]
    f = np.arange(600.0, 3500.1, 4.0)
    ref = Robot.load("irb6660", tool="dummy").at(p)
    tgt = Robot.load("irb6660", tool="endmill").at(p)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        fit = identify_contact(ref.frf(f, FULL_COORDS), tgt.frf(f, ("1X", "1Y")), f, REF, TGT,
                               free=("k_t", "k_r", "c_t"), tool_model="lumped")
    got, want = fit.contact, Contact.of(TGT)
    for name in ("k_t", "k_r", "c_t"):
        assert abs(getattr(got, name) / getattr(want, name) - 1) < 0.01, name


def test_unknown_tool_model_is_a_clear_error():
    with pytest.raises(InputError, match="tool model must be one of beam, lumped"):
        tool_receptance(REF, HIGH, model="shell")


def test_sensor_masses_add_to_the_overhangs_rigid_mass():
    # far below the bending modes the holder-end receptance is −(ω² M_rigid)⁻¹: 0.2 g at the tip
    # and at 1a add 0.4 g to its translational mass, in both models
    masses = ((0.0, 2e-4), (0.02, 2e-4))
    m0 = REF.mass_per_length * REF.overhang
    omega2 = (2 * np.pi) ** 2
    for model in ("beam", "lumped"):
        a = tool_receptance(REF, np.array([1.0]), model=model, masses=masses)
        m_rigid = np.linalg.inv(-omega2 * a.t22[0, :2, :2]).real
        assert m_rigid[0, 0] == pytest.approx(m0 + 4e-4, rel=1e-4), model


def test_decoupling_the_accelerometers_mass_recovers_the_bare_target(posture2):
    # the reference tool measured with four 0.2 g accelerometers (tip and 1a, as the campaigns
    # mount them): with their masses on its substructure the bare target comes back as exactly as
    # from the bare reference (< 0.1 % of the peak); left off, their loading stays in the prediction
    from rmbench.robot.variant import with_tool_masses

    masses = ((0.0, 2e-4), (0.0, 2e-4), (0.02, 2e-4), (0.02, 2e-4))
    p = validation_postures()[1]
    loaded = with_tool_masses(Robot.load("irb6660", tool="dummy"), masses).at(p)
    truth = posture2[1].frf(HIGH, FULL_COORDS)
    t_ref = loaded.frf(HIGH, FULL_COORDS)
    with_masses = change_tool(t_ref, HIGH, REF, TGT, tool_model="lumped", reference_masses=masses)
    without = change_tool(t_ref, HIGH, REF, TGT, tool_model="lumped")
    assert _rel(with_masses.t, truth)[0::2, 0::2].max() < 1e-3
    assert _rel(without.t, truth)[0::2, 0::2].max() > 3 * _rel(with_masses.t, truth)[0::2, 0::2].max()


def test_sensor_masses_are_read_from_a_campaigns_toml_or_json_design():
    # a campaign stores the TOML it was run from, or the validated JSON: both give the same
    # sensors (the default high band: four 0.2 g accelerometers, two at the tip, two at 1a)
    import xarray as xr

    from rmbench.impact.config import parse_config
    from rmbench.rcsa.tool_change import sensor_masses

    toml = 'seed = 3\nmethod = "linear"\n'
    from_toml = sensor_masses(xr.Dataset(attrs={"config": toml}), "high")
    from_json = sensor_masses(xr.Dataset(attrs={"config": parse_config(toml).model_dump_json()}), "high")
    assert from_toml == from_json
    assert len(from_toml) == 4 and all(m == pytest.approx(2e-4) for _, m in from_toml)
    assert sensor_masses(xr.Dataset(), "high") == []


def _campaign_like(H, band_of_line, config):
    import xarray as xr

    return xr.Dataset({"H": (("posture", "freq", "out", "inp"), H)},
                      coords={"freq": np.arange(H.shape[1], dtype=float), "band": ("freq", band_of_line),
                              "out": list(POINT_COORDS), "inp": list(POINT_COORDS)},
                      attrs={"config": config})


def test_each_accelerometer_reads_two_percent_of_the_perpendicular_motion_of_its_point():
    # the default design: 2 % transverse sensitivity, the perpendicular the axis turned +90° about Z
    import xarray as xr

    from rmbench.rcsa.tool_change import reading_matrix

    D = reading_matrix(xr.Dataset(attrs={"config": 'method = "linear"\n'}), "high")
    want = np.array([[1, 0.02, 0, 0], [-0.02, 1, 0, 0], [0, 0, 1, 0.02], [0, 0, -0.02, 1]])
    np.testing.assert_allclose(D, want, atol=1e-15)
    np.testing.assert_allclose(reading_matrix(xr.Dataset(attrs={"config": 'method = "linear"\n'}), "low"),
                               np.eye(4), atol=1e-15)    # lasers: no transverse sensitivity


def test_taking_the_cross_axis_off_gives_back_the_translations_band_by_band():
    from rmbench.rcsa.tool_change import reading_matrix, without_cross_axis

    rng = np.random.default_rng(1)
    H0 = rng.standard_normal((2, 6, 4, 4)) + 1j * rng.standard_normal((2, 6, 4, 4))
    band = np.array(["low"] * 3 + ["high"] * 3)
    ds = _campaign_like(H0, band, 'method = "linear"\n')
    D = reading_matrix(ds, "high")
    read = H0.copy()
    read[:, 3:] = np.einsum("ij,pfjk->pfik", D, H0[:, 3:])
    back = without_cross_axis(ds.assign(H=(ds["H"].dims, read)))
    np.testing.assert_allclose(back["H"].values, H0, rtol=1e-12, atol=1e-12)


def test_hits_aimed_at_the_tip_land_on_average_sigma_over_root_two_pi_above_it():
    # the hammer cannot hit beyond the tool's end: the scattered point is clipped at the tip
    from rmbench.impact.hammer import mean_hit_point

    sigma = 2e-4
    draws = np.maximum(0.0, sigma * np.random.default_rng(3).standard_normal(400_000))
    assert mean_hit_point(0.0, sigma) == pytest.approx(sigma / np.sqrt(2 * np.pi), rel=1e-12)
    assert mean_hit_point(0.0, sigma) == pytest.approx(draws.mean(), rel=0.01)   # MC error 0.15 %
    assert mean_hit_point(0.02, sigma) == pytest.approx(0.02, abs=1e-12)         # 100 σ up: no clipping


def test_taking_the_hit_offset_off_gives_back_the_nominal_columns_band_by_band():
    from rmbench.rcsa.tool_change import hit_matrix, without_hit_offset

    rng = np.random.default_rng(2)
    H0 = rng.standard_normal((2, 6, 4, 4)) + 1j * rng.standard_normal((2, 6, 4, 4))
    band = np.array(["low"] * 3 + ["high"] * 3)
    ds = _campaign_like(H0, band, 'method = "linear"\n')
    hit = H0.copy()
    for b, lines in (("low", slice(0, 3)), ("high", slice(3, 6))):
        hit[:, lines] = H0[:, lines] @ hit_matrix(ds, b)
    back = without_hit_offset(ds.assign(H=(ds["H"].dims, hit)))
    np.testing.assert_allclose(back["H"].values, H0, rtol=1e-12, atol=1e-12)


def test_the_tip_hits_mean_point_matches_force_and_moment_on_the_rigid_tip_segment():
    # default design, high band: S = 20 mm, σ = 0.2 mm; a tip column carries a / (1 - a) of the
    # 1a column with a = σ/√(2π)/S, so the pair has the nominal force and the moment F·s̄
    import xarray as xr

    from rmbench.rcsa.tool_change import hit_matrix

    W = hit_matrix(xr.Dataset(attrs={"config": 'method = "linear"\n'}), "high")
    a = 2e-4 / np.sqrt(2 * np.pi) / 0.02
    np.testing.assert_allclose(W[:, 0], [1 - a, 0, a, 0], atol=1e-15)
    np.testing.assert_allclose(W[:, 3], [0, 0, 0, 1], atol=1e-15)       # 1a hits: 100 σ up, unclipped
    np.testing.assert_allclose(W.sum(axis=0), 1.0, atol=1e-15)          # total force kept


def test_the_hit_matrix_reproduces_the_simulators_offset_tip_hits():
    # hits 0.08 mm above the tip, as the simulator applies them, against the nominal hits mixed by
    # W: what is left is the tool's hinge at 13.8 mm, between the tip and 1a (20 mm), which the
    # rigid-segment interpolation does not see; measured 5 % of the offset's whole effect
    import xarray as xr

    from rmbench.impact.hammer import Hit
    from rmbench.impact.measure import hammer_rows
    from rmbench.rcsa.tool_change import hit_matrix

    op = Robot.load("irb6660", tool="dummy").at(validation_postures()[0])
    s_1a, s_bar = 0.02, 2e-4 / np.sqrt(2 * np.pi)
    hits = [Hit(c, 1.0, 1e-3, location_error=s_bar if c in ("1X", "1Y") else 0.0) for c in POINT_COORDS]
    f = np.arange(600.0, 3500.0, 2.0)
    out, modes = op.coordinate_map(POINT_COORDS, s_1a=s_1a), op.linear.modes()
    h_nominal = modes.frf(f, out, hammer_rows(op, POINT_COORDS, s_1a))
    h_offset = modes.frf(f, out, hammer_rows(op, POINT_COORDS, s_1a, hits))
    W = hit_matrix(xr.Dataset(attrs={"config": 'method = "linear"\n'}), "high")
    effect = np.abs(h_offset - h_nominal).max()
    assert np.abs(h_offset - h_nominal @ W).max() < 0.1 * effect
