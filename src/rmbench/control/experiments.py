"""The seed's suppression tests, run closed loop in MuJoCo (seed 004 Paper II §3.3-3.4).

- :func:`sine_sweep`: the disturbance voice coil of one axis drives a sine (20 N by default) at each
  frequency of a list; the acceleration at the excitation frequency over the force is the
  acceleration sensitivity (Fig. 9), uncontrolled or with a controller running.
- :func:`eccentric_test`: the spindle turns its eccentric mass at each speed of a list; the
  tangential and axial accelerations at the excitation frequency, over the eccentric force
  ``m e Ω²``, give each axis's sensitivity (Fig. 12).

Each frequency is one steady-state run (settling, then an integer number of periods read by a
single-frequency DFT), and the runs go in parallel through dask.distributed (a local cluster by
default, ``scheduler`` an address or a dask Client for an existing one). Results are xarray Datasets; :func:`reduction_at`
computes the seed's reduction figure from two of them.
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
import xarray as xr

from rmbench.control.closed_loop import Hardware, LoopDiverged, eccentric_force_amplitude, run_loop
from rmbench.control.controller import Controller
from rmbench.threads import default_workers

__all__ = ["sine_sweep", "eccentric_test", "traced_runs", "excitation_frequencies", "reduction_at", "settle_time",
           "cluster"]


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


@contextmanager
def cluster(workers: int | None = None, scheduler=None):
    """A dask client: an existing one (``scheduler`` a Client), a scheduler address, or a local
    cluster of ``workers`` processes (default: the machine's cores); None for ``workers=0``."""
    if scheduler is not None and not isinstance(scheduler, str):
        yield scheduler
        return
    if scheduler is None and workers == 0:
        yield None
        return
    from dask.distributed import Client, LocalCluster

    local = None
    if scheduler is not None:
        client = Client(scheduler)
    else:
        # dask's nanny starts each worker with its BLAS and OpenMP pools at one thread
        local = LocalCluster(n_workers=workers or default_workers(), threads_per_worker=1,
                             processes=True, dashboard_address=None, silence_logs=50)
        client = Client(local)
    try:
        yield client
    finally:
        client.close()
        if local is not None:
            local.close()


def _run(tasks, workers, scheduler, progress, what):
    """Run ``(fn, args)`` tasks, results in task order: here (workers=0) or through dask."""
    from tqdm import tqdm

    with tqdm(total=len(tasks), unit="run", desc=what, disable=not progress, dynamic_ncols=True) as bar, \
            cluster(workers, scheduler) as client:
        if client is None:
            out = []
            for fn, args in tasks:
                out.append(fn(*args))
                bar.update(1)
            return out
        from dask.distributed import as_completed

        futures = [client.submit(fn, *args, pure=False) for fn, args in tasks]
        index = {f.key: i for i, f in enumerate(futures)}
        out = [None] * len(tasks)
        for fut in as_completed(futures):
            out[index[fut.key]] = fut.result()
            bar.update(1)
        return out


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
