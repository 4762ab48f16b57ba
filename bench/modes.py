"""Mode tables of the virtual robots beside the seed's Tables 2-3, and the cost of ground truth.

Prints, for the IRB6660 stand-in with the dummy tool: the exact modes at the seed's three
validation postures; the range of every mode's natural frequency over the seed's 112-posture grid;
the checks of issue 2 item 4 (mode counts in 5-30 Hz and 700-1100 Hz visible at the tool tip, f1
spread over the workspace, largest θ shift at fixed (x, y), cross coupling at the low modes); the
MH180 stand-in's first tangential and axial modes; and the time of one posture's ground truth
(IK, equilibrium, linearisation, eigen-analysis, 4x4 FRF on 4 000 lines) on one core.

Last line: one JSON object with the headline figures.

usage: python bench/modes.py
"""

from __future__ import annotations

import json
import os
import time

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core, as the target says
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmbench.robot import Robot, seed_grid, validation_postures  # noqa: E402
from rmbench.robot.suppressor import reference_modes  # noqa: E402

# Seed 000, Tables 2-3, measured f_n (Hz) and ζ (%) at the three validation postures.
SEED_LOW = {"1800,-200,0": [(8.19, 13.90), (10.51, 1.17), (18.03, 4.08), (17.62, 1.45), (20.63, 7.36)],
            "1800,200,0": [(9.68, 14.07), (10.74, 1.60), (18.15, 4.14), (18.42, 1.52), (20.53, 6.09)],
            "1800,200,60": [(9.29, 16.63), (10.52, 0.88), (18.95, 5.53), (19.31, 1.94), (21.18, 5.13)]}
SEED_HIGH = {"1800,-200,0": [(824.10, 6.62), (851.34, 6.91), (877.75, 2.90), (888.82, 1.50)],
             "1800,200,0": [(869.35, 12.84), (872.98, 2.79), (876.87, 4.69), (895.50, 1.36)],
             "1800,200,60": [(844.90, 9.22), (873.90, 4.97), (880.67, 1.60), (901.64, 1.37)]}
TIP = ("1X", "1Y")


def visible_tip_modes(op, f_lo, f_hi, s_1a, threshold=0.01):
    """Modes in [f_lo, f_hi] whose contribution to the tool-tip X/Y FRFs exceeds 1 % of the peak."""
    modes = op.linear.modes()
    t = op.coordinate_map(TIP, s_1a=s_1a)
    r, lt = t @ modes.phi_r, t @ modes.phi_l
    contrib = np.abs(np.einsum("om,im->moi", r, lt)).reshape(len(modes.poles), -1).max(1)
    contrib /= np.abs(modes.poles.real)
    freq = np.linspace(f_lo, f_hi, 3000)
    peak = np.abs(modes.frf(freq, t, t)).max()
    keep = (modes.f_n >= f_lo) & (modes.f_n <= f_hi) & (contrib > threshold * peak)
    return modes.f_n[keep], modes.zeta[keep]


def cross_coupling(op, f_low):
    """max over low modes of |H_1x1y| / |H_1x1x| at the mode's natural frequency."""
    h = op.frf(f_low, TIP)
    return float(np.max(np.abs(h[:, 0, 1]) / np.abs(h[:, 0, 0])))


