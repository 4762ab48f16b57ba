"""H∞ proof-mass vibration suppression (issue 6), closed loop in MuJoCo on the MH180 stand-in.

1. Single axis (seed Fig. 9): tangential controller designed on the exact linearisation at the
   reference posture (default weights); the tangential disturbance voice coil sweeps a 20 N sine,
   uncontrolled and controlled; reduction at the mode, largest amplification above twice the mode,
   stroke and force. Beside it: the seed's "modified" controller and controllers designed on the
   measured plant (modes identified from a simulated shaker FRF, METHODS §8 two-mass model with
   every resonance of 2-40 Hz, or with the seed's one mode).
2. Eccentric mass (seed Fig. 12): the spindle turns its eccentric mass at 2-20 Hz (dense near the
   modes); tangential and axial acceleration at the excitation frequency: uncontrolled, two
   separately designed SISO loops (on the exact single-axis plants; and as the seed made them, on
   measured two-mass plants with the modified controller), one MIMO design.
3. Robustness: the reference-posture controllers at postures where the tangential mode has moved
   by ×0.8 and ×1.2 (J2 moved): normal, modified, and robust (designed over the three plants), at a
   10 N sine; 20 N at the ×0.8 posture drives the stage into its end stops (an extra row shows it).
4. Speed: one closed-loop run (MIMO controller, 2 kHz, 10 s simulated) on one core.
5. hinfsyn failures come back as messages naming the condition or weight.

Last line: one JSON object with the headline figures.

usage: python bench/control_loop.py [--workers 2] [--plots bench/results]
"""

from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmbench.control import (Controller, DesignError, Hardware, Weights, design, eccentric_test,  # noqa: E402
                             excitation_frequencies, measured_plant, posture_for_mode_ratio, reduction_at,
                             robot_plant, robust_design, run_loop, sine_sweep)
from rmbench.control.plot import plot_sensitivity  # noqa: E402
from rmbench.robot.suppressor import reference_point, reference_q  # noqa: E402


ROBUST_N = 10.0  # N, disturbance of the robustness sweeps (see section 3's note)


def amplification_db(open_ds, closed_ds, axis, f_above):
    f = open_ds.freq.values
    o = np.abs(open_ds.sensitivity.sel(axis=axis).values)
    c = np.abs(closed_ds.sensitivity.sel(axis=axis).values)
    sel = f > f_above
    return float(20 * np.log10(np.max(c[sel] / o[sel])))


def timed(run, controllers: dict) -> tuple[dict, float]:
    """``({name: run(controller)}, seconds)``: each controller's run (None: uncontrolled) and the
    wall time of them all."""
    t0 = time.perf_counter()
    out = {name: run(k) for name, k in controllers.items()}
    return out, time.perf_counter() - t0


def controlled(runs: dict):
    """``(name, run)`` of each controlled run, in order (the uncontrolled one is the reference)."""
    return [(name, ds) for name, ds in runs.items() if name != "uncontrolled"]


def effort(ds) -> str:
    """A run's largest stroke used (% of the stage's) and actuator force (N), as the tables print them."""
    return f"{100 * float(ds.stroke_used.max()):6.0f}% {float(ds.force_max.max()):8.1f}"


