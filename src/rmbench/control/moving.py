"""Vibration reduction on a moving robot: the arm follows a trajectory while a disturbance coil
shakes it, uncontrolled and with each controller, under the same force.

The force is band-limited random (to ``f_max``), so the targeted mode is excited wherever the arm
is. Along the move, windows of ``window`` s (``hop`` s apart) give the acceleration energy within
``±band`` of the mode at the window's middle (its frequency from the controller's design record,
blended like the controllers, or from a function of the posture), and the reduction over the
move is ``1 − √(Σ E_closed / Σ E_open)``. Switching transients show as the loudest 0.25 s of the
closed loop within the modes' band against the open loop's level over the whole move.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from scipy import signal

from rmbench.control.closed_loop import Hardware, run_loop
from rmbench.control.controller import Controller
from rmbench.control.schedule import Schedule
from rmbench.control.trajectory import Trajectory
from rmbench.errors import InputError

__all__ = ["moving_test", "moving_figures", "design_mode"]

SHORT_S = 0.25  # s: the transient check's window
EDGE_S = 0.5  # s: kept out of the transient check at the record's ends (the band-pass's edges)


def design_mode(controller: Controller | Schedule, axis: int, q) -> float:
    """The mode (Hz) the controller was designed to damp on ``axis`` at arm posture ``q`` (rad)."""
    if isinstance(controller, Schedule):
        w = controller.weights(controller.variables(q))
        return float(sum(wi * c.meta["mode_hz"][axis] for wi, c in zip(w, controller.controllers) if wi > 0))
    modes = controller.meta.get("mode_hz")
    if not modes:
        raise InputError("the controller file records no design mode (mode_hz); redesign it with this rmbench")
    return float(modes[axis])


def moving_test(op, controllers: dict, trajectory: Trajectory, *, axis: str = "tangential",
                force_rms: float = 10.0, f_max: float = 40.0, window: float = 4.0, hop: float = 1.0,
                band: float = 0.25, start: float = 0.0, mode_hz=None, hardware: Hardware | None = None,
                seed: int = 0) -> xr.Dataset:
    """Run the move uncontrolled and with each controller; reduction window by window.

    Parameters
    ----------
    op : OperatingPoint
        The robot at the trajectory's first posture.
    controllers : dict
        ``{name: Controller or Schedule}``, each driving ``axis`` first.
    trajectory : Trajectory
    start : float
        Seconds at the beginning left out of the figures (a hold while the loop settles).
    mode_hz : callable, optional
        ``q -> Hz``, the mode at an arm posture; default: the first controller's design mode.

    Returns
    -------
    xarray.Dataset
        Per window (``window``): ``t_mid`` s, ``q_mid`` (window, arm_joint) rad, ``f0`` Hz,
        ``energy`` (controller incl. ``"open"``, window); per controller: ``reduction`` over the
        move, ``transient`` (loudest 0.25 s / open-loop RMS, in the modes' band), ``saturated``,
        ``stroke_used``, ``guard_trips`` (the stroke guard, :class:`Hardware`), ``realtime_factor``.
    """
    hw = hardware if hardware is not None else Hardware()
    if not controllers:
        raise InputError("moving_test needs at least one controller")
    duration = float(trajectory.t[-1])
    n = int(round(duration * hw.fs))
    win, step, short = int(window * hw.fs), int(hop * hw.fs), int(SHORT_S * hw.fs)
    first = int(round(start * hw.fs))
    if n - first < win:
        raise InputError(f"the move lasts {duration - start:g} s after the start, shorter than one {window:g} s window")
    sos = signal.butter(4, f_max, fs=hw.fs, output="sos")
    force = signal.sosfilt(sos, np.random.default_rng(seed).normal(0.0, 1.0, n))
    force *= force_rms / force.std()
    names = ["open"] + list(controllers)
    recs = {name: run_loop(op, None if name == "open" else controllers[name], duration, hardware=hw,
                           shaker={axis: force}, record_axes=(axis,), trajectory=trajectory, seed=seed)
            for name in names}
    ref = next(iter(controllers.values()))
    mode = mode_hz if mode_hz is not None else (lambda q: design_mode(ref, ref.axes.index(axis), q))
    hann = np.hanning(win)
    f = np.fft.rfftfreq(win, 1 / hw.fs)
    starts = np.arange(first, n - win + 1, step)
    q_mid = np.array([recs["open"].q_arm[s0 + win // 2] for s0 in starts])
    f0 = np.array([mode(q) for q in q_mid])
    energy = np.array([[float(np.sum(np.abs(np.fft.rfft(hann * recs[k].acc[s0:s0 + win, 0]))[np.abs(f - fm) <= band * fm] ** 2))
                        for s0, fm in zip(starts, f0)] for k in names])
    lo, hi = 0.6 * f0.min(), min(1.6 * f0.max(), 0.45 * hw.fs)
    bp = signal.butter(4, [lo, hi], btype="band", fs=hw.fs, output="sos")
    # filtered whole, then cut: the band-pass's own start-up would otherwise pass for a transient in
    # the first window (it did, at 1.38 of the open-loop level); the record's first and last
    # EDGE_S stay out for the same reason when the figures start at t = 0
    edge = int(EDGE_S * hw.fs)
    lo_i, hi_i = max(first, edge), n - edge
    a = {k: signal.sosfiltfilt(bp, recs[k].acc[:, 0])[lo_i:hi_i] for k in names}
    m = len(a["open"]) - len(a["open"]) % short
    open_rms = float(np.sqrt(np.mean(a["open"] ** 2)))
    per = {k: {"reduction": 1 - float(np.sqrt(energy[i].sum() / energy[0].sum())),
               "transient": float(np.max(np.sqrt(np.mean(a[k][:m].reshape(-1, short) ** 2, axis=1)))) / open_rms,
               "saturated": recs[k].saturated, "stroke_used": recs[k].stroke_used,
               "guard_trips": recs[k].guard_trips, "realtime_factor": recs[k].realtime_factor}
           for i, k in enumerate(names)}
    ctrl_names = list(controllers)
    return xr.Dataset(
        {"energy": (("controller", "window"), energy),
         "f0": ("window", f0), "q_mid": (("window", "arm_joint"), q_mid),
         **{key: ("controller", [per[k][key] for k in names])
            for key in ("reduction", "transient", "saturated", "stroke_used", "guard_trips", "realtime_factor")}},
        coords={"controller": names, "window": np.arange(len(starts)), "t_mid": ("window", (starts + win // 2) / hw.fs),
                "arm_joint": np.arange(q_mid.shape[1])},
        attrs={"axis": axis, "force_rms_n": force_rms, "f_max_hz": f_max, "band": band, "window_s": window,
               "controllers": ",".join(ctrl_names), "modes_band_hz": [lo, hi]})


def moving_figures(ds: xr.Dataset, controller: str = "controlled") -> dict:
    """One controller's figures of a :func:`moving_test`: its ``reduction`` over the move,
    ``transient``, ``saturated``, ``stroke_used``, ``guard_trips``, ``realtime_factor``, and
    ``windows``: each window's middle ``t_s`` (s), ``mode_hz`` and reduction
    ``1 − √(E_controlled / E_open)``."""
    c = ds.sel(controller=controller)
    energy, open_ = ds.energy.sel(controller=controller).values, ds.energy.sel(controller="open").values
    return {"reduction": float(c.reduction), "transient": float(c.transient), "saturated": float(c.saturated),
            "stroke_used": float(c.stroke_used), "guard_trips": int(c.guard_trips),
            "realtime_factor": float(c.realtime_factor),
            "windows": [{"t_s": float(t), "mode_hz": float(f), "reduction": 1 - float(np.sqrt(energy[w] / open_[w]))}
                        for w, (t, f) in enumerate(zip(ds.t_mid.values, ds.f0.values))]}
