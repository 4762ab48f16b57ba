"""Posture-scheduled proof-mass control on drawn robots, across six axes, certified on the sampled
loop (issue 83; issue 41 before it).

For each of ``--robots`` "real" MH180s (``truth/control.py``, plain MJCF edits: every ordinary
parameter drawn as the calibration bench draws them, a compliant foundation on every other one, and
two model-form errors of ``truth/form.py`` each, kinds ``i`` and ``i + 2`` of its six):

1. **Campaign**: simulated shaker tests (tangential and axial coils in turn, 64 s of band-limited
   random force each) at the 16 postures of a 4 × 4 grid over J2 −10…20° and J3 −10…30° (J5 keeps
   the spindle vertical), and at the reference posture.
2. **Design from the campaign only**: each posture's 2 × 2 accelerance fitted with real normal modes,
   a plant built on them, H∞ designs at every grid posture: a SISO
   tangential schedule and a MIMO tangential + axial one, all with the out-of-band weight on
   (``WEIGHTS``: k_o 5, k_a 60; the library's default has it off); the fixed single-posture controller is
   designed the same way at the reference posture. Each schedule declares where it vouches for its
   loop: 5° beyond the grid (``REACH_DEG``) and, for the unscheduled joints, J1 ±90°, J4 ±10°,
   J5 ±15° about its hold, J6 ±20° (``SPAN_DEG``). The design never reads the robot's exact model.
3. **Certificate** of the sampled-data loop (2 kHz, delay, hold, amplifier: ``Hardware()``) on the
   design plants, the grid and a 3× finer grid between them; and the MIMO schedule's robust
   certificate over ``ROBUST_DRAWS`` plants drawn from each grid posture's fit (``control.robust``);
   and both schedules' sampled loops on plants measured at the grid's four corners with the
   unscheduled joints the schedule vouches for turned: J1 ±45° (``SPAN_CHECK_DEG``), the wrist
   J4, J5, J6 at both ends of their span in all eight combinations (``WRIST_CHECK``), and J1 ±45° with
   each of those (8 + 32 + 64 more shaker tests), each loop's spectral radius at most ``SPAN_RHO_MAX``. Each schedule is redesigned with a
   higher out-of-band weight (``KO_LADDER``) until it passes its certificates (the single-axis one its
   sampled and span ones, the MIMO one these and its robust one; the weight each ends with is
   recorded). **The loop that runs** is the
   MIMO schedule where it passes all three, else the single-axis schedule with the axial coil open
   (as ``control design`` refuses an uncertified schedule); the MIMO rows score the loop that runs.
4. **Scored on the truth**: the real robot's exact linearisation at ``--postures`` quasi-random
   (Halton) postures across six axes inside the grid (J2, J3 in the grid's box, the other joints
   anywhere in the span) and ``--ring`` in the extrapolation ring (J2, J3 within the reach outside
   the box; every posture covered by the schedule: a refused one is counted). Per posture and
   controller: the sampled loop's spectral radius (the stability that counts), the continuous
   loop's, the reduction of the acceleration sensitivity peak within ±25 % of each axis's first
   strong mode (the seed's Fig. 9 figure), the largest amplification above twice the mode (dB),
   the full-band RMS ratio under a flat force over 1-40 Hz (the random force's band; 1-100 Hz beside it),
   the loop margin.
5. **Moving**: the arm moves across the grid (J2 −8 → 18°, J3 −8 → 28°, cosine profile, 12 s) in
   MuJoCo, uncontrolled, with the schedule (blended on the measured joint angles) and with the fixed
   controller, (a) under a band-limited random force of the tangential disturbance coil (10 N rms
   to 40 Hz, two realisations) and (b) under a milling force: a low-speed steel face-milling cut's
   force (the stability stage's cutting model, rigid tool, one tooth's runout) along the coil. The
   reduction is ``1 − √(Σ E_closed / Σ E_open)`` of the acceleration energy within ±25 % of the
   local mode in 4 s windows; switching transients as the loudest 0.25 s of the scheduled loop in
   the modes' band against the open loop's RMS there; saturation events counted.

Each robot's figures go to a JSON-lines file keyed by seed and code, so a killed run resumes.
Last line: one JSON object with issue 83's bench keys.

usage: python bench/control_schedule.py [--robots 10] [--postures 160] [--ring 48] [--seed S]
"""

from __future__ import annotations

import argparse
import itertools
import json
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.stats import qmc  # noqa: E402