def zeta_near(op, f0):
    m = op.linear.modes()
    return float(m.zeta[np.argmin(np.abs(m.f_n - f0))])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--plots", default=str(Path(__file__).parent / "results"))
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    plots = Path(args.plots)
    plots.mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    op = reference_point()
    robot = op.robot
    tang = robot_plant(op, ("tangential",), order=14)
    axial = robot_plant(op, ("axial",), order=14)
    f_t, f_a = tang.mode_hz[0], axial.mode_hz[0]
    z_t, z_a = zeta_near(op, f_t), zeta_near(op, f_a)
    print(f"MH180 stand-in, reference posture: tangential mode {f_t:.2f} Hz (zeta {z_t:.3f}), "
          f"axial {f_a:.2f} Hz (zeta {z_a:.3f})")
    d_t = design(tang)
    d_t_mod = design(tang, modified=True)
    d_meas = design(measured_plant(op, "tangential"))
    d_a = design(axial)
    d_mimo = design(robot_plant(op, ("tangential", "axial"), order=24), order=20)
    pair = Controller.block_diagonal([d_t.controller, d_a.controller])
    # the seed's own process per axis: the mode identified from a shaker test, METHODS §8 two-mass
    # plant, modified controller
    pair_seed = Controller.block_diagonal([
        design(measured_plant(op, ax, single_mode=True), modified=True).controller for ax in ("tangential", "axial")])
    d_meas1 = design(measured_plant(op, "tangential", single_mode=True))
    print(f"designs: tangential SISO order {d_t.controller.order} (gamma {d_t.gamma:.2f}), axial SISO "
          f"gamma {d_a.gamma:.2f}, MIMO order {d_mimo.controller.order} (gamma {d_mimo.gamma:.2f}); "
          f"measured plant: target mode {d_meas.plant.mode_hz[0]:.3f} Hz, zeta {d_meas.plant.info['zeta']:.4f}; "
          f"resonances {', '.join(f'{f:.2f}' for f in d_meas.plant.info['modes_hz'][1:])} Hz and a residual mass")

    # seed Fig. 7: the modelled sensitivity with the original and the modified controller
    from rmbench.control import sensitivity

    f_lin = np.geomspace(1.0, 40.0, 1500)
    tang_full = robot_plant(op, ("tangential",))
    fig7 = {name: (f_lin, {"tangential": sensitivity(tang_full, k, f_lin)["acc"][:, 0, 0]})
            for name, k in (("uncontrolled", None), ("H-infinity", d_t.controller), ("modified", d_t_mod.controller))}
    plot_sensitivity(fig7, plots / "control_fig7_model.png", title="modelled sensitivity (linear, exact plant)")

    kw = dict(workers=args.workers)  # local worker processes (rmbench.parallel.map_cases)
    # 1. single axis --------------------------------------------------------------------
    f_sweep = excitation_frequencies([(f_t, z_t), (f_a, z_a)], 2.0, 40.0)
    sw, t_sweep = timed(lambda k: sine_sweep(op, k, "tangential", f_sweep, **kw),
                        {"uncontrolled": None, "H-infinity": d_t.controller, "modified": d_t_mod.controller,
                         "measured plant, all modes": d_meas.controller,
                         "measured plant, one mode": d_meas1.controller})
    print(f"\n1. Single axis, 20 N sine on the tangential disturbance coil, {len(f_sweep)} frequencies "
          f"2-40 Hz ({t_sweep:.0f} s)")
    print(f"  {'controller':<24} {'reduction':>9} {'amp >2f0 dB':>11} {'stroke':>7} {'force N':>8} {'sat.':>5} "
          f"{'end-stop runs':>13}")
    single = {}
    for name, ds in controlled(sw):
        red = reduction_at(sw["uncontrolled"], ds, "tangential", f_t)
        amp = amplification_db(sw["uncontrolled"], ds, "tangential", 2 * f_t)
        single[name] = (red, amp)
        print(f"  {name:<24} {100 * red:8.1f}% {amp:11.2f} {effort(ds)} "
              f"{float(ds.saturated.max()):5.2f} {int((ds.end_stop > 0).sum()):13d}")
    print("  seed: 75.2 % at 5.72 Hz (modified controller); target >= 80 %, <= 3 dB above 2 f0, "
          "stroke <= 12.5 mm, force <= 180 N")
    plot_sensitivity(sw, plots / "control_fig9_single_axis.png", title="single axis: 20 N sine sweep")

    # 2. eccentric mass ---------------------------------------------------------------------
    speeds = excitation_frequencies([(f_t, z_t), (f_a, z_a)], 2.0, 20.0)
    ecc, t_ecc = timed(lambda k: eccentric_test(op, k, speeds, **kw),
                       {"uncontrolled": None, "two SISO loops": pair, "SISO, seed process": pair_seed,
                        "MIMO": d_mimo.controller})
    print(f"\n2. Eccentric mass (m e = 0.01 kg m), {len(speeds)} speeds 2-20 Hz ({t_ecc:.0f} s)")
    print(f"  {'controller':<18} {'tangential':>10} {'axial':>8} {'amp >1.5f_a dB (t/a)':>19} {'stroke':>7} "
          f"{'force N':>8} {'runs at an end stop':>19}")
    ecc_red = {}
    for name, ds in controlled(ecc):
        rt = reduction_at(ecc["uncontrolled"], ds, "tangential", f_t)
        ra = reduction_at(ecc["uncontrolled"], ds, "axial", f_a)
        at = amplification_db(ecc["uncontrolled"], ds, "tangential", 1.5 * f_a)
        aa = amplification_db(ecc["uncontrolled"], ds, "axial", 1.5 * f_a)
        out = ds.freq.values[ds.end_stop.values > 0]
        ecc_red[name] = (rt, ra)
        print(f"  {name:<18} {100 * rt:9.1f}% {100 * ra:7.1f}% {at:9.2f}/{aa:<9.2f} {effort(ds)} "
              f"{', '.join(f'{f:g}' for f in out) + ' Hz' if len(out) else 'none':>19}")
    print("  seed (two SISO loops): 58.7 % tangential at 6.0 Hz, 27.8 % axial at 12.3 Hz, an increase "
          "at 13.9 Hz; target MIMO >= 70 % on both")
    plot_sensitivity(ecc, plots / "control_fig12_eccentric.png", title="eccentric mass test",
                     ylabel="acceleration / eccentric force, m/s²/N")

    # 3. robustness ---------------------------------------------------------------------------
    print("\n3. Robustness: the reference-posture tangential controllers where the mode has moved "
          "(robust: designed over the plants at x0.8, x1, x1.2, acceleration weight widened)")
    print(f"  {'mode ratio':>10} {'f_n Hz':>7} {'controller':<12} {'d, N':>5} {'reduction':>9} {'amp >2f0 dB':>11} "
          f"{'stroke':>7} {'stable':>6} {'end-stop runs':>13}")
    q_ref = reference_q(robot)
    q_fam = {r: posture_for_mode_ratio(robot, q_ref, r) for r in (0.8, 1.2)}
    family = [robot_plant(robot.at(q), ("tangential",), order=14) for q in q_fam.values()] + [tang]
    d_rob = robust_design(family)
    robust = []
    t0 = time.perf_counter()
    for ratio in (0.8, 1.2):
        op_r = robot.at(q_fam[ratio])
        f_r = robot_plant(op_r, ("tangential",)).mode_hz[0]
        fr = excitation_frequencies([(f_r, zeta_near(op_r, f_r))], 2.0, 40.0, coarse=2.0)
        rows = [("H-infinity", d_t.controller, ROBUST_N), ("modified", d_t_mod.controller, ROBUST_N),
                ("robust", d_rob.controller, ROBUST_N)]
        if ratio < 1:
            rows.append(("H-infinity", d_t.controller, 20.0))  # the single-axis test's level
        base = {}
        for name, k, amp_n in rows:
            if amp_n not in base:
                base[amp_n] = sine_sweep(op_r, None, "tangential", fr, amplitude=amp_n, **kw)
            ds = sine_sweep(op_r, k, "tangential", fr, amplitude=amp_n, **kw)
            ok = bool(ds.ok.all())
            red = reduction_at(base[amp_n], ds, "tangential", f_r) if ok else float("nan")
            amp = amplification_db(base[amp_n], ds, "tangential", 2 * f_r) if ok else float("nan")
            if name == "H-infinity" and amp_n == ROBUST_N:
                robust.append(red if ok else 0.0)
            print(f"  {ratio:10.2f} {f_r:7.2f} {name:<12} {amp_n:5.0f} {100 * red:8.1f}% {amp:11.2f} "
                  f"{100 * float(ds.stroke_used.max()):6.0f}% {str(ok):>6} {int((ds.end_stop > 0).sum()):13d}")
    t_rob = time.perf_counter() - t0
    print(f"  ({t_rob:.0f} s) target: >= 60 % and stable at both. At x0.8 the mode sits at 4.7 Hz, where a 20 N "
          "sine asks for more travel than the ±12.5 mm stage has (the 20 N row: end stops); the robustness "
          f"runs use {ROBUST_N:g} N")

    # 4. speed ------------------------------------------------------------------------------------
    shake = lambda t: 20 * np.sin(2 * np.pi * f_t * t)  # noqa: E731
    rec = run_loop(op, d_mimo.controller, 10.0, hardware=Hardware(), shaker={"tangential": shake})
    rec_siso = run_loop(op, d_t.controller, 10.0, hardware=Hardware(), shaker={"tangential": shake})
    print(f"\n4. Closed loop, 10 s simulated at 2 kHz (semi-implicit Euler, 1 physics step per sample), one "
          f"core: MIMO order {d_mimo.controller.order}: {rec.realtime_factor:.1f}x real time; SISO order "
          f"{d_t.controller.order}: {rec_siso.realtime_factor:.1f}x (target >= 10x)")

    # 5. failures -----------------------------------------------------------------------------------
    print("\n5. hinfsyn failures:")
    for label, kwargs in (("gamma bound too low", dict(gamma_max=1e-3)),
                          ("position weight pole on the jw axis", dict(weights=Weights(f_pl=1e-12))),
                          ("no accelerometer noise", dict(weights=Weights(noise_acc=1e-300))),
                          ("acceleration weight beyond the force limit", dict(weights=Weights(k_a=1e5, k_u=10.0),
                                                                              gamma_max=1.0))):
        try:
            design(tang, **kwargs)
            print(f"  {label}: (no error)")
        except DesignError as err:
            print(f"  {label}: {err}")
    print(f"\ntotal {time.perf_counter() - t_all:.0f} s")
    print(json.dumps({
        "single_axis_reduction": round(single["H-infinity"][0], 4),
        "mimo_tangential_reduction": round(ecc_red["MIMO"][0], 4),
        "mimo_axial_reduction": round(ecc_red["MIMO"][1], 4),
        "siso_pair_reductions": [round(ecc_red["two SISO loops"][0], 4), round(ecc_red["two SISO loops"][1], 4)],
        "robust_min_reduction": round(float(min(robust)), 4),
        "realtime_factor": round(float(rec.realtime_factor), 2)}))


if __name__ == "__main__":
    main()
