"""One posture of an impact campaign: simulate the hits, record them as sensors would, estimate FRFs.

Per band (METHODS.md §1, issue 3):

- **high band** (accelerometers, hard tip): the full robot with the accelerometers' masses on the
  tool is integrated by RK4 at ≈ 11 µs (below the stability limit of the tool's 28 kHz tip-segment
  mode) until the slowest in-band mode has decayed to ``decay``;
- **low band** (lasers, soft tip): the spindle, holder and tool freedoms are welded (their modes
  are far above the band) so that a 1 ms RK4 step suffices for the 5 s decay of the low modes;
  their static compliance under the hammer force is added back to the readings (quasi-static
  condensation, error of order (f/f_spindle)² ≈ 0.1 %); a spinning rotor keeps its joint
  (gyroscopic coupling).

On a spinning spindle the drive's command is held over each step while the rotor turns Ω dt
(1 rad at 10 000 rev/min in 1 ms): RK4's stages then see position errors of ±kp Ω dt/2 whose
reaction disturbs the arm by a few µm, the same on every run. The response of an unforced run is
subtracted from each hit's (superposition: the motions are small about the operating point).

Sensor signals then pass through the sensor dynamics, an anti-aliasing filter and decimation to the
DAQ rate, noise, resolution and range; where the signals were decimated each record starts a
pre-trigger of 16 DAQ samples before the hit, as a DAQ's trigger keeps them, and continues (noise
only) to the length set by the line spacing; force and exponential windows; H1 and coherence over the averages.
With ``method="linear"`` the exact as-tested FRF gets the same sensors' noise model instead.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import signal

from rmbench.impact.estimate import SpectralSums, exponential_window, force_window, h1
from rmbench.impact.hammer import Hit, draw_hit, pulse
from rmbench.impact.sensors import COORDS, SensorSet, nominal_point
from rmbench.robot.modes import mode_table
from rmbench.robot.simulate import simulate, stable_step

__all__ = ["BandResult", "band_lines", "measure_band", "exact_band", "hammer_rows", "integrator_of",
           "substeps", "PRETRIGGER"]

# DAQ samples recorded before the hit. Why: the anti-aliasing filter is linear-phase, so it spreads
# the hit's abrupt onset over about ten samples on either side; a record starting at the hit cut the
# part before it, from force and response unequally, which put up to 1.6 % of the peak on the high
# band's direct FRFs (the tool calibration's 600-3500 Hz, hammer ideal and noise off; 0.2 % with it
# and the five-point acceleration)
PRETRIGGER = 16


@dataclass
class BandResult:
    """Measured and exact receptance of one band at one posture (SI units).

    Attributes
    ----------
    freq : ndarray, shape (n_lines,), Hz
    H, coherence : ndarray, shape (n_lines, 4, 4)
        Measured receptance (m/N; row response, column excitation) and coherence.
    H_exact, H_exact_bare : ndarray, shape (n_lines, 4, 4)
        Exact receptance as tested (sensor effects in) and of the bare structure.
    modes, modes_bare : ModeTable
        Exact modal parameters as tested and bare.
    steps : int
        Time steps simulated (0 for the linear method).
    overloads : int
        Samples clipped at a sensor's range.
    """

    freq: np.ndarray
    H: np.ndarray
    coherence: np.ndarray
    H_exact: np.ndarray
    H_exact_bare: np.ndarray
    modes: object
    modes_bare: object
    steps: int = 0
    overloads: int = 0
    info: dict = field(default_factory=dict)


def band_lines(band_cfg) -> np.ndarray:
    """Frequency lines of a band (multiples of the line spacing inside [f_min, f_max]), Hz."""
    df = band_cfg.line_spacing
    k0 = int(np.ceil(band_cfg.f_min / df - 1e-9))
    k1 = int(np.floor(band_cfg.f_max / df + 1e-9))
    return np.arange(k0, k1 + 1) * df


def hammer_rows(op, coords, s_1a: float, hits: list[Hit] | None = None) -> np.ndarray:
    """Generalised-force rows of hammer hits, shape (n, n_dof): nominal, or as actually hit."""
    rows = []
    for k, c in enumerate(coords):
        s, a = nominal_point(c, s_1a)
        if hits is not None:
            s, a = max(0.0, s + hits[k].location_error), a + hits[k].direction_error
        d = np.array([np.cos(a), np.sin(a), 0.0])
        rows.append(d @ op.point_jacobian(op.robot.tcp, s))
    return np.array(rows)


def exact_band(op_tested, op_bare, sensors: SensorSet, band, freq, coords=COORDS):
    """Exact receptance and modes of a band, as tested and bare (see :class:`BandResult`)."""
    s_1a = band.s_1a
    read = sensors.reading_rows(op_tested)
    ham_t = hammer_rows(op_tested, coords, s_1a)
    h_exact = op_tested.linear.frf(freq, read, ham_t)
    nominal = op_bare.coordinate_map(coords, s_1a=s_1a)
    h_bare = op_bare.linear.frf(freq, nominal, nominal)
    modes = mode_table(op_tested.linear.modes(), read, ham_t, band)
    modes_bare = mode_table(op_bare.linear.modes(), nominal, nominal, band)
    return h_exact, h_bare, modes, modes_bare


def measure_band(op_sim, op_full, sensors: SensorSet, band_cfg, band, hammer_gain: float,
                 n_avg: int, coords, rng: np.random.Generator, *, method: str = "time",
                 h_exact: np.ndarray | None = None, records: list | None = None,
                 noise_scale: float = 1.0):
    """Measured receptance and coherence of one band, shape (n_lines, 4, n_coords) each.

    Parameters
    ----------
    op_sim : OperatingPoint
        The model that is integrated (for the low band the condensed one).
    op_full : OperatingPoint
        The full as-tested model (static compliance of the condensed freedoms; linear method).
    band_cfg : BandConfig
        File units.
    hammer_gain : float
        Actual over nominal load-cell sensitivity.
    noise_scale : float
        Scale of the load cell's noise (the sensors' is in ``sensors``).
    records : list, optional
        If given, receives ``(k, force, responses)`` per hit: the windowed records at the DAQ
        rate (coordinate index k, force shape (n_rec,), responses shape (n_rec, 4)), for checking
        the estimate with another tool.
    """
    freq = band_lines(band_cfg)
    fs = band_cfg.sample_rate
    n_rec = int(round(fs / band_cfg.line_spacing))
    lines = np.rint(freq / band_cfg.line_spacing).astype(int)
    hcfg = band_cfg.hammer
    win_e = exponential_window(n_rec, band_cfg.exp_window)
    load_noise = hcfg.load_cell_noise_n * noise_scale

    if method == "linear":
        win_f = force_window(n_rec, fs, _force_window_length(hcfg, fs))
        return _linear_band(h_exact, 2 * np.pi * freq, n_rec, fs, sensors, hcfg, n_avg, win_f, win_e,
                            lines, load_noise, rng), 0, 0

    sub = substeps(op_sim, band_cfg)
    # without decimation there is no anti-aliasing filter to spread the onset: no pre-trigger (its
    # samples would only widen the force window and let more of the load cell's noise in)
    pre = PRETRIGGER if sub > 1 else 0
    n_step = min(n_rec, int(np.ceil(_decay_time(op_full, band, band_cfg.decay) * fs))) * sub
    hits = [[draw_hit(c, hcfg, rng) for c in coords] for _ in range(n_avg)]
    forces, resp = _hit_responses(op_sim, op_full, sensors, band, coords, hits, n_step, fs * sub,
                                  integrator_of(band_cfg))
    # anti-aliasing FIR and decimation to the DAQ rate, force and responses alike
    rec = _record(np.concatenate([forces[:, :, None], resp], axis=2), sub, n_rec, pre)
    win_f = force_window(n_rec, fs, _force_window_length(hcfg, fs) + pre / fs)
    sums = [SpectralSums(len(freq), 4) for _ in coords]
    overloads = 0
    for j in range(len(rec)):   # noise is drawn hit by hit, in the order of the hits
        k = j % len(coords)
        f_rec = hammer_gain * rec[j, :, 0] + load_noise * rng.standard_normal(n_rec)
        y_rec, over = _sensor_record(sensors, rec[j, :, 1:], rng)
        overloads += over
        f_win, y_win = f_rec * win_f * win_e, y_rec * win_e[:, None]
        if records is not None:
            records.append((k, f_win, y_win))
        sums[k].add(np.fft.rfft(f_win)[lines], np.fft.rfft(y_win, axis=0)[lines])
    return _receptance(sums, freq, sensors.kind == "accelerometer"), n_step * len(rec), overloads


def _hit_responses(op_sim, op_full, sensors: SensorSet, band, coords, hits, n_step: int, rate: float,
                   integrator: str) -> tuple[np.ndarray, np.ndarray]:
    """Every hit's force, (n_hit, n_step) N, and the sensors' response at the simulation rate
    ``rate`` (Hz), (n_hit, n_step, 4) in the sensors' quantity, hits in the order (average,
    coordinate)."""
    dt = 1.0 / rate
    t = np.arange(n_step) * dt
    read_sim = sensors.reading_rows(op_sim)
    flex, read_full = _condensation(op_sim, op_full, sensors)
    n_hit = len(coords) * len(hits)
    # a spinning spindle's unforced run rides along as the last history of the same rollout
    spinning = bool(op_sim.robot.spindle_rpm)
    qfrc = np.empty((n_hit + spinning, n_step, op_sim.robot.model.nv))
    qfrc[n_hit:] = 0.0
    forces = np.empty((n_hit, n_step))
    static = np.zeros((n_hit, 4))
    for a, hits_a in enumerate(hits):
        rows_sim = hammer_rows(op_sim, coords, band.s_1a, hits_a)
        rows_full = hammer_rows(op_full, coords, band.s_1a, hits_a) if flex is not None else None
        for k in range(len(coords)):
            j = a * len(coords) + k
            # each step holds the force's mean over the step: what the simulator applies and,
            # box-filtered, what the load cell records for the step's midpoint
            forces[j] = pulse(hits_a[k], t)
            qfrc[j] = forces[j][:, None] * rows_sim[k][None, :]
            if flex is not None:
                static[j] = read_full[:, flex] @ np.linalg.solve(
                    op_full.linear.K[np.ix_(flex, flex)], rows_full[k][flex])
    q0 = op_sim.data.qpos
    states = simulate(op_sim, qfrc, dt=dt, integrator=integrator)
    del qfrc
    drift = states[-1] - q0 if spinning else None   # the unforced run's motion, subtracted
    disp = np.empty((n_hit, n_step, 4))
    for j in range(n_hit):   # hit by hit: one history's arrays stay in the cache
        q = states[j] - drift if spinning else states[j]
        # the states are those at the end of each step; the force sample stands for the step's
        # midpoint, so the response is read there too (read at the end, it ran ω dt/2 ahead):
        # cubic interpolation between the states at the step's start and end
        mid = _midpoints(q, q0)
        mid -= q0
        disp[j] = mid @ read_sim.T + forces[j][:, None] * static[j][None, :]
    del states
    if sensors.kind != "accelerometer":
        return forces, disp
    resp = _second_derivative(disp, dt)
    if sensors.highpass > 0:
        b, a_ = signal.bilinear([1, 0], [1, 2 * np.pi * sensors.highpass], rate)
        resp = signal.lfilter(b, a_, resp, axis=-2)
    return forces, resp


def _sensor_record(sensors: SensorSet, y: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, int]:
    """The sensors' record of the true response ``y`` (n_rec, 4): gain, noise, quantisation and
    clipping at full range; and the number of overloaded samples."""
    y_rec = sensors.gain * y + sensors.noise * rng.standard_normal(y.shape)
    if sensors.resolution > 0:
        y_rec = np.round(y_rec / sensors.resolution) * sensors.resolution
    over = int((np.abs(y_rec) > sensors.full_range).sum())
    return np.clip(y_rec, -sensors.full_range, sensors.full_range), over


def _receptance(sums, freq: np.ndarray, accel: bool) -> tuple[np.ndarray, np.ndarray]:
    """H1 receptance and coherence per coordinate from the spectral sums, (n_lines, 4, n_coords)
    each (an accelerance divided by −ω²)."""
    omega = 2 * np.pi * freq
    h = np.empty((len(freq), 4, len(sums)), complex)
    coh = np.empty((len(freq), 4, len(sums)))
    for k, s in enumerate(sums):
        hk, ck = h1(s)
        h[:, :, k] = -hk / omega[:, None] ** 2 if accel else hk
        coh[:, :, k] = ck
    return h, coh


def integrator_of(band_cfg) -> str:
    """The band's integrator: ``auto`` is RK4 (error (ω dt)⁴ on the condensed models)."""
    return "rk4" if band_cfg.integrator == "auto" else band_cfg.integrator