from _stats import keyed_run, open_lines, wilson  # noqa: E402
from truth.control import draw_mh180_form  # noqa: E402
from truth.form import FORM_KINDS  # noqa: E402
from rmbench.control import Weights, design, is_stable, sensitivity  # noqa: E402
from rmbench.control.controller import Controller  # noqa: E402
from rmbench.control.analysis import amplification_db, fullband_ratio  # noqa: E402
from rmbench.control.closed_loop import Hardware  # noqa: E402
from rmbench.control.experiments import measured_matrix_plant  # noqa: E402
from rmbench.control.moving import moving_test  # noqa: E402
from rmbench.control.plant import first_strong_mode, robot_plant  # noqa: E402
from rmbench.control.robust import certify_schedule_robust, measured_modes  # noqa: E402
from rmbench.control.sampled import sampled_radius  # noqa: E402
from rmbench.control.schedule import certify, design_schedule, grid_posture, loop_margin  # noqa: E402
from rmbench.control.trajectory import linear_move  # noqa: E402
from rmbench.robot.model import Robot  # noqa: E402
from rmbench.robot.suppressor import reference_q  # noqa: E402
from rmbench.stability import STEEL_C45, cutting_force  # noqa: E402

AXES = ("tangential", "axial")
JOINTS, HOLD = (1, 2), 4  # J2 and J3 scheduled, J5 keeps the spindle vertical
GRID_DEG = ((-10.0, 0.0, 10.0, 20.0), tuple(np.linspace(-10.0, 30.0, 4)))
REACH_DEG = 5.0
SPAN_DEG = {0: 90.0, 3: 10.0, 4: 15.0, 5: 20.0}  # arm joint index: ± degrees about the schedule's posture
WINDOW = 0.25  # the mode's ±25 %: where the reduction is read
DISTURBANCE_N = 10.0
FREQ = np.geomspace(1.0, 100.0, 700)
FULL = np.linspace(1.0, 40.0, 800)  # Hz: the broadband force's band (the moving test's random force)
# the out-of-band weight on (issue 83 item 5): the force's high-pass above 2 f0, and a higher weight
# at the mode to keep its reduction. k_o 3 (k_a 50), chosen on seed 4183's drawn robots, left 7
# single-axis postures of seed 45410 unstable on the sampled loop: the wrist turned (J4, J6) puts a
# 9-11 Hz mode, near 2 f0, into the tangential coil; redesigned with k_o 5 (k_a 60) none of them is,
# for 0.5-1.6 points of reduction at the mode
WEIGHTS = Weights(k_o=5.0, k_a=60.0)
MOVE_DEG = ((-8.0, -8.0), (18.0, 28.0))
MOVE_S, HOLD_S = 12.0, 2.0
WIN_S, HOP_S = 4.0, 1.0
# the milling disturbance: steel (STEEL_C45: 6 teeth at half immersion) at low speed, the spindle
# (6 rev/s) near the tangential mode with 10 µm of runout on one tooth
MILL = {"rpm": 360.0, "depth": 0.5e-3, "feed_per_tooth": 0.1e-3, "runout": 10e-6}
HW = Hardware()
ROBUST_DRAWS = 20  # plants drawn from each grid posture's fit for the MIMO schedule's robust certificate
# J1 is not scheduled, yet each schedule vouches for it over ±90°: on a skewed foundation J1 turns the
# arm against the skew and moves an axial mode (seed 5498 robot 5: 9.4-10.7 Hz over J1, fitted 9.95 Hz
# at J1 0), which no design plant shows and the MIMO loop was unstable for J1 +25...+70°. So the
# campaign also measures the grid's four corners with J1 turned by these, and the loops are certified there
SPAN_CHECK_DEG = (-45.0, 45.0)
# nor is the wrist scheduled, yet each schedule vouches for J4 ±10°, J5 ±15°, J6 ±20°: turned (J4 +,
# J5 −, J6 +) it moves a 10.6-11.2 Hz mode near 2 f0 into the tangential coil (seed 64563 robot 8:
# 3 single-axis postures unstable on the sampled loop, none with the wrist at its hold). So the grid's
# corners are also measured with the wrist at the span's ends, all eight sign combinations
WRIST_CHECK = (3, 4, 5)
# a span plant passes with the sampled loop's decay rate at least 0.2 /s (−fs ln ρ): the corners do
# not test the schedule's inner controllers (seed 64563 robot 8 with k_o 8: corners at most 0.99999,
# the truth at an inner grid posture with the wrist turned 1.00001; with k_o 10: 0.99980 and 0.99988)
SPAN_RHO_MAX = 0.9999
# the single-axis schedule's out-of-band weight (k_o, WEIGHTS' k_a kept), raised until it passes its
# certificates: only the robots whose span plants need it pay its reduction (robot 8: k_o 10,
# median at the mode 91.7 -> 90.4 %)
KO_LADDER = (5.0, 6.0, 7.0, 8.0, 10.0, 12.0, 15.0, 20.0)
# the axial coil left open: where the MIMO schedule fails a certificate, the loop that runs is the
# single-axis schedule (a certified loop), as `control design` refuses the uncertified one
IDLE_AXIAL = Controller(AXES[1:], np.zeros((0, 0)), np.zeros((0, 2)), np.zeros((1, 0)), np.zeros((1, 2)),
                        {"structure": "open"})


