"""The seed's suppression tests, run closed loop in MuJoCo (seed 004 Paper II §3.3-3.4).

- :func:`sine_sweep`: the disturbance voice coil of one axis drives a sine (20 N by default) at each
  frequency of a list; the acceleration at the excitation frequency over the force is the
  acceleration sensitivity (Fig. 9), uncontrolled or with a controller running.
- :func:`eccentric_test`: the spindle turns its eccentric mass at each speed of a list; the
  tangential and axial accelerations at the excitation frequency, over the eccentric force
  ``m e Ω²``, give each axis's sensitivity (Fig. 12).

- :func:`measure_accelerance` (one axis) and :func:`measure_accelerance_matrix` (every axis, one
  coil at a time): the seed's shaker test, a band-limited random force on the disturbance coil and
  the H1 estimate of the accelerance (averaged Hann-windowed segments,
  :mod:`rmbench.impact.estimate`); :func:`measured_plant` and :func:`measured_matrix_plant` fit the
  plant to it (:mod:`rmbench.control.identify`).

Each frequency is one steady-state run (settling, then an integer number of periods read by a
single-frequency DFT), and the runs go in parallel through :func:`rmbench.parallel.map_cases`
(local worker processes by default, ``scheduler`` the address of an existing dask scheduler).
Results are xarray Datasets; :func:`reduction_at` computes the seed's reduction figure from two of them.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from scipy import signal

from rmbench.control.closed_loop import Hardware, LoopDiverged, eccentric_force_amplitude, run_loop
from rmbench.control.controller import Controller
from rmbench.control.identify import plant_from_frf, plant_from_frf_matrix
from rmbench.control.plant import Plant, parse_axes, reaction_mass
from rmbench.errors import InputError
from rmbench.impact.estimate import SpectralSums, h1

__all__ = ["sine_sweep", "eccentric_test", "traced_runs", "excitation_frequencies", "reduction_at", "settle_time",
           "measure_accelerance", "measured_plant", "measure_accelerance_matrix", "measured_matrix_plant"]


def settle_time(zeta: float, f_n: float, *, decay: float = 0.01, floor: float = 2.0) -> float:
    """Time for a transient of a mode (ζ, f_n Hz) to decay to ``decay`` of its start, s."""
    return max(floor, float(np.log(1 / decay) / (max(zeta, 1e-3) * 2 * np.pi * f_n)))


def excitation_frequencies(modes, f_min: float = 2.0, f_max: float = 20.0, *, coarse: float = 1.0,
                     fine_fraction: float = 1 / 3) -> np.ndarray:
    """Excitation frequencies: a coarse grid plus a fine one across each mode's half-power band.

    Parameters
    ----------
    modes : sequence of (f_n Hz, ζ)
        The modes to resolve; near each, the spacing is ``fine_fraction`` of its half-power
        bandwidth ``2 ζ f_n`` over ``f_n (1 ± 3 ζ)``.
    """
    f = list(np.arange(f_min, f_max + 1e-9, coarse))
    for fn, z in modes:
        bw = 2 * z * fn
        f += list(np.arange(fn * (1 - 3 * z), fn * (1 + 3 * z) + 1e-9, fine_fraction * bw))
    f = np.unique(np.round(f, 4))
    return f[(f >= f_min) & (f <= f_max)]


def _steady_amplitude(t, x, f):
    """Complex amplitude of ``x`` at ``f`` Hz over the record (an integer number of periods)."""
    return 2.0 / len(t) * np.sum(x * np.exp(-2j * np.pi * f * t[:, None]), axis=0)


def _window(fs, f, settle, periods):
    n_per = max(periods, int(np.ceil(1.0 * f)))  # at least 1 s of data
    n_meas = int(round(n_per / f * fs))
    return settle + n_meas / fs, n_meas


def _steady_runs(task, before, after, op, controller, freqs, settle, periods, hardware, seed, workers,
                 scheduler, progress, what):
    """One steady-state run per frequency: ``task(xml, name, q, ctrl, *before, f, *after, settle,
    periods, hw, seed)``; returns the frequencies and the runs' result rows, in order."""
    hw = hardware if hardware is not None else Hardware()
    freqs = np.asarray(freqs, float)
    settle = _default_settle(op) if settle is None else settle
    tasks = [(task, (op.robot.xml, op.robot.name, op.q_cmd, controller, *before, float(f), *after, settle,
                     periods, hw, seed + i)) for i, f in enumerate(freqs)]
    return freqs, _run(tasks, workers, scheduler, progress, what)