def substeps(op_sim, band_cfg) -> int:
    """Simulation steps per DAQ sample: below the stability limit and fine enough for the band.

    Accuracy bounds ω·dt at f_max: 0.3 for RK4 (error ~(ω dt)⁴/120), 0.15 for Euler.
    """
    integrator = integrator_of(band_cfg)
    accuracy = (0.3 if integrator == "rk4" else 0.15) / (2 * np.pi * band_cfg.f_max)
    dt_max = min(stable_step(op_sim, integrator=integrator), accuracy)
    return int(np.ceil(1.0 / (band_cfg.sample_rate * dt_max)))


def _force_window_length(hcfg, fs: float) -> float:
    """Pulse (and double hit) with margin, and at least 32 samples: the anti-aliasing filter
    spreads a pulse of a few samples over its impulse response, which the window must keep."""
    extra = hcfg.double_hit_delay_ms if hcfg.double_hit_probability > 0 else 0.0
    return max(1e-3 * (3 * hcfg.pulse_ms + extra), 32 / fs)


def _decay_time(op, band, decay: float) -> float:
    """Time for the slowest mode in the band to decay to ``decay`` of its initial amplitude, s."""
    modes = op.linear.modes()
    in_band = (modes.f_n >= band.f_min) & (modes.f_n <= band.f_max)
    rate = np.min(-modes.poles.real[in_band]) if np.any(in_band) else 2 * np.pi * band.f_min * 0.01
    return float(np.log(1 / decay) / rate)