def span_rad(n_arm: int) -> tuple[float, ...]:
    return tuple(float(np.radians(SPAN_DEG.get(j, 0.0))) for j in range(n_arm))


def span_postures(q_ref, grid) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """``(kind, s, q)`` of the span plants at the grid's four corners: J1 turned by ``SPAN_CHECK_DEG``
    (kind ``"j1"``), the wrist (``WRIST_CHECK``) at the ends of its span in every sign combination
    (kind ``"wrist"``), and both together (kind ``"j1_wrist"``: seed 79513's robot 5 was unstable with
    J1 and J4 turned together and stable with either alone)."""
    corners = [np.array(s) for s in itertools.product(*((g[0], g[-1]) for g in grid))]
    wrist = list(itertools.product((-1, 1), repeat=len(WRIST_CHECK)))
    out = []
    for kind, j1s, signs in (("j1", SPAN_CHECK_DEG, [None]), ("wrist", (0.0,), wrist),
                             ("j1_wrist", SPAN_CHECK_DEG, wrist)):
        for s, d, sg in itertools.product(corners, j1s, signs):
            q = grid_posture(q_ref, JOINTS, s, HOLD)
            q[0] += np.radians(d)
            for j, v in zip(WRIST_CHECK, sg or ()):
                q[j] += v * np.radians(SPAN_DEG[j])
            out.append((kind, s, q))
    return out


def span_plants(real, q_ref, grid, seed: int) -> list[tuple[str, np.ndarray, object]]:
    """``(kind, s, plant)``: the span postures' (:func:`span_postures`) plants, measured."""
    seeds = {"j1": seed + 200, "wrist": seed + 300, "j1_wrist": seed + 400}
    count = dict.fromkeys(seeds, 0)
    out = []
    for kind, s, q in span_postures(q_ref, grid):
        out.append((kind, s, measured_matrix_plant(real.at(q), AXES, seed=int(seeds[kind] + count[kind]))))
        count[kind] += 1
    return out


def span_certificate(points, schedules: dict) -> dict:
    """The sampled loop's largest spectral radius of each of ``schedules`` (``{name: (schedule,
    axes)}``) on the span plants ``points`` (:func:`span_plants`), per kind (the schedule's controller
    at the corner: the joints turned are not scheduled)."""
    rho = {name: {} for name in schedules}
    for kind, s, p in points:
        for name, (sch, axes) in schedules.items():
            plant = p if tuple(axes) == AXES else p.select(axes)
            r = float(sampled_radius(plant, sch.at(s), HW))
            rho[name][kind] = max(rho[name].get(kind, 0.0), r)
    return rho


def span_passes(rho: dict) -> bool:
    return max(rho.values()) <= SPAN_RHO_MAX


def certified(plants, grid, q_ref, limits, points, *, mimo: bool, robust=None):
    """The schedule over ``plants`` (single-axis, or ``mimo``) with the lowest ``KO_LADDER`` weight
    whose certificates pass: sampled on the design plants, span (``points``) and, where given,
    ``robust(schedule)`` (the last one tried where none does). Returns the schedule, its sampled
    certificate, span radii, k_o and the robust certificate (None without ``robust``)."""
    axes = AXES if mimo else AXES[:1]
    for k_o in KO_LADDER:
        sch = design_schedule(plants, grid, JOINTS, q_ref, hold=HOLD, mimo=mimo,
                              **dict(limits, weights=WEIGHTS.with_(k_o=k_o)))
        cert = certify(sch, plants, hardware=HW)
        span = span_certificate(points, {"s": (sch, axes)})["s"]
        rob = None
        if cert.stable and span_passes(span):
            rob = None if robust is None else robust(sch)
            if rob is None or rob.stable:
                break
    return sch, cert, span, k_o, rob