def _steady_run(robot_xml, name, q, ctrl, f, settle, periods, hw, seed, **loop):
    """One closed-loop run to steady state at ``f`` Hz: the operating point, the record and the
    complex amplitude of the recorded accelerations at ``f``; or a failure row if it diverged."""
    op = _operating_point(robot_xml, name, q)
    duration, n_meas = _window(hw.fs, f, settle, periods)
    try:
        rec = run_loop(op, ctrl, duration, hardware=hw, seed=seed, **loop)
    except LoopDiverged as err:
        return op, None, {"f": f, "ok": False, "reason": str(err)}
    acc = _steady_amplitude(rec.t[-n_meas:], rec.acc[-n_meas:], f)
    row = {"f": f, "ok": True, "reason": "", "stroke": rec.stroke_used, "end_stop": rec.end_stop,
           "force": float(np.abs(rec.force).max(initial=0.0)), "saturated": rec.saturated,
           "rt": rec.realtime_factor}
    return op, acc, row


def _sine_task(robot_xml, name, q, ctrl, axis, f, amplitude, settle, periods, hw, seed):
    _, acc, row = _steady_run(robot_xml, name, q, ctrl, f, settle, periods, hw, seed, record_axes=(axis,),
                              shaker={axis: lambda t: amplitude * np.sin(2 * np.pi * f * t)})
    if acc is not None:
        # d on the robot is minus the coil force A sin ωt, i.e. the phasor +iA (cosine reference)
        row["acc"] = acc / (1j * amplitude)
    return row


def _ecc_task(robot_xml, name, q, ctrl, axes, f, settle, periods, hw, seed):
    op, acc, row = _steady_run(robot_xml, name, q, ctrl, f, settle, periods, hw, seed, record_axes=axes,
                               spindle_hz=f)
    if acc is not None:
        force = eccentric_force_amplitude(op.robot.model, f)
        row.update(acc=acc / force, acc_amp=np.abs(acc), ecc_force=force)
    return row


def sine_sweep(op, controller: Controller | None, axis: str, freqs, *, amplitude: float = 20.0,
               settle: float | None = None, periods: int = 5, hardware: Hardware | None = None,
               workers: int | None = None, scheduler: str | None = None, progress: bool = False,
               seed: int = 0) -> xr.Dataset:
    """Stepped-sine test with the axis's disturbance voice coil (seed Fig. 8-9).

    Returns
    -------
    xarray.Dataset
        ``sensitivity`` (freq) complex, m/s²/N; ``stroke_used``, ``end_stop`` (fraction of
        samples at a stop), ``force_max`` (N), ``saturated``, ``ok``, ``reason`` per frequency;
        attrs ``axis``, ``amplitude``.
    """
    freqs, rows = _steady_runs(_sine_task, (axis,), (amplitude,), op, controller, freqs, settle, periods,
                               hardware, seed, workers, scheduler, progress, "sweep")
    ds = _assemble(rows, freqs, (axis,), "sensitivity")
    ds.attrs.update(test="sine sweep", axis=axis, amplitude=amplitude, controlled=int(controller is not None))
    return ds


def eccentric_test(op, controller: Controller | None, speeds, *, axes=("tangential", "axial"),
                   settle: float | None = None, periods: int = 5, hardware: Hardware | None = None,
                   workers: int | None = None, scheduler: str | None = None, progress: bool = False,
                   seed: int = 0) -> xr.Dataset:
    """Eccentric-mass test: the spindle at each speed (rev/s), accelerations along ``axes``.

    Returns
    -------
    xarray.Dataset
        ``sensitivity`` (freq, axis) complex, m/s² per N of eccentric force (phase relative to
        the eccentric's angle); ``acceleration``
        (freq, axis) amplitude, m/s²; ``ecc_force`` (freq) N; per-run ``stroke_used``,
        ``force_max``, ``saturated``, ``ok``, ``reason``.
    """
    speeds, rows = _steady_runs(_ecc_task, (tuple(axes),), (), op, controller, speeds, settle, periods,
                                hardware, seed, workers, scheduler, progress, "eccentric")
    ds = _assemble(rows, speeds, tuple(axes), "sensitivity")
    ds["acceleration"] = (("freq", "axis"), np.array([r.get("acc_amp", np.full(len(axes), np.nan)) for r in rows]))
    ds["ecc_force"] = ("freq", np.array([r.get("ecc_force", np.nan) for r in rows]))
    ds.attrs.update(test="eccentric mass", controlled=int(controller is not None))
    return ds