def truth_time(robot, postures, n_lines=4000):
    freq = np.linspace(robot.bands["low"].f_min, robot.bands["high"].f_max, n_lines)
    times = []
    for p in postures:
        t0 = time.perf_counter()
        op = robot.at(p)  # IK, equilibrium, linearisation
        op.modes("low")  # eigen-analysis and modal parameters
        op.modes("high")
        op.frf(freq)  # 4x4 exact FRF
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main():
    robot = Robot.load("irb6660", tool="dummy")
    print("rmbench robot ground truth: IRB6660 stand-in, dummy tool")
    print()
    print("Modes at the seed's validation postures (exact, as bare structure; seed: measured)")
    for p in validation_postures():
        op = robot.at(p)
        lo, hi = op.modes("low"), op.modes("high")
        print(f"  posture {p.label()} (mm, mm, deg)   q_cmd = {np.round(np.degrees(op.q_cmd), 2).tolist()} deg")
        print(f"    {'mode':>4} {'f_n Hz':>9} {'zeta %':>7}   {'seed f_n':>8} {'seed zeta':>9}")
        seed = SEED_LOW[p.label()] + SEED_HIGH[p.label()]
        for i, (f, z) in enumerate(list(zip(lo.f_n, lo.zeta)) + list(zip(hi.f_n, hi.zeta))):
            sf, sz = seed[i] if i < len(seed) else (float("nan"), float("nan"))
            print(f"    {i + 1:>4} {f:9.2f} {100 * z:7.2f}   {sf:8.2f} {sz:9.2f}")
    print()

    grid = seed_grid()
    low_counts, high_counts, f_low_all, f_high_all, cross = [], [], [], [], []
    s_lo, s_hi = robot.bands["low"].s_1a, robot.bands["high"].s_1a
    for p in grid:
        op = robot.at(p)
        fl, _ = visible_tip_modes(op, 5.0, 30.0, s_lo)
        fh, _ = visible_tip_modes(op, 700.0, 1100.0, s_hi)
        low_counts.append(len(fl))
        high_counts.append(len(fh))
        f_low_all.append(op.modes("low").f_n)
        f_high_all.append(op.modes("high").f_n)
        cross.append(cross_coupling(op, fl))
    n_lo = min(len(f) for f in f_low_all)
    n_hi = min(len(f) for f in f_high_all)
    flo = np.array([f[:n_lo] for f in f_low_all])
    fhi = np.array([f[:n_hi] for f in f_high_all])
    print(f"Range of each mode's natural frequency over the {len(grid)} grid postures (modes numbered by frequency)")
    print(f"    {'mode':>4} {'min Hz':>9} {'max Hz':>9} {'spread':>7}")
    for i in range(n_lo):
        print(f"    {i + 1:>4} {flo[:, i].min():9.2f} {flo[:, i].max():9.2f} {np.ptp(flo[:, i]) / flo[:, i].min():7.1%}")
    for i in range(n_hi):
        print(f"    {n_lo + i + 1:>4} {fhi[:, i].min():9.2f} {fhi[:, i].max():9.2f} {np.ptp(fhi[:, i]) / fhi[:, i].min():7.1%}")
    print("    (seed's 9 modes: 10.4-21.2 Hz and 844-896 Hz at its representative posture, Table B1)")
    print()

    # θ shift at fixed (x, y): the grid is x-major, then y, then θ (7 values)
    by_xy = flo.reshape(-1, 7, n_lo)
    theta_shift = float((np.ptp(by_xy, axis=1) / by_xy.min(axis=1)).max())
    f1_spread = float(np.ptp(flo[:, 0]) / flo[:, 0].min())
    print("Checks of issue 2, item 4 (over the 112 grid postures)")
    print(f"  modes visible at the tool tip in 5-30 Hz:     min {min(low_counts)}, max {max(low_counts)}   (need >= 5)")
    print(f"  modes visible at the tool tip in 700-1100 Hz: min {min(high_counts)}, max {max(high_counts)}   (need >= 4)")
    print(f"  damping ratios: {100 * min(z.min() for z in [op.modes('low').zeta]):.2f} % and up (see tables; need 0.5-20 %)")
    print(f"  f1 spread over the workspace: {f1_spread:.1%}   (need >= 10 %)")
    print(f"  largest shift of a low mode over theta at fixed (x, y): {theta_shift:.1%}   (need >= 3 %, seed ~5 %)")
    print(f"  cross coupling |H_1x1y|/|H_1x1x| at a low mode: min over postures {min(cross):.2f}   (need >= 0.10)")
    print()

    mh = reference_modes()
    print("MH180 stand-in at its reference posture")
    print(f"  first tangential mode {mh['tangential_hz']:.2f} Hz (need 5-7; seed 5.72-6.0), "
          f"first axial mode {mh['axial_hz']:.2f} Hz (need 10-14; seed 12.3)")
    print(f"  cross FRF / direct at the tangential mode {mh['cross_tangential']:.2f}, "
          f"at the axial mode {mh['cross_axial']:.2f}   (need >= 0.10)")
    print()

    t = truth_time(robot, validation_postures() * 3)
    print(f"Ground truth of one posture (IK, equilibrium, linearisation, eigen, 4x4 FRF on 4000 lines): {t * 1e3:.1f} ms (target <= 500 ms)")
    zetas = np.concatenate([np.concatenate([robot.at(p).modes(b).zeta for b in ("low", "high")])
                            for p in validation_postures()])
    print(f"Damping ratios at the validation postures: {100 * zetas.min():.2f}-{100 * zetas.max():.2f} %")
    print(json.dumps({"irb_low_modes": int(min(low_counts)), "irb_high_modes": int(min(high_counts)),
                      "f1_spread": round(f1_spread, 4), "theta_shift_max": round(theta_shift, 4),
                      "cross_coupling_min": round(float(min(cross)), 4),
                      "mh180_tangential_hz": round(mh["tangential_hz"], 3),
                      "mh180_axial_hz": round(mh["axial_hz"], 3), "truth_seconds": round(t, 4)}))


if __name__ == "__main__":
    main()