def postures(q_ref, n: int, seed: int, ring: bool) -> np.ndarray:
    """Arm postures (n, 6), rad: J2, J3 in the grid's box (or, ``ring``, in the reach outside it),
    the other joints anywhere within the span about the schedule's posture (Halton, scrambled)."""
    lo_in, hi_in = np.array([g[0] for g in GRID_DEG]), np.array([g[-1] for g in GRID_DEG])
    lo, hi = (lo_in - REACH_DEG, hi_in + REACH_DEG) if ring else (lo_in, hi_in)
    free = [j for j in range(6) if j not in JOINTS]
    halton = qmc.Halton(2 + len(free), seed=seed)
    out = []
    while len(out) < n:
        u = halton.random(1)[0]
        s = lo + u[:2] * (hi - lo)
        if ring and np.all((s >= lo_in) & (s <= hi_in)):
            continue  # the ring is outside the box: a geometric rule, not the method's choice
        q = grid_posture(q_ref, JOINTS, np.radians(s), HOLD)
        for k, j in enumerate(free):
            q[j] += np.radians(SPAN_DEG.get(j, 0.0)) * (2 * u[2 + k] - 1)
        out.append(q)
    return np.array(out)


def score(plant, ctrl, f0s, open_resp):
    """Sampled and continuous stability; reduction per axis, amplification above 2 f0 (dB),
    full-band RMS ratio, stroke (m) and force (N) per N, loop margin."""
    out = {"rho": float(sampled_radius(plant, ctrl, HW)), "stable": bool(is_stable(plant, ctrl))}
    if not out["stable"] or out["rho"] >= 1:
        return out
    r = sensitivity(plant, ctrl, FREQ)
    out.update(reduction=[], amp_db=[], stroke_m_per_n=[], force_n_per_n=[])
    for i, f0 in enumerate(f0s):
        o, c = np.abs(open_resp[:, i, i]), np.abs(r["acc"][:, i, i])
        out["reduction"].append(1 - peak_in(FREQ, c, f0) / peak_in(FREQ, o, f0))
        out["amp_db"].append(amplification_db(FREQ, o, c, f0))
        out["stroke_m_per_n"].append(float(np.max(np.abs(r["pos"][:, i, i]))))
        out["force_n_per_n"].append(float(np.max(np.abs(r["force"][:, i, i]))))
    out["fullband"] = [float(v) for v in np.atleast_1d(fullband_ratio(plant, ctrl, FULL))]
    out["fullband_100"] = [float(v) for v in np.atleast_1d(fullband_ratio(plant, ctrl, FREQ))]
    out["margin"] = loop_margin(plant, ctrl, FREQ)
    return out


def peak_in(f, mag, f0):
    return float(np.max(mag[np.abs(f - f0) <= WINDOW * f0]))


def band_ratio(plant, ctrl, f0):
    """Linear closed-to-open ratio of the acceleration energy within ±WINDOW of f0 (flat force)."""
    f = np.linspace((1 - WINDOW) * f0, (1 + WINDOW) * f0, 200)
    o = np.abs(sensitivity(plant, None, f)["acc"][:, 0, 0])
    c = np.abs(sensitivity(plant, ctrl, f)["acc"][:, 0, 0])
    return float(np.sum(c**2) / np.sum(o**2))


def milling_force(duration: float) -> np.ndarray:
    """The coil force per controller sample, N: the cutting force's feed component, its mean
    taken out (the arm's servos hold a steady load; the coil meets what varies)."""
    t = np.arange(int(round(duration * HW.fs))) / HW.fs
    f = cutting_force(STEEL_C45, MILL["rpm"], MILL["depth"], t, feed_per_tooth=MILL["feed_per_tooth"],
                      runout=MILL["runout"])[:, 0]
    return f - f.mean()