def _condensation(op_sim, op_full, sensors):
    """Freedoms of the full model missing from the simulated one, and the full model's reading rows."""
    if op_sim.linear.n_dof == op_full.linear.n_dof:
        return None, None
    kept = set(op_sim.linear.dof_names)
    flex = np.array([i for i, n in enumerate(op_full.linear.dof_names) if n not in kept])
    return flex, sensors.reading_rows(op_full)


def _midpoints(ends: np.ndarray, rest: np.ndarray) -> np.ndarray:
    """Values at the midpoints of the steps from those at their ends, shape like ``ends``.

    Four-point (cubic) interpolation, error of order (ω dt)⁴: the value at ``t_k + dt/2`` is
    ``(−y(t_{k−1}) + 9 y(t_k) + 9 y(t_{k+1}) − y(t_{k+2})) / 16``, with the structure at ``rest``
    up to ``t_0`` and the last value held past the end. ``ends`` has shape (..., n_step, n) (time
    on the second-last axis), ``rest`` shape (n,).
    """
    rest = np.broadcast_to(rest, ends.shape[:-2] + (1,) + ends.shape[-1:])
    y = np.concatenate([rest, rest, ends, ends[..., -1:, :]], axis=-2)   # y(t_{-1}), y(t_0), y(t_1) ...
    return _stencil(y, ((0, -1), (1, 9), (2, 9), (3, -1)), 16)