def reduction_at(open_ds: xr.Dataset, closed_ds: xr.Dataset, axis: str, f0: float,
                 window: float = 0.25) -> float:
    """Seed's reduction: ``1 − controlled peak / uncontrolled peak`` of |sensitivity| near ``f0``."""
    from rmbench.control.analysis import reduction

    o = np.abs(open_ds.sensitivity.sel(axis=axis).values)
    c = np.abs(closed_ds.sensitivity.sel(axis=axis).values)
    return reduction(open_ds.freq.values, o, c, f0, window)


def traced_runs(op, ctrl: Controller, axis: str | None, f0: float, *, amplitude: float = 20.0,
                duration: float | None = None) -> dict:
    """Uncontrolled and controlled closed-loop runs at ``f0`` Hz, kept whole for their time traces.

    Parameters
    ----------
    op : OperatingPoint
    ctrl : Controller
    axis : str or None
        Axis of a sine of ``amplitude`` N; None: the eccentric mass spinning at ``f0``.
    duration : float, optional
        Seconds (default the longer of 2 s and 25 periods).

    Returns
    -------
    dict
        ``{"uncontrolled": LoopRecord, "controlled": LoopRecord}``; a run that diverged is left out.
    """
    duration = duration if duration is not None else max(2.0, 25.0 / f0)
    if axis is None:
        kw = {"spindle_hz": f0}
    else:
        kw = {"shaker": {axis: lambda t: amplitude * np.sin(2 * np.pi * f0 * t)}, "record_axes": (axis,)}
    out = {}
    for name, k in (("uncontrolled", None), ("controlled", ctrl)):
        try:
            out[name] = run_loop(op, k, duration, **kw)
        except LoopDiverged:
            pass                              # the sweep's table already reports the failed runs
    return out