def moving(real, q_ref, sch, fixed, seed) -> dict:
    """Section 5 of the module docstring, for one robot."""
    q0, q1 = (grid_posture(q_ref, JOINTS, np.radians(s), HOLD) for s in MOVE_DEG)
    traj = linear_move(q0, q1, MOVE_S, hold=HOLD_S)
    op = real.at(q0)

    def truth_plant(q):
        return robot_plant(real.at(q), AXES[:1])

    runs = [("random", {"seed": seed + rep}) for rep in range(2)]
    runs.append(("milling", {"seed": seed + 7, "disturbance": milling_force(float(traj.t[-1]))}))
    out = {}
    for kind, kw in runs:
        ds = moving_test(op, {"scheduled": sch, "fixed": fixed}, traj, start=HOLD_S, window=WIN_S, hop=HOP_S,
                         band=WINDOW, mode_hz=lambda q: first_strong_mode(truth_plant(q), 0), **kw)
        o = out.setdefault(kind, {"energy": {"open": 0.0, "scheduled": 0.0, "fixed": 0.0, "static_scheduled": 0.0,
                                             "static_fixed": 0.0},
                                  "realtime_factor": [], "saturated": 0.0, "stroke_used": 0.0, "transient_ratio": 0.0,
                                  "guard_trips": 0, "saturation_events": 0, "fixed_transient_ratio": []})
        e = o["energy"]
        for k in ("open", "scheduled", "fixed"):
            e[k] += float(ds.energy.sel(controller=k).sum())
        for w in ds.window.values:
            q = ds.q_mid.values[w]
            plant, f0, e_open = truth_plant(q), float(ds.f0.values[w]), float(ds.energy.sel(controller="open")[w])
            e["static_scheduled"] += e_open * band_ratio(plant, sch.at(q[list(JOINTS)]), f0)
            e["static_fixed"] += e_open * band_ratio(plant, fixed, f0)
        sc = ds.sel(controller="scheduled")
        o["realtime_factor"].append(float(sc.realtime_factor))
        o["saturated"] = max(o["saturated"], float(sc.saturated))
        o["stroke_used"] = max(o["stroke_used"], float(sc.stroke_used))
        o["guard_trips"] += int(sc.guard_trips)
        o["saturation_events"] += int(sc.saturation_events)
        o["transient_ratio"] = max(o["transient_ratio"], float(sc.transient))
        o["fixed_transient_ratio"].append(float(ds.transient.sel(controller="fixed")))
    for o in out.values():
        e = o.pop("energy")
        for k in ("scheduled", "fixed", "static_scheduled", "static_fixed"):
            o[k] = 1 - float(np.sqrt(e[k] / e["open"]))
        o["realtime_factor"] = float(np.min(o["realtime_factor"]))
    return out


