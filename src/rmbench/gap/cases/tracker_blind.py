"""Withheld-source check of the tracker diagnosis: hidden error sources drawn, diagnosed blind, scored.

Each case draws one hidden source (three cases in five), two or three at once (one in five), or a
source outside the library (one in five: backlash, a joint angle error whose sign follows the
direction the joint last moved in). The true robot is the tracker simulator's
(:class:`~rmbench.tracker.TrackerSimulator`: joint repeatability, tracker noise, the base at an
unknown place in the tracker frame) with only the drawn sources present, built here from the
simulator's own parameters (hidden offsets, placement twists, stiffness, payload, gear harmonics)
and, for thermal drift and backlash, from the readings' time and visiting order. The magnitude is
drawn large enough that the source moves the registered TCP by at least ``VISIBLE`` rms over the
configurations. The campaign reads ``n_config`` quasi-random configurations of the joint box twice,
in a random visiting order, 15 s apart; the diagnosis gets the joint commands, readings, their
noise and time stamps, and the nominal robot.

Scores per case: which hidden sources carry ≥ 10 % of the true error (the drop of the true
registered mean squared error when the source is taken out of the truth, normalised over the
sources) and whether the diagnosis chose each; sources it chose that were not there; its verdict;
the held-out shrink of the measured rms and of the true (noise-free) error; and the
model-invalidation accuracy level (METHODS.md §7) of the nominal and the updated model at the
held-out configurations beside their true maximum errors there and over the workspace.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from rmbench.gap.tracker.sources import PoseModel
from rmbench.gap.tracker.diagnosis import (TrackerData, TrackerSettings, default_covariance, default_sigma,
                                           diagnose_tracker)
from rmbench.io.strict_json import strict_dumps

__all__ = ["HiddenSource", "TrackerCase", "TrackerCaseOptions", "TrueRobot", "draw_sources", "run_tracker_case",
           "run_tracker_blind", "summarise_tracker", "VISIBLE"]

VISIBLE = 0.15e-3          # a hidden source moves the registered TCP by this much rms (m)
_PERIOD = 15.0             # s between readings
_OUT_KINDS = ("backlash",)


@dataclass(frozen=True)
class HiddenSource:
    """One hidden source: kind, location (the diagnosis's naming) and parameters (SI)."""

    kind: str
    location: str
    values: tuple

    @property
    def name(self) -> str:
        return f"{self.kind}@{self.location}"


@dataclass(frozen=True)
class TrackerCase:
    """The outcome of one blind case (JSON-friendly)."""

    index: int
    hidden: tuple
    in_library: bool
    verdict: str
    chosen: tuple
    confidences: dict
    shares: dict               # true share of the error per hidden source
    found: dict                # every hidden source → chosen?
    found_alike: dict          # the same, up to the look-alikes the diagnosis reported
    false_sources: tuple       # chosen but not hidden
    false_alike: tuple         # the same, up to look-alikes
    shrink_measured: float
    shrink_true: float
    heldout_before: dict
    heldout_after: dict
    level_before: float
    level_after: float
    true_max_before: float     # over the held-out configurations
    true_max_after: float
    workspace_max_before: float
    workspace_max_after: float
    seconds: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["hidden"] = [asdict(h) for h in self.hidden]
        return d


@dataclass(frozen=True)
class TrackerCaseOptions:
    """How one blind tracker case is read and scored (:func:`run_tracker_case`).

    Attributes
    ----------
    n_config : int
        Quasi-random configurations of the joint box.
    repeats : int
        Readings of each, in a random visiting order.
    kind : str or None
        ``"single"`` source, ``"out"`` of the library, or None (drawn: one, several, or out).
    settings : TrackerSettings
        The diagnosis's.
    n_workspace : int
        Configurations of the workspace the true maximum error is taken over.
    levels : bool
        Measure the model-invalidation accuracy levels (the slowest score).
    """

    n_config: int = 250
    repeats: int = 2
    kind: str | None = None
    settings: TrackerSettings = TrackerSettings()
    n_workspace: int = 20_000
    levels: bool = True


def draw_sources(rng: np.random.Generator, names, compliant, kind: str | None = None) -> tuple:
    """Hidden sources of one case (unit magnitudes; :func:`run_tracker_case` scales them up)."""
    u = rng.uniform()
    if kind == "out" or (kind is None and u < 0.2):
        j = int(rng.integers(1, len(names)))
        return (HiddenSource("backlash", names[j], (float(rng.uniform(60e-6, 150e-6)),)),)
    n = 1 if (kind == "single" or (kind is None and u < 0.8)) else int(rng.integers(2, 4))
    out, taken = [], set()
    while len(out) < n:
        h = _draw_one(rng, names, compliant)
        if h.name not in taken:
            taken.add(h.name)
            out.append(h)
    return tuple(out)


def _draw_one(rng, names, compliant) -> HiddenSource:
    kind = str(rng.choice(["joint_offset", "link_geometry", "gravity_compliance", "payload",
                           "gear_periodic_error", "frame_error", "thermal_drift"]))
    sign = lambda: float(rng.choice([-1.0, 1.0]))   # noqa: E731
    j = int(rng.integers(1, len(names)))             # j1's offset is the registration's
    if kind == "joint_offset":
        return HiddenSource(kind, names[j], (sign() * rng.uniform(2e-4, 1.5e-3),))
    if kind == "link_geometry":
        return HiddenSource(kind, names[j], (sign() * rng.uniform(0.3e-3, 1.5e-3),
                                             sign() * rng.uniform(2e-4, 1.5e-3)))
    if kind == "gravity_compliance":
        jc = int(rng.choice(compliant))
        return HiddenSource(kind, names[jc], (sign() * rng.uniform(0.3, 0.9),))
    if kind == "payload":
        return HiddenSource(kind, "tool", (float(rng.uniform(10.0, 40.0)),))
    if kind == "gear_periodic_error":
        h = int(rng.integers(1, 3))
        amp, phase = rng.uniform(60e-6, 250e-6), rng.uniform(0, 2 * np.pi)
        return HiddenSource(kind, f"{names[j]}:h{h}", (amp * np.cos(phase), amp * np.sin(phase)))
    if kind == "frame_error":
        v = rng.normal(size=3)
        return HiddenSource(kind, "tool", tuple(v / np.linalg.norm(v) * rng.uniform(0.5e-3, 2e-3)))
    return HiddenSource("thermal_drift", "time", (float(rng.uniform(2e-5, 6e-5)),))


class TrueRobot:
    """The true robot of a case: the tracker simulator with only the hidden sources.

    Parameters
    ----------
    robot : rmbench.robot.Robot
        The nominal robot.
    hidden : sequence of HiddenSource
    scale : float
        Factor on every hidden parameter.
    rng : numpy.random.Generator
    """

    def __init__(self, robot, hidden, scale: float, rng: np.random.Generator):
        from rmbench.tracker.chain import SerialChain
        from rmbench.tracker.repeatability import joint_sigma_for_rp
        from rmbench.tracker.simulator import (HiddenErrors, TrackerSimulator, TrackerSpec,
                                               reference_joints, nominal_stiffness)

        chain = SerialChain.from_kinematics(robot.kinematics, robot.arm_joints)
        n = chain.n_joint
        self.names = chain.names
        self.model = PoseModel(chain, 1.0 / nominal_stiffness(robot))
        self.hidden, self.scale = tuple(hidden), float(scale)
        k = nominal_stiffness(robot).copy()
        offsets = np.zeros(n)
        amp, phase = np.zeros((n, 2)), np.zeros((n, 2))
        tw_sources, tw_values = [], []
        payload = 0.0
        self.thermal = 0.0
        self.backlash = np.zeros(n)
        for h in self.hidden:
            v = np.asarray(h.values, float) * scale
            j = self.names.index(h.location.split(":")[0]) if h.location.split(":")[0] in self.names else -1
            if h.kind == "joint_offset":
                offsets[j] += v[0]
            elif h.kind == "gravity_compliance":
                k[j] = k[j] / (1.0 + v[0])
            elif h.kind == "payload":
                payload += v[0]
            elif h.kind == "gear_periodic_error":
                hh = int(h.location.split(":h")[1])
                amp[j, hh - 1] = np.hypot(v[0], v[1])
                phase[j, hh - 1] = np.arctan2(v[1], v[0])
            elif h.kind in ("link_geometry", "frame_error"):
                from rmbench.gap.tracker.sources import Source
                tw_sources.append(Source.of(h.kind, h.location, joint=j))
                tw_values.append(v)
            elif h.kind == "thermal_drift":
                self.thermal += v[0]
            elif h.kind == "backlash":
                self.backlash[j] += v[0]
        twists = self.model.twists(tw_sources, tw_values)
        hiddenerr = HiddenErrors(twists=twists, offsets=offsets, stiffness=k, mass_scale=np.ones(n),
                                 payload_mass=payload, gear_amplitude=amp, gear_phase=phase)
        true_chain = chain.perturbed(twists).with_payload(payload, chain.tool_translation)
        js = joint_sigma_for_rp(chain.jacobian(reference_joints(robot, n)), 0.2e-3)
        self.sim = TrackerSimulator(chain, true_chain, hiddenerr, TrackerSpec(), js)
        self.rng = rng

    def _backlash_angles(self, q, previous):
        return self.backlash * np.sign(q - previous)

    def positions(self, q, t, previous, *, noise: bool, rng=None) -> np.ndarray:
        """Readings (noise) or true positions (no noise) in the tracker frame, shape (n, 3), m."""
        sim = self.sim
        # backlash: the link lags the motor by b against the direction the joint last moved in
        extra = self._backlash_angles(q, previous)
        if noise:
            extra = extra + rng.normal(size=q.shape) * sim.joint_sigma
        p_base = sim.true_chain.position(sim.link_angles(q, extra))
        if self.thermal:
            p_base = p_base * (1.0 + self.thermal * np.asarray(t) / 3600.0)[:, None]
        rot, trans = sim.base_in_tracker
        p = p_base @ rot.T + trans
        if noise:
            p = p + rng.normal(size=p.shape) * sim.tracker.sigma(np.linalg.norm(p, axis=-1))[:, None]
        return p


def _registered_msd(model, truth_p, q, sources=(), values=()) -> float:
    """Mean squared distance of a model's positions to the truth after a rigid best fit, m²."""
    from rmbench.tracker.registration import kabsch

    p = model.positions(q, sources, values)
    rot, t = kabsch(p, truth_p)
    return float(np.mean(np.sum((truth_p - (p @ rot.T + t)) ** 2, axis=1)))


def run_tracker_case(index: int, seed: int, options: TrackerCaseOptions = TrackerCaseOptions(), *,
                     robot=None, **changes) -> TrackerCase:
    """Draw, simulate, diagnose and score blind case ``index`` of ``seed``: as ``options``
    (:class:`TrackerCaseOptions`) say, with any of its fields changed by keyword
    (``run_tracker_case(0, 1, n_config=120, levels=False)``), on ``robot`` (default: the MH180)."""
    from rmbench.robot import Robot
    from rmbench.tracker import MH180_JOINT_BOX, sobol_points
    from rmbench.tracker.simulator import nominal_stiffness

    opt = replace(options, **changes)
    t0 = time.perf_counter()
    robot = robot if robot is not None else Robot.load("mh180")
    rng = np.random.default_rng([seed, index, 14])
    names = tuple(robot.arm_joints)
    compliant = [j for j, k in enumerate(nominal_stiffness(robot)) if np.isfinite(k) and j > 0]
    hidden = draw_sources(rng, names, compliant, opt.kind)
    plan = _plan(rng, opt.n_config, opt.repeats)
    hidden = _visible(robot, hidden, rng, plan)
    truth = TrueRobot(robot, hidden, 1.0, rng)
    p_true = truth.positions(plan.q, plan.t, plan.previous, noise=False)
    y = truth.positions(plan.q, plan.t, plan.previous, noise=True, rng=rng)
    cov = default_covariance(robot, plan.q, y)
    data = TrackerData(plan.q, y, plan.order, np.sqrt(np.diagonal(cov, axis1=1, axis2=2)), plan.t, names,
                       covariance=cov)
    t1 = time.perf_counter()
    dg = diagnose_tracker(robot, data, settings=opt.settings)
    t2 = time.perf_counter()
    shares = _true_shares(truth, robot, hidden, plan.q, plan.t, plan.previous, p_true)
    qw = sobol_points(opt.n_workspace, *MH180_JOINT_BOX, np.random.default_rng([seed, index, 99]))
    errors = _true_errors(truth, dg, plan, p_true, qw)
    level_b = level_a = float("nan")
    if opt.levels:
        level_b, level_a = _levels(truth, robot, dg, plan, (seed, index))
    return TrackerCase(
        index=index, hidden=hidden, in_library=all(h.kind not in _OUT_KINDS for h in hidden),
        verdict=dg.verdict, confidences={s.name: s.confidence for s in dg.sources[:6]}, shares=shares,
        **_picks(dg, hidden), shrink_measured=dg.shrink, heldout_before=dg.heldout_before,
        heldout_after=dg.heldout_after, level_before=float(level_b), level_after=float(level_a), **errors,
        seconds={"simulate": t1 - t0, "diagnose": t2 - t1, "score": time.perf_counter() - t2})


@dataclass(frozen=True)
class _Plan:
    """A case's campaign: the configurations (n_config, n_joint), rad, the order they are read
    in (indices), the commands read (n, n_joint) and each one's predecessor, the times (n,), s."""

    q_conf: np.ndarray
    order: np.ndarray
    q: np.ndarray
    previous: np.ndarray
    t: np.ndarray


def _plan(rng, n_config: int, repeats: int) -> _Plan:
    """``n_config`` quasi-random configurations of the joint box, read ``repeats`` times in a
    random order, ``_PERIOD`` apart."""
    from rmbench.tracker import MH180_JOINT_BOX, sobol_points

    lo, hi = MH180_JOINT_BOX
    q_conf = sobol_points(n_config, lo, hi, rng)
    order = np.concatenate([rng.permutation(n_config) for _ in range(repeats)])
    q = q_conf[order]
    return _Plan(q_conf, order, q, np.vstack([q[:1], q[:-1]]), np.arange(len(q)) * _PERIOD)


def _visible(robot, hidden, rng, plan: _Plan) -> tuple:
    """The hidden sources scaled up until they move the registered TCP by ``VISIBLE`` rms."""
    scale = 1.0
    for _ in range(8):
        truth = TrueRobot(robot, hidden, scale, rng)
        p_true = truth.positions(plan.q, plan.t, plan.previous, noise=False)
        msd = _registered_msd(truth.model, p_true, plan.q)
        if np.sqrt(msd) >= VISIBLE:
            break
        scale *= max(1.25, 1.05 * VISIBLE / max(np.sqrt(msd), 1e-9))
    return tuple(HiddenSource(h.kind, h.location, tuple(float(v) * scale for v in h.values))
                 for h in hidden)


def _picks(dg, hidden) -> dict:
    """The diagnosis's chosen sources against the hidden ones: :class:`TrackerCase`'s ``chosen``,
    ``found``, ``found_alike``, ``false_sources`` and ``false_alike``."""
    chosen = tuple(s.name for s in dg.chosen)
    alike = {n: {m for g in dg.equivalent if n in g for m in g} | {n} for n in
             [h.name for h in hidden] + list(chosen)}
    hidden_names = {h.name for h in hidden}
    return {"chosen": chosen, "found": {h.name: h.name in chosen for h in hidden},
            "found_alike": {h.name: bool(alike[h.name] & set(chosen)) for h in hidden},
            "false_sources": tuple(c for c in chosen if c not in hidden_names),
            "false_alike": tuple(c for c in chosen if not (alike[c] & hidden_names))}


def _true_errors(truth, dg, plan: _Plan, p_true, qw) -> dict:
    """The true error of the nominal and the fitted model at the held-out configurations and at
    the workspace configurations ``qw``: :class:`TrackerCase`'s ``shrink_true``,
    ``true_max_before``/``after`` and ``workspace_max_before``/``after``."""
    q, t = plan.q, plan.t
    held = np.isin(plan.order, dg.held)
    hours = (t - t.min()) / 3600
    fitted = dg.fitted
    nominal_fit = dg.nominal_fitted
    err_b = p_true[held] - nominal_fit.position(q[held], hours[held])
    err_a = p_true[held] - fitted.position(q[held], hours[held])
    shrink_true = 1 - np.sqrt(np.mean(np.sum(err_a ** 2, 1)) / np.mean(np.sum(err_b ** 2, 1)))
    tw_ = np.full(len(qw), t.mean())
    pw = truth.positions(qw, tw_, qw, noise=False)
    ws_b = float(np.max(np.linalg.norm(pw - nominal_fit.position(qw, (tw_ - t.min()) / 3600), axis=1)))
    ws_a = float(np.max(np.linalg.norm(pw - fitted.position(qw, (tw_ - t.min()) / 3600), axis=1)))
    return {"shrink_true": float(shrink_true),
            "true_max_before": float(np.max(np.linalg.norm(err_b, axis=1))),
            "true_max_after": float(np.max(np.linalg.norm(err_a, axis=1))),
            "workspace_max_before": ws_b, "workspace_max_after": ws_a}


def _levels(truth, robot, dg, plan: _Plan, key: tuple) -> tuple:
    """The model-invalidation accuracy level (METHODS.md §7) of the nominal and the fitted model
    at the held-out configurations, measured anew on the true robot (random streams from ``key``,
    the case's ``(seed, index)``)."""
    from rmbench.tracker import accuracy_level

    q, t = plan.q, plan.t
    held = np.isin(plan.order, dg.held)
    q_held = plan.q_conf[np.unique(plan.order[held])]
    s_held = default_sigma(robot, q_held, truth.positions(q_held, np.zeros(len(q_held)), q_held,
                                                         noise=False))
    meas_rng = np.random.default_rng([*key, 7])

    def meter(model):
        last = {"q": q[-1:]}

        def measure(qj):
            # approached from the configuration measured before it (backlash)
            qj = np.asarray(qj, float)[None]
            p = truth.positions(qj, np.full(1, t.mean()), last["q"], noise=True, rng=meas_rng)
            last["q"] = qj
            return (p - model.position(qj, np.full(1, (t.mean() - t.min()) / 3600)))[0]
        return measure

    level_b = accuracy_level(meter(dg.nominal_fitted), q_held, s_held, 0.9, 10,
                             np.random.default_rng([*key, 8])).eta
    level_a = accuracy_level(meter(dg.fitted), q_held, s_held, 0.9, 10,
                             np.random.default_rng([*key, 8])).eta
    return level_b, level_a


def _true_shares(truth, robot, hidden, q, t, previous, p_true) -> dict:
    """Each hidden source's share of the true registered error (leave-one-out, normalised)."""
    if len(hidden) == 1:
        return {hidden[0].name: 1.0}
    full = _registered_msd(truth.model, p_true, q)
    drops = {}
    for h in hidden:
        rest = TrueRobot(robot, tuple(x for x in hidden if x is not h), 1.0, truth.rng)
        p_rest = rest.positions(q, t, previous, noise=False)
        drops[h.name] = max(full - _registered_msd(truth.model, p_rest, q), 0.0)
    total = sum(drops.values())
    return {k: (v / total if total > 0 else 0.0) for k, v in drops.items()}


def _case_dict(index: int, *, seed: int, **kw) -> dict:
    """One case of :func:`run_tracker_blind`, as the dict its JSON line holds."""
    return run_tracker_case(index, seed, **kw).to_dict()


def run_tracker_blind(cases: int, seed: int, *, out=None, progress=None, workers: int = 1,
                      scheduler: str | None = None, **kw) -> list:
    """Run cases ``0 .. cases-1``; with ``out`` (JSON lines) finished cases are kept and resumed.

    The cases run here one after the other, on ``workers`` local processes, or as tasks of the
    cluster of an existing dask scheduler (``scheduler``, its address); each is written as it
    finishes, and ``progress(index, case)`` called. ``kw`` goes to :func:`run_tracker_case`."""
    from functools import partial
    from pathlib import Path

    from rmbench.parallel import map_cases

    done = {}
    if out is not None and Path(out).exists():
        for line in Path(out).read_text().splitlines():
            if line.strip():
                d = json.loads(line)
                done[d["index"]] = d
    todo = [i for i in range(cases) if i not in done]
    for i, case in map_cases(partial(_case_dict, seed=seed, **kw), todo, workers=workers,
                             scheduler=scheduler):
        if out is not None:
            with open(out, "a") as f:
                f.write(strict_dumps(case) + "\n")
        done[i] = case
        if progress:
            progress(i, case)
    return [done[i] for i in range(cases)]


def summarise_tracker(cases) -> dict:
    """The check's figures from case dicts (see the module docstring)."""
    inl = [c for c in cases if c["in_library"]]
    out = [c for c in cases if not c["in_library"]]
    found = [v for c in inl for v in c["found"].values()]
    found_alike = [v for c in inl for v in c["found_alike"].values()]
    # the sources carrying at least a tenth of the true error (a small one beside a large one can
    # hide under the noise): reported beside the recall of every source
    major = [v for c in inl for k, v in c["found"].items() if c["shares"].get(k, 0.0) >= 0.1]
    n_chosen = sum(len(c["chosen"]) for c in inl)
    n_false = sum(len(c["false_sources"]) for c in inl)
    n_false_alike = sum(len(c["false_alike"]) for c in inl)
    return {
        "cases": len(cases), "in_library": len(inl), "out_of_library": len(out),
        "recall": float(np.mean(found)) if found else float("nan"), "recall_n": (int(sum(found)), len(found)),
        "recall_major": float(np.mean(major)) if major else float("nan"),
        "recall_major_n": (int(sum(major)), len(major)),
        "recall_alike": float(np.mean(found_alike)) if found_alike else float("nan"),
        "false_sources": n_false / n_chosen if n_chosen else 0.0, "false_n": (n_false, n_chosen),
        "false_alike": n_false_alike / n_chosen if n_chosen else 0.0,
        "median_shrink": float(np.median([c["shrink_true"] for c in inl])) if inl else float("nan"),
        "median_shrink_measured": float(np.median([c["shrink_measured"] for c in inl])) if inl else float("nan"),
        "unexplained_ok": float(np.mean([c["verdict"] == "unexplained" for c in out])) if out else float("nan"),
        "unexplained_n": (int(sum(c["verdict"] == "unexplained" for c in out)), len(out)),
        "explained_in_library": float(np.mean([c["verdict"] == "explained" for c in inl])) if inl else float("nan"),
    }
