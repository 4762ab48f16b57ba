"""Profiling helpers of the bench scripts: a callable's profile as text, and a campaign worker's
step rate against MuJoCo's raw RK4 on the same models, measured side by side in one process."""

from __future__ import annotations

import cProfile
import io
import pstats
import time

import numpy as np


def profile_top(fn, n: int = 12, *, sort: str = "cumulative") -> str:
    """The top ``n`` lines of ``fn()``'s cProfile, as text (its header line, then the table).

    ``sort`` is a :mod:`pstats` key: ``"cumulative"`` (time below each function: which call
    path costs it) or ``"tottime"`` (time in the function itself: where the time goes). Keep
    what ``fn`` returns through a closure if it is needed.
    """
    pr = cProfile.Profile()
    pr.enable()
    try:
        fn()
    finally:
        pr.disable()
    s = io.StringIO()
    pstats.Stats(pr, stream=s).sort_stats(sort).print_stats(n)
    lines = [ln for ln in s.getvalue().splitlines() if ln.strip()]
    start = next(i for i, ln in enumerate(lines) if ln.lstrip().startswith("ncalls"))
    total = next((ln.strip() for ln in lines if "function calls" in ln), "")
    return "\n".join([f"    {total}, sorted by {sort}"] + ["    " + ln for ln in lines[start:]])


def band_models(campaign, posture) -> dict[str, tuple]:
    """Per band: ``(op_sim, dt, steps)``: the operating point that a worker integrates at
    ``posture``, its time step (s) and the steps the posture simulates in that band."""
    from rmbench.impact.measure import _decay_time, substeps

    cfg = campaign.config
    op = campaign.operating_point(posture)
    hits = len(cfg.hits.points) * cfg.hits.averages
    out = {}
    for name, b in cfg.bands.items():
        op_t = campaign.tested_robots[name].at(op.q_cmd)
        op_sim = campaign.sim_robots[name].at(op.q_cmd)
        sub = substeps(op_sim, b)
        n_samp = min(int(round(b.sample_rate / b.line_spacing)),
                     int(np.ceil(_decay_time(op_t, campaign.bands[name], b.decay) * b.sample_rate)))
        out[name] = (op_sim, 1.0 / (b.sample_rate * sub), n_samp * sub * hits)
    return out


def raw_rk4_rate(op_sim, dt: float, *, n_steps: int = 20000, integrator: str = "rk4",
                 clock=time.perf_counter) -> float:
    """MuJoCo's bare ``mj_step`` rate on an operating point's model (steps/s): the integrator and
    flags of :func:`rmbench.robot.simulate.simulate`, from the equilibrium, one thread."""
    import mujoco

    from rmbench.robot.simulate import stepping_model

    m, d = stepping_model(op_sim, dt=dt, integrator=integrator)
    t0 = clock()
    for _ in range(n_steps):
        mujoco.mj_step(m, d)
    return n_steps / (clock() - t0)


def worker_vs_raw(campaign, postures, *, start: int = 0, clock=time.perf_counter) -> list[dict]:
    """A worker's steps/s against the raw RK4 rate on the same steps, posture by posture, in this
    process: for each posture the raw rate of each band's model is timed just before
    :func:`rmbench.impact.campaign.run_posture` runs it, so that both see the same machine.

    Returns one dict per posture: ``steps``, ``seconds`` (the posture's, by ``clock``),
    ``worker`` (steps/s), ``raw`` (steps/s over the posture's mix of bands: Σ steps / Σ band
    steps / band rate) and ``ratio`` (worker / raw). ``clock=time.thread_time`` counts CPU time
    only (what other processes on the core take is left out of both).
    """
    from rmbench.impact.campaign import run_posture

    rows = []
    for i, posture in enumerate(postures, start=start):
        bands = band_models(campaign, posture)
        t_raw = sum(steps / raw_rk4_rate(op_sim, dt, clock=clock) for op_sim, dt, steps in bands.values())
        steps = sum(s for _, _, s in bands.values())
        t0 = clock()
        res = run_posture(campaign, i, posture)
        seconds = clock() - t0
        if res["steps"] != steps:
            raise RuntimeError(f"posture {i}: {res['steps']} steps simulated, {steps} expected")
        rows.append({"steps": steps, "seconds": seconds, "worker": steps / seconds, "raw": steps / t_raw,
                     "ratio": t_raw / seconds})
    return rows


def simulator_share(fn, *, clock=time.thread_time) -> tuple[float, float]:
    """``fn()``'s time and the part of it spent inside MuJoCo's ``rollout`` (s, by ``clock``):
    the rest is the worker's own work (linearisation, exact FRFs, signal processing, Python)."""
    from mujoco import rollout

    inner = rollout.rollout
    spent = [0.0]

    def timed(*args, **kwargs):
        t0 = clock()
        try:
            return inner(*args, **kwargs)
        finally:
            spent[0] += clock() - t0

    rollout.rollout = timed
    try:
        t0 = clock()
        fn()
        total = clock() - t0
    finally:
        rollout.rollout = inner
    return total, spent[0]