def _second_derivative(y: np.ndarray, dt: float) -> np.ndarray:
    """Second derivative of values ``y`` (deviations from rest, at the steps' midpoints) by the
    five-point stencil, error (ω dt)⁴/90: 0.009 % at the band's ω dt ≤ 0.3, where the central
    difference's (ω dt)²/12 took 0.75 % off an accelerometer's reading at f_max. Before the first
    midpoint the structure is at rest (the hit's force, and the acceleration with it, act from the
    first step on); past the last the last value is held. Time runs along the second-last axis."""
    rest = np.zeros_like(y[..., :2, :])
    last = y[..., -1:, :]
    y = np.concatenate([rest, y, last, last], axis=-2)
    return _stencil(y, ((4, -1), (3, 16), (2, -30), (1, 16), (0, -1)), 12 * dt**2)


def _stencil(y: np.ndarray, terms, denominator: float) -> np.ndarray:
    """``Σ c · y[k + offset] / denominator`` along the second-last axis, for ``(offset, c)`` in
    ``terms``, summed in their order (the written-out expression's roundoff) with two arrays of
    the result's size, where the expression makes one per operation."""
    n = y.shape[-2] - max(o for o, _ in terms)
    term = [y[..., o:o + n, :] for o, _ in terms]
    out = np.multiply(terms[0][1], term[0])
    tmp = np.empty_like(out)
    for (_, c), t in zip(terms[1:], term[1:]):
        out += np.multiply(c, t, out=tmp)
    out /= denominator
    return out