def measure_accelerance(op, axis: str = "tangential", *, duration: float = 64.0, segment: float = 8.0,
                        force_rms: float = 10.0, f_max: float = 50.0, hardware: Hardware | None = None,
                        seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulated shaker test: random force on the axis's disturbance coil, H1 of ``a/d``.

    Returns
    -------
    freq : ndarray, Hz
    accelerance : ndarray, complex, m/s²/N (``d`` = force on the robot, minus the coil force)
    coherence : ndarray
    """
    hw = hardware if hardware is not None else Hardware()
    n = int(round(duration * hw.fs))
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, f_max, fs=hw.fs, output="sos")
    f_coil = signal.sosfilt(sos, rng.normal(0.0, 1.0, n))
    f_coil *= force_rms / np.std(f_coil)
    rec = run_loop(op, None, duration, hardware=hw, shaker={axis: f_coil}, record_axes=(axis,), seed=seed)
    acc = rec.acc[:, 0] + rng.normal(0.0, hw.acc_noise, n)
    d = -f_coil
    n_seg = int(round(segment * hw.fs))
    win = np.hanning(n_seg)
    freq = np.fft.rfftfreq(n_seg, 1 / hw.fs)
    sums = SpectralSums(len(freq), 1)
    start = n_seg  # the first segment holds the start-up transient
    for s0 in range(start, n - n_seg + 1, n_seg // 2):
        sums.add(np.fft.rfft(win * d[s0:s0 + n_seg]), np.fft.rfft(win * acc[s0:s0 + n_seg])[:, None])
    H, coh = h1(sums)
    keep = (freq > 0) & (freq <= f_max)
    return freq[keep], H[keep, 0], coh[keep, 0]


def measured_plant(op, axis: str = "tangential", *, single_mode: bool = False, **kwargs) -> Plant:
    """The plant of one axis from a simulated FRF measurement (the seed's path).

    ``single_mode=True``: the seed's one-mode model; default: every resonance in 2-40 Hz.
    ``kwargs`` go to :func:`measure_accelerance`.
    """
    freq, H, _ = measure_accelerance(op, axis, **kwargs)
    return plant_from_frf(freq, H, reaction_mass(op.robot.model, axis), axis=axis, single_mode=single_mode)


def measure_accelerance_matrix(op, axes=("tangential", "axial"), *, duration: float = 64.0, segment: float = 8.0,
                               force_rms: float = 10.0, f_max: float = 50.0, hardware: Hardware | None = None,
                               seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulated shaker tests, one axis's disturbance coil at a time, every axis recorded.

    Returns
    -------
    freq : ndarray, shape (n_freq,), Hz
    accelerance : ndarray, shape (n_freq, n, n), complex, m/s²/N (row measured, column excited)
    coherence : ndarray, shape (n_freq, n, n)
    """
    axes = parse_axes(axes)
    hw = hardware if hardware is not None else Hardware()
    n = int(round(duration * hw.fs))
    n_seg = int(round(segment * hw.fs))
    if n < 3 * n_seg:
        raise InputError(f"a {duration:g} s test holds fewer than three {segment:g} s segments")
    win = np.hanning(n_seg)
    freq = np.fft.rfftfreq(n_seg, 1 / hw.fs)
    keep = (freq > 0) & (freq <= f_max)
    H = np.zeros((int(keep.sum()), len(axes), len(axes)), complex)
    coh = np.zeros(H.shape)
    sos = signal.butter(4, f_max, fs=hw.fs, output="sos")
    for j, axis in enumerate(axes):
        rng = np.random.default_rng([seed, j])
        f_coil = signal.sosfilt(sos, rng.normal(0.0, 1.0, n))
        f_coil *= force_rms / np.std(f_coil)
        rec = run_loop(op, None, duration, hardware=hw, shaker={axis: f_coil}, record_axes=axes,
                       seed=seed + 7919 * (j + 1))
        acc = rec.acc + rng.normal(0.0, hw.acc_noise, rec.acc.shape)
        d = -f_coil
        sums = SpectralSums(len(freq), len(axes))
        for s0 in range(n_seg, n - n_seg + 1, n_seg // 2):  # the first segment holds the start-up transient
            sums.add(np.fft.rfft(win * d[s0:s0 + n_seg]), np.fft.rfft(win[:, None] * acc[s0:s0 + n_seg], axis=0))
        h, c = h1(sums)
        H[:, :, j], coh[:, :, j] = h[keep], c[keep]
    return freq[keep], H, coh


def measured_matrix_plant(op, axes=("tangential", "axial"), **kwargs) -> Plant:
    """The multi-axis plant from simulated shaker tests at ``op`` (:func:`measure_accelerance_matrix`,
    then :func:`plant_from_frf_matrix`); ``kwargs`` go to the measurement."""
    axes = parse_axes(axes)
    freq, H, _ = measure_accelerance_matrix(op, axes, **kwargs)
    return plant_from_frf_matrix(freq, H, [reaction_mass(op.robot.model, a) for a in axes], axes)


# -- helpers --------------------------------------------------------------------------------------
def _default_settle(op) -> float:
    """Settling time of the slowest lightly damped mode below 40 Hz, uncontrolled (upper bound)."""
    modes = op.linear.modes()
    sel = (modes.f_n > 2.0) & (modes.f_n < 40.0) & ~modes.real_pole
    if not np.any(sel):
        return 2.0
    return max(settle_time(z, f) for z, f in zip(modes.zeta[sel], modes.f_n[sel]))


def _operating_point(xml, name, q):
    from rmbench.robot import Robot

    return Robot(xml, name=name, tool=None).at(np.asarray(q, float))


def _assemble(rows, freqs, axes, var):
    n_ax = len(axes)
    sens = np.array([r["acc"] if r["ok"] else np.full(n_ax, np.nan + 0j) for r in rows]).reshape(len(rows), n_ax)
    ds = xr.Dataset(
        {var: (("freq", "axis"), sens),
         "stroke_used": ("freq", np.array([r.get("stroke", np.nan) for r in rows])),
         "end_stop": ("freq", np.array([r.get("end_stop", np.nan) for r in rows])),
         "force_max": ("freq", np.array([r.get("force", np.nan) for r in rows])),
         "saturated": ("freq", np.array([r.get("saturated", np.nan) for r in rows])),
         "realtime_factor": ("freq", np.array([r.get("rt", np.nan) for r in rows])),
         "ok": ("freq", np.array([r["ok"] for r in rows])),
         "reason": ("freq", np.array([r["reason"] for r in rows], dtype=object))},
        coords={"freq": np.asarray(freqs, float), "axis": list(axes)})
    ds.freq.attrs["units"] = "Hz"
    return ds


def _run(tasks, workers, scheduler, progress, what):
    """Run ``(fn, args)`` tasks through :func:`rmbench.parallel.map_cases`, results in task order:
    here (``workers`` 0 or 1), on local worker processes, or on the dask scheduler at ``scheduler``."""
    from tqdm import tqdm

    from rmbench.parallel import map_cases

    out = [None] * len(tasks)
    with tqdm(total=len(tasks), unit="run", desc=what, disable=not progress, dynamic_ncols=True) as bar:
        cases = [(i, fn, args) for i, (fn, args) in enumerate(tasks)]
        for (i, _, _), result in map_cases(_call, cases, workers=workers, scheduler=scheduler):
            out[i] = result   # the cases finish in any order
            bar.update(1)
    return out


def _call(case):
    _, fn, args = case
    return fn(*args)