def run_robot(i: int, seed: int, n_in: int, n_ring: int) -> dict:
    rng = np.random.default_rng([seed, i])
    nominal = Robot.load("mh180")
    kinds = (FORM_KINDS[i % len(FORM_KINDS)], FORM_KINDS[(i + 2) % len(FORM_KINDS)])
    xml, truth = draw_mh180_form(nominal.xml, rng, base=bool(i % 2), kinds=kinds)
    real = Robot(xml, name=f"real{i}", tool=None)
    q_ref = reference_q(nominal)
    grid = tuple(np.radians(g) for g in GRID_DEG)
    S = np.stack([m.ravel() for m in np.meshgrid(*grid, indexing="ij")], axis=1)
    t0 = time.perf_counter()
    plants = [measured_matrix_plant(real.at(grid_posture(q_ref, JOINTS, s, HOLD)), AXES, seed=int(seed + k))
              for k, s in enumerate(S)]
    p_ref = measured_matrix_plant(real.at(q_ref), AXES, seed=seed + 99)
    t_measure = time.perf_counter() - t0

    limits = {"reach": (np.radians(REACH_DEG),) * len(JOINTS), "span": span_rad(len(q_ref)), "weights": WEIGHTS}
    t0 = time.perf_counter()
    points = span_plants(real, q_ref, grid, seed)
    t_span = time.perf_counter() - t0
    t0 = time.perf_counter()
    single = [p.select(AXES[:1]) for p in plants]
    sch_single, cert_single, span_single, k_o_single, _ = certified(single, grid, q_ref, limits, points, mimo=False)
    t_single = time.perf_counter() - t0
    t0 = time.perf_counter()
    fixed_single = design(p_ref.select(AXES[:1]), WEIGHTS, order=12, mode_hz=[first_strong_mode(p_ref, 0)]).controller
    modes = [measured_modes(p) for p in plants]

    def robust_of(sch):
        return certify_schedule_robust(sch, [m[0] for m in modes], modes[0][1], HW, draws=ROBUST_DRAWS,
                                       seed=int(seed + i))

    # the MIMO schedule climbs the same ladder, its robust certificate part of each rung's test
    sch_mimo, cert_mimo, span_mimo, k_o_mimo, robust = certified(plants, grid, q_ref, limits, points, mimo=True,
                                                                 robust=robust_of)
    if robust is None:      # no rung passed its sampled and span certificates: the last one's, for the record
        robust = robust_of(sch_mimo)
    t_mimo = time.perf_counter() - t0
    cert = {"single": cert_single, "mimo": cert_mimo}
    span = {"single": span_single, "mimo": span_mimo}
    # the loop that runs: the MIMO schedule where it passes every certificate, else the single-axis one
    mimo_runs = bool(cert["mimo"].stable and robust.stable and span_passes(span["mimo"]))

    def running(s):
        return sch_mimo.at(s) if mimo_runs else Controller.block_diagonal([sch_single.at(s), IDLE_AXIAL])

    rows, refused = [], 0
    t0 = time.perf_counter()
    draw_seed = int(rng.integers(2**31))
    for where, Q in (("in", postures(q_ref, n_in, draw_seed, False)), ("ring", postures(q_ref, n_ring, draw_seed + 1, True))):
        for q in Q:
            if sch_single.refusal(q) is not None or sch_mimo.refusal(q) is not None:
                refused += 1
                continue
            truth_plant = robot_plant(real.at(q), AXES)
            f0s = [first_strong_mode(truth_plant, k) for k in range(2)]
            open_mimo = sensitivity(truth_plant, None, FREQ)["acc"]
            s = q[list(JOINTS)]
            one = truth_plant.select(AXES[:1])
            rows.append({"where": where, "q_deg": np.degrees(q).round(3).tolist(), "f0_hz": f0s,
                         "single": score(one, sch_single.at(s), f0s[:1], open_mimo[:, :1, :1]),
                         "fixed_single": score(one, fixed_single, f0s[:1], open_mimo[:, :1, :1]),
                         "mimo": score(truth_plant, running(s), f0s, open_mimo)})
    t_score = time.perf_counter() - t0
    t0 = time.perf_counter()
    path = moving(real, q_ref, sch_single, fixed_single, seed + 1000 * i)
    t_path = time.perf_counter() - t0
    return {"index": i, "seed": seed, "base": bool(i % 2), "truth": truth,
            "grid_mode_hz": [first_strong_mode(p, 0) for p in plants],
            "fit_rel_error": [p.info["fit"]["rel_error"] for p in plants],
            "certificate": {k: {"stable": c.stable, "min_margin": float(c.margin.min()),
                                "max_spectral_radius": float(c.spectral_radius.max()), "points": int(len(c.margin))}
                            for k, c in cert.items()},
            "robust_mimo": robust.headline(),
            "span_certificate": {"j1_deg": list(SPAN_CHECK_DEG), "wrist_joints": [j + 1 for j in WRIST_CHECK],
                                 "max_spectral_radius": {k: max(v.values()) for k, v in span.items()},
                                 "by_kind": span, "rho_max": SPAN_RHO_MAX, "plants": len(points)},
            "single_k_o": k_o_single, "mimo_k_o": k_o_mimo,
            "mimo_runs": mimo_runs,
            "refused": refused, "postures": rows, "path": path,
            "seconds": {"measure": t_measure, "span": t_span, "design_single": t_single, "design_mimo": t_mimo,
                        "score": t_score, "path": t_path}}


def pct(values, q):
    return float(np.percentile(values, q)) if len(values) else float("nan")


def unstable(sc) -> bool:
    """The sampled loop (what the hardware runs) or the continuous one unstable."""
    return sc["rho"] >= 1 or not sc["stable"]


def collect(lines, kind, key, axis=0, where=("in", "ring")):
    return np.array([r[kind][key][axis] for ln in lines for r in ln["postures"]
                     if r["where"] in where and not unstable(r[kind])])


