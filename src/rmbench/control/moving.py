"""Vibration reduction on a moving robot: the arm follows a trajectory while a disturbance coil
shakes it, uncontrolled and with each controller, under the same force.

The force is band-limited random (to ``f_max``) by default, so the targeted mode is excited wherever
the arm is; or a given force history (a milling force, :func:`rmbench.stability.cutting_force`,
composed by the caller: control does not read stability), and the spindle may turn its eccentric
mass. Open loop and every controller get the same disturbance. Along the move, windows of ``window`` s (``hop`` s apart) give the acceleration energy within
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
# the per-controller figures read off each run's LoopRecord as they are
RECORD_FIGURES = ("saturated", "saturation_events", "stroke_used", "guard_trips", "realtime_factor")


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
                seed: int = 0, disturbance=None, spindle_hz: float | None = None,
                label: str | None = None) -> xr.Dataset:
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
    force_rms, f_max : float
        The random force's level, N rms, and band edge, Hz (``disturbance`` None or ``"random"``).
    disturbance : None, str, array_like or callable
        The disturbance coil's force on ``axis``: None or ``"random"`` (default) the band-limited
        random force; ``"none"`` no force (the eccentric mass alone, with ``spindle_hz``); an
        array of shape (n,), N, one value per controller sample of the run (n = duration · fs);
        or a function of time, (n,) s → (n,) N, evaluated once at the controller samples.
    spindle_hz : float, optional
        Spindle speed, rev/s, turning its eccentric mass in every run (None: held still).
    label : str, optional
        A description of the disturbance for the attrs (e.g. the cut a milling force came from).

    Returns
    -------
    xarray.Dataset
        Per window (``window``): ``t_mid`` s, ``q_mid`` (window, arm_joint) rad, ``f0`` Hz,
        ``energy`` (controller incl. ``"open"``, window); per controller: ``reduction`` over the
        move, ``transient`` (loudest 0.25 s / open-loop RMS, in the modes' band), ``saturated``,
        ``saturation_events`` (runs of samples at the force limit), ``stroke_used``,
        ``guard_trips`` (the stroke guard, :class:`Hardware`), ``realtime_factor``. Attrs name the
        ``disturbance`` (``"random"``, ``"force history"``, ``"force function"``, ``"none"``,
        with ``"+ eccentric"`` where the spindle turns), ``spindle_hz`` (0: held) and ``label``.
    """
    hw = hardware if hardware is not None else Hardware()
    if not controllers:
        raise InputError("moving_test needs at least one controller")
    duration = float(trajectory.t[-1])
    n = int(round(duration * hw.fs))
    win, step = int(window * hw.fs), int(hop * hw.fs)
    first = int(round(start * hw.fs))
    if n - first < win:
        raise InputError(f"the move lasts {duration - start:g} s after the start, shorter than one {window:g} s window")
    if spindle_hz is not None and not (np.isfinite(spindle_hz) and spindle_hz >= 0):
        raise InputError(f"spindle speed must be a finite rev/s ≥ 0, got {spindle_hz}")
    force, kind = _coil_force(disturbance, n, hw.fs, force_rms, f_max, seed)
    names = ["open"] + list(controllers)
    # one force array for every run: the open loop and each controller see the same disturbance
    recs = {name: run_loop(op, None if name == "open" else controllers[name], duration, hardware=hw,
                           shaker={axis: force}, spindle_hz=spindle_hz, record_axes=(axis,),
                           trajectory=trajectory, seed=seed)
            for name in names}
    ref = next(iter(controllers.values()))
    mode = mode_hz if mode_hz is not None else (lambda q: design_mode(ref, ref.axes.index(axis), q))
    starts = np.arange(first, n - win + 1, step)
    q_mid = np.array([recs["open"].q_arm[s0 + win // 2] for s0 in starts])
    f0 = np.array([mode(q) for q in q_mid])
    energy = np.array([_band_energy(recs[k].acc[:, 0], starts, win, f0, band, hw.fs) for k in names])
    transient, (lo, hi) = _transients(recs, f0, first, hw.fs)
    per = {"reduction": [1 - float(np.sqrt(e.sum() / energy[0].sum())) for e in energy],
           "transient": [transient[k] for k in names],
           **{key: [getattr(recs[k], key) for k in names] for key in RECORD_FIGURES}}
    return xr.Dataset(
        {"energy": (("controller", "window"), energy),
         "f0": ("window", f0), "q_mid": (("window", "arm_joint"), q_mid),
         **{key: ("controller", v) for key, v in per.items()}},
        coords={"controller": names, "window": np.arange(len(starts)), "t_mid": ("window", (starts + win // 2) / hw.fs),
                "arm_joint": np.arange(q_mid.shape[1])},
        attrs={"axis": axis, **({"force_rms_n": force_rms, "f_max_hz": f_max} if kind == "random" else {}),
               "disturbance": kind + (" + eccentric" if spindle_hz else ""),
               "spindle_hz": float(spindle_hz or 0.0), "label": label or kind, "band": band, "window_s": window,
               "controllers": ",".join(controllers), "modes_band_hz": [lo, hi]})


def _band_energy(acc: np.ndarray, starts: np.ndarray, win: int, f0: np.ndarray, band: float, fs: float) -> list:
    """The Hann-windowed energy of ``acc`` (n,) m/s² within ``±band·f0`` of each window's mode:
    windows of ``win`` samples from ``starts``, ``f0`` (window,) Hz."""
    hann = np.hanning(win)
    f = np.fft.rfftfreq(win, 1 / fs)
    return [float(np.sum(np.abs(np.fft.rfft(hann * acc[s0:s0 + win]))[np.abs(f - fm) <= band * fm] ** 2))
            for s0, fm in zip(starts, f0)]


def _transients(recs: dict, f0: np.ndarray, first: int, fs: float) -> tuple[dict, tuple[float, float]]:
    """Each run's loudest ``SHORT_S`` within the modes' band against the open loop's RMS there
    (``recs``: name → LoopRecord, ``"open"`` among them; ``f0`` the windows' modes, Hz; ``first``
    the first sample in the figures), and the band (lo, hi), Hz."""
    n, short = len(recs["open"].t), int(SHORT_S * fs)
    lo, hi = 0.6 * f0.min(), min(1.6 * f0.max(), 0.45 * fs)
    bp = signal.butter(4, [lo, hi], btype="band", fs=fs, output="sos")
    # filtered whole, then cut: the band-pass's own start-up would otherwise pass for a transient in
    # the first window (it did, at 1.38 of the open-loop level); the record's first and last
    # EDGE_S stay out for the same reason when the figures start at t = 0
    edge = int(EDGE_S * fs)
    lo_i, hi_i = max(first, edge), n - edge
    a = {k: signal.sosfiltfilt(bp, r.acc[:, 0])[lo_i:hi_i] for k, r in recs.items()}
    m = len(a["open"]) - len(a["open"]) % short
    open_rms = float(np.sqrt(np.mean(a["open"] ** 2)))
    return ({k: float(np.max(np.sqrt(np.mean(x[:m].reshape(-1, short) ** 2, axis=1)))) / open_rms
             for k, x in a.items()}, (lo, hi))


def _coil_force(disturbance, n: int, fs: float, force_rms: float, f_max: float, seed: int) -> tuple[np.ndarray, str]:
    """The disturbance coil's force per controller sample, shape (n,), N, and its kind
    (:func:`moving_test`'s ``disturbance``)."""
    if disturbance is None or (isinstance(disturbance, str) and disturbance == "random"):
        sos = signal.butter(4, f_max, fs=fs, output="sos")
        force = signal.sosfilt(sos, np.random.default_rng(seed).normal(0.0, 1.0, n))
        return force * (force_rms / force.std()), "random"
    if isinstance(disturbance, str):
        if disturbance != "none":
            raise InputError(f"unknown disturbance {disturbance!r}: 'random', 'none', a force array or a function of time")
        return np.zeros(n), "none"
    kind = "force function" if callable(disturbance) else "force history"
    force = np.asarray(disturbance(np.arange(n) / fs) if callable(disturbance) else disturbance, float)
    if force.shape != (n,):
        raise InputError(f"the disturbance force needs one value per controller sample, shape ({n},) N, "
                         f"got {force.shape}")
    if not np.isfinite(force).all():
        raise InputError("the disturbance force must be finite (N)")
    return force, kind


def moving_figures(ds: xr.Dataset, controller: str = "controlled") -> dict:
    """One controller's figures of a :func:`moving_test`: its ``reduction`` over the move,
    ``transient``, ``saturated``, ``saturation_events`` (None in a Dataset without them),
    ``stroke_used``, ``guard_trips``, ``realtime_factor``, and ``windows``: each window's middle
    ``t_s`` (s), ``mode_hz`` and reduction ``1 − √(E_controlled / E_open)``."""
    c = ds.sel(controller=controller)
    energy, open_ = ds.energy.sel(controller=controller).values, ds.energy.sel(controller="open").values
    return {"reduction": float(c.reduction), "transient": float(c.transient), "saturated": float(c.saturated),
            # None where the Dataset predates the count (a file written before it)
            "saturation_events": int(c.saturation_events) if "saturation_events" in ds else None,
            "stroke_used": float(c.stroke_used), "guard_trips": int(c.guard_trips),
            "realtime_factor": float(c.realtime_factor),
            "windows": [{"t_s": float(t), "mode_hz": float(f), "reduction": 1 - float(np.sqrt(energy[w] / open_[w]))}
                        for w, (t, f) in enumerate(zip(ds.t_mid.values, ds.f0.values))]}