def _record(x: np.ndarray, sub: int, n_rec: int, pre: int = 0) -> np.ndarray:
    """Anti-alias, decimate by ``sub`` and pad with the structure at rest to ``n_rec`` samples,
    ``pre`` of them before the hit (``x`` starts at the hit, a deviation from rest).

    ``x`` has shape (n_hit, n_step, n_channel); each channel is filtered on its own. Returns
    shape (n_hit, n_rec, n_channel).
    """
    x = np.pad(x, ((0, 0), (pre * sub, 0), (0, 0)))
    y = signal.resample_poly(x, 1, sub, axis=1) if sub > 1 else x
    out = np.zeros((len(x), n_rec, x.shape[2]))
    m = min(n_rec, y.shape[1])
    out[:, :m] = y[:, :m]
    return out


def _linear_band(h_exact, omega, n_rec, fs, sensors, hcfg, n_avg, win_f, win_e, lines, load_noise, rng):
    """Exact as-tested FRF plus the noise an H1 estimate of the same test would carry."""
    t = np.arange(n_rec) / fs
    nominal = Hit(coordinate="1X", peak=hcfg.peak_n, duration=1e-3 * hcfg.pulse_ms)
    f_spec = np.fft.rfft(pulse(nominal, t) * win_f * win_e)[lines]
    # white noise of rms σ over n samples has E|N_k|² = n σ² per DFT line (before windowing)
    e_win = np.mean(win_e**2)
    s_nn = n_rec * sensors.noise**2 * e_win
    s_ff_noise = n_rec * load_noise**2 * np.mean((win_f * win_e) ** 2)
    to_reading = -(omega**2) if sensors.kind == "accelerometer" else np.ones_like(omega)
    h_read = h_exact * to_reading[:, None, None]
    sff = np.abs(f_spec) ** 2
    sigma_h = np.sqrt(s_nn / (n_avg * sff))[:, None, None]
    noise = sigma_h * (rng.standard_normal(h_exact.shape) + 1j * rng.standard_normal(h_exact.shape)) / np.sqrt(2)
    h_meas = (h_read + noise) / to_reading[:, None, None]
    signal_power = np.abs(h_read) ** 2 * sff[:, None, None]
    coh = signal_power / (signal_power + s_nn) * (sff / (sff + s_ff_noise))[:, None, None]
    return h_meas, coh