def report(lines: list[dict]) -> dict:
    rows = [r for ln in lines for r in ln["postures"]]
    n_in, n_ring = sum(r["where"] == "in" for r in rows), sum(r["where"] == "ring" for r in rows)
    refused = sum(ln["refused"] for ln in lines)
    print(f"\n{len(lines)} robots (spread and two form errors each), {len(rows)} postures across six axes: "
          f"{n_in} inside the grid, {n_ring} in the {REACH_DEG:g} deg ring; {refused} refused by the schedule; "
          "controllers designed from each robot's own 16-posture campaign, scored on its exact linearisation")
    bad = {k: sum(r[k]["rho"] >= 1 for r in rows) for k in ("single", "mimo", "fixed_single")}
    bad_c = {k: sum(not r[k]["stable"] for r in rows) for k in ("single", "mimo", "fixed_single")}
    print(f"  unstable on the sampled loop (2 kHz, delay, hold, amplifier): single {bad['single']}, MIMO "
          f"{bad['mimo']}, fixed {bad['fixed_single']}; on the continuous loop: {bad_c['single']}, {bad_c['mimo']}, "
          f"{bad_c['fixed_single']}")
    print(f"  {'controller':<14} {'axis':<11} {'where':<6} {'p5':>7} {'median':>7} {'min':>7}")
    for kind, axes in (("single", (0,)), ("fixed_single", (0,)), ("mimo", (0, 1))):
        for axis in axes:
            for where in ("in", "ring"):
                v = collect(lines, kind, "reduction", axis, (where,))
                print(f"  {kind:<14} {AXES[axis]:<11} {where:<6} {pct(v, 5):7.1%} {pct(v, 50):7.1%} "
                      f"{(v.min() if len(v) else float('nan')):7.1%}")
    amp = collect(lines, "single", "amp_db")
    full = collect(lines, "single", "fullband")
    full100 = collect(lines, "single", "fullband_100")
    margins = [r["single"]["margin"] for r in rows if not unstable(r["single"])]
    stroke = collect(lines, "single", "stroke_m_per_n") * DISTURBANCE_N
    print(f"  single axis: amplification above twice the mode p95 {pct(amp, 95):.2f} dB (median {pct(amp, 50):.2f}); "
          f"full-band RMS against open loop under a flat force 1-40 Hz p95 {pct(full, 95):.3f}, median {pct(full, 50):.3f} "
          f"(1-100 Hz: p95 {pct(full100, 95):.3f}, median {pct(full100, 50):.3f}); "
          f"loop margin p5 {pct(margins, 5):.3f}; stroke at a {DISTURBANCE_N:g} N sine p95 {pct(stroke, 95) * 1e3:.2f} mm")
    cert = [ln["certificate"][k] for ln in lines for k in ("single", "mimo")]
    print(f"  sampled-loop certificates on the design plants: {sum(c['stable'] for c in cert)}/{len(cert)} pass, "
          f"largest spectral radius {max(c['max_spectral_radius'] for c in cert):.6f}")
    rob = [ln["robust_mimo"] for ln in lines]
    print(f"  robust certificates of the MIMO schedules ({rob[0]['draws']} plants drawn from each grid posture's fit): "
          f"{sum(r['stable'] for r in rob)}/{len(rob)} pass, {sum(r['unstable'] for r in rob)} drawn loops unstable, "
          f"P(unstable) <= {100 * rob[0]['epsilon']:.1f} % per posture at {100 * (1 - rob[0]['beta']):.0f} % confidence where they pass")
    span = [ln.get("span_certificate", {}).get("max_spectral_radius") for ln in lines]
    runs = [ln.get("mimo_runs", True) for ln in lines]
    k_os = [ln.get("single_k_o", WEIGHTS.k_o) for ln in lines]
    k_os_mimo = [ln.get("mimo_k_o", WEIGHTS.k_o) for ln in lines]
    if all(x is not None for x in span):
        print(f"  sampled loop with J1 turned {', '.join(f'{d:+g}' for d in SPAN_CHECK_DEG)} deg, the wrist at its span's "
              f"ends, and both, at the grid's corners (rho <= {SPAN_RHO_MAX:g}): single passes on "
              f"{sum(x['single'] <= SPAN_RHO_MAX for x in span)}/{len(span)}, MIMO on "
              f"{sum(x['mimo'] <= SPAN_RHO_MAX for x in span)}/{len(span)}; the MIMO schedule runs on {sum(runs)}/"
              f"{len(runs)} robots (elsewhere the single-axis schedule, the axial coil open); single-axis out-of-band "
              f"weight k_o {', '.join(f'{k:g}' for k in k_os)}; MIMO k_o {', '.join(f'{k:g}' for k in k_os_mimo)}")
    design_s = [ln["seconds"]["design_mimo"] for ln in lines]
    for kind in ("random", "milling"):
        paths = [ln["path"][kind] for ln in lines]
        drop = [100 * (p["static_scheduled"] - p["scheduled"]) for p in paths]
        ok = sum(p["scheduled"] >= 0.6 for p in paths)
        lo, hi = wilson(ok, len(paths))
        print(f"  moving, {kind} force: scheduled {pct([p['scheduled'] for p in paths], 50):.1%} median over robots "
              f"(min {min(p['scheduled'] for p in paths):.1%}; >= 60 % on {ok}/{len(paths)}, {lo:.0%}-{hi:.0%}), "
              f"static {pct([p['static_scheduled'] for p in paths], 50):.1%}, drop worst {max(drop):+.1f} points; "
              f"fixed {pct([p['fixed'] for p in paths], 50):.1%}; loudest 0.25 s against open loop "
              f"{max(p['transient_ratio'] for p in paths):.2f} (fixed up to {max(v for p in paths for v in p['fixed_transient_ratio']):.3g}); "
              f"saturation events {sum(p['saturation_events'] for p in paths)}, saturated samples at most "
              f"{max(p['saturated'] for p in paths):.1%}, stroke used at most {max(p['stroke_used'] for p in paths):.0%}, "
              f"guard trips {sum(p['guard_trips'] for p in paths)}; {min(p['realtime_factor'] for p in paths):.1f}x real time")
    mill = [ln["path"]["milling"] for ln in lines]
    return {"robots": len(lines), "postures": len(rows),
            "unstable_sampled": int(bad["single"] + bad["mimo"]),
            "single_p5_in": round(pct(collect(lines, "single", "reduction", 0, ("in",)), 5), 4),
            "single_median_in": round(pct(collect(lines, "single", "reduction", 0, ("in",)), 50), 4),
            "single_p5_ring": round(pct(collect(lines, "single", "reduction", 0, ("ring",)), 5), 4),
            "mimo_median_min": round(min(pct(collect(lines, "mimo", "reduction", a, ("in",)), 50) for a in (0, 1)), 4),
            "amp_above_2f0_p95_db": round(pct(amp, 95), 2),
            "fullband_rms_ratio": round(pct(full, 95), 3), "fullband_rms_ratio_median": round(pct(full, 50), 3),
            "milling_moving_reduction": round(pct([p["scheduled"] for p in mill], 50), 4),
            "realtime_factor": round(min(p["realtime_factor"] for ln in lines for p in ln["path"].values()), 1),
            "refused": refused, "unstable_continuous": int(bad_c["single"] + bad_c["mimo"]),
            "fixed_unstable_sampled": int(bad["fixed_single"]),
            "milling_transient_ratio": round(max(p["transient_ratio"] for p in mill), 2),
            "milling_saturation_events": int(sum(p["saturation_events"] for p in mill)),
            "robust_pass": int(sum(ln["robust_mimo"]["stable"] for ln in lines)),
            "mimo_runs": int(sum(ln.get("mimo_runs", True) for ln in lines)),
            "design_s": round(max(design_s), 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", type=int, default=10)
    ap.add_argument("--postures", type=int, default=160, help="unseen postures per robot inside the grid")
    ap.add_argument("--ring", type=int, default=48, help="unseen postures per robot in the extrapolation ring")
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    ap.add_argument("--only", default=None, metavar="I,J,...", help="run only these robots")
    ap.add_argument("--lines", default=None, help="JSON-lines file (default: keyed by seed and code)")
    args = ap.parse_args(argv)
    warnings.filterwarnings("ignore", module="control")
    keyed_run(args, f"control_schedule_p{args.postures}r{args.ring}", __file__,
              modules=("rmbench.control", "rmbench.robot", "rmbench.stability"),
              extra=("truth/control.py", "truth/ordinary.py", "truth/form.py"))
    path = Path(args.lines)
    path.parent.mkdir(parents=True, exist_ok=True)
    done = set()
    if path.exists():
        with open_lines(path) as fh:
            done = {json.loads(s)["index"] for s in fh.read().splitlines()}
    todo = [int(x) for x in args.only.split(",")] if args.only else range(args.robots)
    for i in todo:
        if i in done:
            continue
        t = time.perf_counter()
        line = run_robot(i, args.seed, args.postures, args.ring)
        with open_lines(path, "a") as fh:
            fh.write(json.dumps(line) + "\n")
        v = [r["single"]["reduction"][0] for r in line["postures"] if not unstable(r["single"])]
        print(f"robot {i}: single-axis median {np.median(v):.1%}, p5 {np.percentile(v, 5):.1%} "
              f"({time.perf_counter() - t:.0f} s)", flush=True)
    with open_lines(path) as fh:
        lines = [json.loads(s) for s in fh.read().splitlines() if s.strip()]
    lines = [ln for ln in lines if ln["index"] < args.robots]
    if not lines:
        return 0
    print(json.dumps(report(lines)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
