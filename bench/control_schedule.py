"""Posture-scheduled proof-mass control designed from measurements, across the workspace (issue 41).

For each of ``--robots`` "real" MH180s (every ordinary parameter drawn as the calibration bench
draws them, a compliant foundation on every other one; ``truth/control.py``, plain MJCF edits):

1. **Campaign**: simulated shaker tests (tangential and axial coils in turn, 64 s of band-limited
   random force each) at the 16 postures of a 4 × 4 grid over J2 −10…20° and J3 −10…30° (J5 keeps
   the spindle vertical), and at the reference posture.
2. **Design from the campaign only**: each posture's 2 × 2 accelerance fitted with real normal modes
   (``fit_modes_matrix``), a plant built on them (``modal_plant``), H∞ designs at every grid
   posture: a SISO tangential schedule and a MIMO tangential + axial one; the fixed single-posture
   controllers are designed the same way at the reference posture. The design never reads the
   robot's exact model.
3. **Certificate** on the design plants: the grid postures and a 3× finer grid between them
   (``certify``, interpolated plants).
4. **Scored on the truth**: the "real" robot's exact linearisation at ``--postures`` quasi-random
   (Sobol) postures inside the grid: reduction of the acceleration sensitivity peak at the first
   strong mode of each axis (the seed's Fig. 9 figure), closed-loop stability, the loop margin
   (smallest singular value of I − K G), the largest amplification above twice the mode (dB, as
   ``bench/control_loop.py``),
   and stroke and force at a 10 N disturbance sine at the mode.

5. **Moving**: the arm moves across the grid (J2 −8 → 18°, J3 −8 → 28°, cosine speed profile, 12 s)
   in MuJoCo while the tangential disturbance coil shakes it (band-limited random force, 10 N rms
   to 40 Hz; two realisations), uncontrolled, with the scheduled single-axis controller (blended on
   the measured joint angles) and with the fixed one. In 4 s windows (1 s apart) the acceleration's
   energy within ±25 % of the local mode gives the moving reduction ``1 − √(Σ E_closed / Σ E_open)``;
   the static figure is the same energy ratio of the linear closed loop at each window's mid
   posture with the controller frozen there. ``path_drop_pts`` = static − moving, in points.
   Switching transients: the loudest 0.25 s of the scheduled loop's acceleration within the modes'
   band (0.6 × the lowest to 1.6 × the highest mode met) against the open loop's RMS there over the
   whole move (``rmbench.control.moving``).

Each robot's figures go to a JSON-lines file keyed by seed and code, so a killed run resumes.
Last line: one JSON object with issue 41's bench keys.

usage: python bench/control_schedule.py [--robots 10] [--postures 256] [--seed S]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
from scipy.stats import qmc  # noqa: E402

from _stats import keyed_run, open_lines  # noqa: E402
from truth.control import draw_mh180  # noqa: E402
from rmbench.control import design, is_stable, sensitivity  # noqa: E402
from rmbench.control.moving import moving_test  # noqa: E402
from rmbench.control.experiments import measured_matrix_plant  # noqa: E402
from rmbench.control.plant import first_strong_mode, robot_plant  # noqa: E402
from rmbench.control.schedule import certify, design_schedule, grid_posture, loop_margin  # noqa: E402
from rmbench.control.trajectory import linear_move  # noqa: E402
from rmbench.robot.model import Robot  # noqa: E402
from rmbench.robot.suppressor import reference_q  # noqa: E402

AXES = ("tangential", "axial")
JOINTS, HOLD = (1, 2), 4  # J2 and J3 scheduled, J5 keeps the spindle vertical
GRID_DEG = ((-10.0, 0.0, 10.0, 20.0), tuple(np.linspace(-10.0, 30.0, 4)))
WINDOW = 0.25  # the mode's ±25 %: where the reduction is read
DISTURBANCE_N = 10.0
FREQ = np.geomspace(1.0, 100.0, 700)
MOVE_DEG = ((-8.0, -8.0), (18.0, 28.0))
MOVE_S, HOLD_S = 12.0, 2.0
WIN_S, HOP_S = 4.0, 1.0


def peak_in(f, mag, f0):
    return float(np.max(mag[np.abs(f - f0) <= WINDOW * f0]))


def score(plant, ctrl, f0s, open_resp):
    """Reduction per axis, amplification outside the modes (dB), stroke (m) and force (N) per N."""
    if not is_stable(plant, ctrl):
        return {"stable": False}
    r = sensitivity(plant, ctrl, FREQ)
    out = {"stable": True, "reduction": [], "amp_db": [], "stroke_m_per_n": [], "force_n_per_n": []}
    for i, f0 in enumerate(f0s):
        o, c = np.abs(open_resp[:, i, i]), np.abs(r["acc"][:, i, i])
        out["reduction"].append(1 - peak_in(FREQ, c, f0) / peak_in(FREQ, o, f0))
        out["amp_db"].append(20 * np.log10(float(np.max((c / o)[FREQ > 2 * f0]))))
        out["stroke_m_per_n"].append(float(np.max(np.abs(r["pos"][:, i, i]))))
        out["force_n_per_n"].append(float(np.max(np.abs(r["force"][:, i, i]))))
    out["margin"] = loop_margin(plant, ctrl, FREQ)
    return out


def band_ratio(plant, ctrl, f0):
    """Linear closed-to-open ratio of the acceleration energy within ±WINDOW of f0 (flat force)."""
    f = np.linspace((1 - WINDOW) * f0, (1 + WINDOW) * f0, 200)
    o = np.abs(sensitivity(plant, None, f)["acc"][:, 0, 0])
    c = np.abs(sensitivity(plant, ctrl, f)["acc"][:, 0, 0])
    return float(np.sum(c**2) / np.sum(o**2))


def moving(real, q_ref, sch, fixed, seed) -> dict:
    """Section 5 of the module docstring, for one robot."""
    q0, q1 = (grid_posture(q_ref, JOINTS, np.radians(s), HOLD) for s in MOVE_DEG)
    traj = linear_move(q0, q1, MOVE_S, hold=HOLD_S)
    op = real.at(q0)

    def truth_plant(q):
        return robot_plant(real.at(q), AXES[:1])

    energy = {"open": 0.0, "scheduled": 0.0, "fixed": 0.0, "static_scheduled": 0.0, "static_fixed": 0.0}
    out = {"realtime_factor": [], "saturated": 0.0, "stroke_used": 0.0, "transient_ratio": 0.0}
    for rep in range(2):
        ds = moving_test(op, {"scheduled": sch, "fixed": fixed}, traj, start=HOLD_S, window=WIN_S, hop=HOP_S,
                         band=WINDOW, mode_hz=lambda q: first_strong_mode(truth_plant(q), 0), seed=seed + rep)
        for k in ("open", "scheduled", "fixed"):
            energy[k] += float(ds.energy.sel(controller=k).sum())
        for w in ds.window.values:
            q = ds.q_mid.values[w]
            plant, f0, e_open = truth_plant(q), float(ds.f0.values[w]), float(ds.energy.sel(controller="open")[w])
            energy["static_scheduled"] += e_open * band_ratio(plant, sch.at(q[list(JOINTS)]), f0)
            energy["static_fixed"] += e_open * band_ratio(plant, fixed, f0)
        sc = ds.sel(controller="scheduled")
        out["realtime_factor"].append(float(sc.realtime_factor))
        out["saturated"] = max(out["saturated"], float(sc.saturated))
        out["stroke_used"] = max(out["stroke_used"], float(sc.stroke_used))
        out["guard_trips"] = out.get("guard_trips", 0) + int(sc.guard_trips)
        out["transient_ratio"] = max(out["transient_ratio"], float(sc.transient))
        out.setdefault("fixed_transient_ratio", []).append(float(ds.transient.sel(controller="fixed")))
    for k in ("scheduled", "fixed", "static_scheduled", "static_fixed"):
        out[k] = 1 - float(np.sqrt(energy[k] / energy["open"]))
    out["realtime_factor"] = float(np.min(out["realtime_factor"]))
    return out


def run_robot(i: int, seed: int, n_postures: int) -> dict:
    rng = np.random.default_rng([seed, i])
    nominal = Robot.load("mh180")
    xml, truth = draw_mh180(nominal.xml, rng, base=bool(i % 2))
    real = Robot(xml, name=f"real{i}", tool=None)
    q_ref = reference_q(nominal)
    grid = tuple(np.radians(g) for g in GRID_DEG)
    S = np.stack([m.ravel() for m in np.meshgrid(*grid, indexing="ij")], axis=1)
    t0 = time.perf_counter()
    plants = [measured_matrix_plant(real.at(grid_posture(q_ref, JOINTS, s, HOLD)), AXES, seed=int(seed + k))
              for k, s in enumerate(S)]
    p_ref = measured_matrix_plant(real.at(q_ref), AXES, seed=seed + 99)
    t_measure = time.perf_counter() - t0

    t0 = time.perf_counter()
    single = [p.select(AXES[:1]) for p in plants]
    sch_single = design_schedule(single, grid, JOINTS, q_ref, hold=HOLD)
    t_single = time.perf_counter() - t0
    t0 = time.perf_counter()
    sch_mimo = design_schedule(plants, grid, JOINTS, q_ref, hold=HOLD, mimo=True)
    t_mimo = time.perf_counter() - t0
    fixed_single = design(p_ref.select(AXES[:1]), order=12, mode_hz=[first_strong_mode(p_ref, 0)]).controller
    fixed_mimo = design(p_ref, order=20, mode_hz=[first_strong_mode(p_ref, k) for k in range(2)]).controller
    cert = {name: certify(s, pl) for name, s, pl in (("single", sch_single, single), ("mimo", sch_mimo, plants))}

    lo, hi = [g[0] for g in grid], [g[-1] for g in grid]
    points = qmc.scale(qmc.Sobol(2, seed=int(rng.integers(2**31))).random(n_postures), lo, hi)
    rows = []
    t0 = time.perf_counter()
    for s in points:
        truth_plant = robot_plant(real.at(grid_posture(q_ref, JOINTS, s, HOLD)), AXES)
        t_single_plant = truth_plant.select(AXES[:1])
        f0s = [first_strong_mode(truth_plant, k) for k in range(2)]
        open_mimo = sensitivity(truth_plant, None, FREQ)["acc"]
        open_single = open_mimo[:, :1, :1]  # the other axis's coil is off either way
        rows.append({"s_deg": np.degrees(s).round(3).tolist(), "f0_hz": f0s,
                     "single": score(t_single_plant, sch_single.at(s), f0s[:1], open_single),
                     "fixed_single": score(t_single_plant, fixed_single, f0s[:1], open_single),
                     "mimo": score(truth_plant, sch_mimo.at(s), f0s, open_mimo),
                     "fixed_mimo": score(truth_plant, fixed_mimo, f0s, open_mimo)})
    t_score = time.perf_counter() - t0
    t0 = time.perf_counter()
    path = moving(real, q_ref, sch_single, fixed_single, seed + 1000 * i)
    t_path = time.perf_counter() - t0
    return {"index": i, "seed": seed, "base": bool(i % 2), "truth": truth,
            "grid_mode_hz": [first_strong_mode(p, 0) for p in plants],
            "fit_rel_error": [p.info["fit"]["rel_error"] for p in plants],
            "certificate": {k: {"stable": c.stable, "min_margin": float(c.margin.min()),
                                "points": int(len(c.margin))} for k, c in cert.items()},
            "postures": rows, "path": path,
            "seconds": {"measure": t_measure, "design_single": t_single, "design_mimo": t_mimo,
                        "score": t_score, "path": t_path}}


def pct(values, q):
    return float(np.percentile(values, q)) if len(values) else float("nan")


def summarise(lines: list[dict]) -> dict:
    def reductions(kind, axis):
        vals, unstable = [], 0
        for ln in lines:
            for r in ln["postures"]:
                sc = r[kind]
                if not sc["stable"]:
                    unstable += 1
                else:
                    vals.append(sc["reduction"][axis])
        return np.array(vals), unstable

    out = {}
    for kind in ("single", "fixed_single", "mimo", "fixed_mimo"):
        for axis in ((0,) if "single" in kind else (0, 1)):
            v, u = reductions(kind, axis)
            out[(kind, axis)] = (v, u)
    return out


def report(lines: list[dict]) -> dict:
    n_post = sum(len(ln["postures"]) for ln in lines)
    s = summarise(lines)
    print(f"\n{len(lines)} robots, {n_post} unseen postures (a robot's own 16-posture campaign designs its "
          "controllers; scored on its exact linearisation)")
    print(f"  {'controller':<26} {'axis':<11} {'p5':>7} {'median':>7} {'min':>7} {'unstable':>9}")
    for (kind, axis), (v, u) in s.items():
        print(f"  {kind:<26} {AXES[axis]:<11} {pct(v, 5):7.1%} {pct(v, 50):7.1%} "
              f"{(v.min() if len(v) else float('nan')):7.1%} {u:9d}")
    margins = [r["mimo"]["margin"] for ln in lines for r in ln["postures"] if r["mimo"]["stable"]]
    margins1 = [r["single"]["margin"] for ln in lines for r in ln["postures"] if r["single"]["stable"]]
    amp = [max(r["single"]["amp_db"]) for ln in lines for r in ln["postures"] if r["single"]["stable"]]
    stroke = [r["single"]["stroke_m_per_n"][0] * DISTURBANCE_N for ln in lines for r in ln["postures"]
              if r["single"]["stable"]]
    force = [r["single"]["force_n_per_n"][0] * DISTURBANCE_N for ln in lines for r in ln["postures"]
             if r["single"]["stable"]]
    cert_ok = sum(ln["certificate"][k]["stable"] for ln in lines for k in ("single", "mimo"))
    print(f"  loop margin min(sigma(I - K G)): single p5 {pct(margins1, 5):.3f}, min {min(margins1):.3f}; "
          f"MIMO p5 {pct(margins, 5):.3f}, min {min(margins):.3f}")
    print(f"  single axis: amplification above twice the mode p95 {pct(amp, 95):.2f} dB; at a "
          f"{DISTURBANCE_N:g} N sine, stroke p95 {pct(stroke, 95) * 1e3:.2f} mm (of ±12.5), force p95 "
          f"{pct(force, 95):.1f} N (of 180)")
    print(f"  certificates (design plants, grid and 3x finer between): {cert_ok}/{2 * len(lines)} pass; "
          f"smallest margin {min(ln['certificate'][k]['min_margin'] for ln in lines for k in ('single', 'mimo')):.3f}")
    design_s = [ln["seconds"]["design_mimo"] for ln in lines]
    print(f"  design of a 16-posture MIMO schedule: median {pct(design_s, 50):.1f} s, max {max(design_s):.1f} s "
          f"(single axis median {pct([ln['seconds']['design_single'] for ln in lines], 50):.1f} s)")
    unstable = sum(s[(k, 0)][1] for k in ("single", "mimo"))
    paths = [ln["path"] for ln in lines]
    drop = [100 * (p["static_scheduled"] - p["scheduled"]) for p in paths]
    print(f"  moving ({MOVE_S:g} s across the grid, random tangential force): scheduled "
          f"{pct([p['scheduled'] for p in paths], 50):.1%} moving against {pct([p['static_scheduled'] for p in paths], 50):.1%} "
          f"static (median over robots), drop median {pct(drop, 50):+.1f} points, worst {max(drop):+.1f}; fixed "
          f"{pct([p['fixed'] for p in paths], 50):.1%} moving, {pct([p['static_fixed'] for p in paths], 50):.1%} static")
    print(f"  moving runs: loudest 0.25 s of the scheduled loop in the modes' band {max(p['transient_ratio'] for p in paths):.2f} "
          f"of the open loop's RMS there (fixed controller: up to "
          f"{max(v for p in paths for v in p['fixed_transient_ratio']):.3g}); "
          f"saturated samples at most {max(p['saturated'] for p in paths):.1%}, stroke used at most "
          f"{max(p['stroke_used'] for p in paths):.0%}, stroke guard trips {sum(p['guard_trips'] for p in paths)}; scheduled loop {min(p['realtime_factor'] for p in paths):.1f}x "
          "real time (slowest run)")
    return {"robots": len(lines), "postures": n_post,
            "single_p5": round(pct(s[("single", 0)][0], 5), 4),
            "single_median": round(pct(s[("single", 0)][0], 50), 4),
            "mimo_median_min": round(min(pct(s[("mimo", a)][0], 50) for a in (0, 1)), 4),
            "fixed_single_median": round(pct(s[("fixed_single", 0)][0], 50), 4),
            "fixed_unstable": s[("fixed_single", 0)][1] + s[("fixed_mimo", 0)][1],
            "unstable": int(unstable), "path_drop_pts": round(max(drop), 2),
            "realtime_factor": round(min(p["realtime_factor"] for p in paths), 1),
            "design_s": round(max(design_s), 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robots", type=int, default=10)
    ap.add_argument("--postures", type=int, default=256, help="unseen postures per robot (a power of two: Sobol)")
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    ap.add_argument("--only", default=None, metavar="I,J,...", help="run only these robots")
    ap.add_argument("--lines", default=None, help="JSON-lines file (default: keyed by seed and code)")
    args = ap.parse_args(argv)
    warnings.filterwarnings("ignore", module="control")
    keyed_run(args, f"control_schedule_p{args.postures}", __file__,
              modules=("rmbench.control", "rmbench.robot"), extra=("truth/control.py", "truth/ordinary.py"))
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
        line = run_robot(i, args.seed, args.postures)
        with open_lines(path, "a") as fh:
            fh.write(json.dumps(line) + "\n")
        v = [r["single"]["reduction"][0] for r in line["postures"] if r["single"]["stable"]]
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
