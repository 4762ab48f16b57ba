"""Any arm as a bench robot: UR10 and Panda from example-robot-data, checked like the stand-ins.

For each arm: build it from its URDF (`rmbench model build`) and compare with the bundled
models/mjcf/NAME.xml; pinocchio against MuJoCo kinematics (100 random configurations of every joint,
flexible and spindle joints included; both from the same MJCF text) and the flange against
pinocchio's model of the URDF itself; the exact FRF against MuJoCo's time-domain response to a force
pulse at every modal peak of both bands at the three validation postures (the check the stand-ins
pass, `sim_tests/test_truth_vs_time.py`); the posture grid's margins; then the chain: a time-domain
impact campaign on 48 postures of the robot's grid (4 x 4 x θ −40, 0, 40°), fitted by the modal
stage (errors against the exact modes), grouped MTGP trained on it and scored against the exact
modes at 128 quasi-random unseen postures inside the grid's box.

Last line: one JSON object, {"robots", "frf_peak_err_max", "kinematics_err_max_m", ...}.

usage: python bench/any_robot.py [--work DIR] [--robots ur10,panda]
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import mujoco  # noqa: E402
import numpy as np  # noqa: E402
import pinocchio as pin  # noqa: E402
from scipy.stats import qmc  # noqa: E402

from rmbench.impact import load_config, open_campaign, run_campaign  # noqa: E402
from rmbench.modal.campaign_fit import fit_campaign, truth_errors  # noqa: E402
from rmbench.predict import PosturePredictor  # noqa: E402
from rmbench.robot import Robot  # noqa: E402
from rmbench.robot.catalog import resolve_robot  # noqa: E402
from rmbench.robot.flexible_arm import build_arm  # noqa: E402
from rmbench.robot.simulate import pulse_check  # noqa: E402


def kinematics_error(robot: Robot, n: int = 100) -> float:
    """Largest pinocchio vs MuJoCo site distance, m, over random configurations of every joint."""
    kin, m = robot.kinematics, robot.model
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    sites = [m.site(i).name for i in range(m.nsite)]
    worst = 0.0
    for _ in range(n):
        q = rng.uniform(-1, 1, m.nq) * np.where(m.jnt_type == 3, 1.0, 1e-3)
        d.qpos[:] = q
        mujoco.mj_kinematics(m, d)
        qp = kin.from_mujoco(m, q)
        pin.framesForwardKinematics(kin.model, kin.data, qp)
        for s in sites:
            fid = kin.model.getFrameId(s, pin.FrameType.OP_FRAME)
            worst = max(worst, float(np.linalg.norm(kin.data.oMf[fid].translation - d.site(s).xpos)))
    return worst


def urdf_error(robot: Robot, arm, n: int = 100) -> float:
    """Largest flange distance, m, between the bench robot and pinocchio's model of the URDF."""
    urdf = pin.buildModelFromUrdf(str(arm.path))
    du = urdf.createData()
    kin = robot.kinematics
    fu, fk = urdf.getFrameId(arm.flange), kin.model.getFrameId(arm.flange)
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(n):
        q = robot.limits[:, 0] + (robot.limits[:, 1] - robot.limits[:, 0]) * rng.random(len(robot.limits))
        pin.framesForwardKinematics(urdf, du, arm.pin_configuration(urdf, q))
        pin.framesForwardKinematics(kin.model, kin.data, kin.full_q(q))
        worst = max(worst, float(np.linalg.norm(kin.data.oMf[fk].translation - du.oMf[fu].translation)))
    return worst


def frf_peak_errors(robot: Robot) -> list[float]:
    """Relative |H| errors, time domain vs exact, at every modal peak (entries ≥ 5 % of the column)."""
    out = []
    for p in robot.validation():
        op = robot.at(p)
        amp = 1e-4 / abs(op.frf(np.array([0.5]))[0, 0, 0])   # ~0.1 mm static: linear deflections
        for band, kw in (("high", dict(record=0.25, pulse=2e-4, tau=0.025)),
                         ("low", dict(record=1.5, pulse=5e-3, tau=0.25))):
            for col in (0, 1):
                for _, meas, exact in pulse_check(op, band, col, amplitude=amp, **kw):
                    big = np.abs(exact) >= 0.05 * np.abs(exact).max()
                    out += list(np.abs(np.abs(meas[big]) - np.abs(exact[big])) / np.abs(exact[big]))
    return out


def unseen(robot: Robot, n: int, seed: int = 7) -> np.ndarray:
    """Quasi-random (x mm, y mm, θ deg) inside the box of the training postures (θ ±40°)."""
    g = robot.grid()
    x, y = [1000 * p.x for p in g], [1000 * p.y for p in g]
    lo, hi = np.array([min(x), min(y), -40.0]), np.array([max(x), max(y), 40.0])
    return lo + qmc.Sobol(3, seed=seed).random(n) * (hi - lo)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default="/tmp/rmbench_any_robot", help="folder for campaigns (resumable)")
    ap.add_argument("--robots", default="ur10,panda")
    args = ap.parse_args()
    work = Path(args.work)
    work.mkdir(parents=True, exist_ok=True)
    names = args.robots.split(",")
    rows, all_peaks, kin_max = {}, [], 0.0
    for name in names:
        r = {}
        t0 = time.perf_counter()
        built = build_arm(name)
        r["build_s"] = time.perf_counter() - t0
        r["bundled_same"] = built.xml == resolve_robot(name).read_text()
        robot = Robot.load(name)
        r["n_axes"] = len(robot.arm_joints)
        r["kin_mj_pin_m"] = kinematics_error(robot)
        r["kin_urdf_m"] = urdf_error(robot, built.arm)
        kin_max = max(kin_max, r["kin_mj_pin_m"])
        g = built.grid
        r.update(f_arm=list(np.round(built.f_low, 2)), f_spindle=list(np.round(built.f_high[:2], 1)),
                 table_mm=1000 * g.table_z, x_mm=(1000 * g.x[0], 1000 * g.x[-1]), margin_deg=np.degrees(g.worst_margin),
                 sigma_min=g.worst_sigma)
        t0 = time.perf_counter()
        peaks = frf_peak_errors(robot)
        r["frf_peak_err_max"] = max(peaks)
        r["frf_peaks"] = len(peaks)
        r["frf_check_s"] = time.perf_counter() - t0
        all_peaks += peaks
        print(f"{name}: built in {r['build_s']:.1f} s (same as bundled: {r['bundled_same']}); kinematics "
              f"MuJoCo-pinocchio {r['kin_mj_pin_m']:.1e} m, vs URDF {r['kin_urdf_m']:.1e} m; FRF peaks "
              f"{r['frf_peaks']} entries, worst {100 * r['frf_peak_err_max']:.3f} %", flush=True)

        # the chain: time-domain campaign on 48 grid postures -> fit -> grouped MTGP -> unseen postures
        xs = sorted({1000 * p.x for p in robot.grid()})
        ys = sorted({1000 * p.y for p in robot.grid()})
        cfg = load_config(name).with_overrides(
            name=f"{name}_48", grid={"kind": "product", "x_mm": xs, "y_mm": ys, "theta_deg": [-40.0, 0.0, 40.0]})
        data = work / f"{name}_48.nc"
        t0 = time.perf_counter()
        if not data.exists():   # a finished campaign is not rerun (delete it to time one)
            run_campaign(cfg, data, workers=2, progress=True)
        r["campaign_s"] = time.perf_counter() - t0
        ds = open_campaign(data)
        t0 = time.perf_counter()
        fit = fit_campaign(ds, workers=2)
        r["fit_s"] = time.perf_counter() - t0
        r["fit_ok"] = float(fit.fit_ok.values.mean())
        fe, ze = np.abs(fit.f_err.values), np.abs(fit.zeta_err.values)
        r["fit_f_err_p50_p95_max"] = [float(np.nanpercentile(fe, q)) for q in (50, 95, 100)]
        r["fit_zeta_err_p50_p95"] = [float(np.nanpercentile(ze, q)) for q in (50, 95)]
        pred = PosturePredictor("mtgp-grouped").fit(fit)
        r["mtgp_train_s"] = pred.train_seconds_
        P = unseen(robot, 128)
        truth_path = work / f"{name}_unseen.nc"
        if not truth_path.exists():
            run_campaign(cfg.with_overrides(name=f"{name}_unseen", method="linear",
                                            grid={"kind": "list", "postures": P.tolist()}),
                         truth_path, workers=2, progress=False)
        truth = open_campaign(truth_path)
        guess = pred.predict(np.column_stack([P[:, 0] / 1e3, P[:, 1] / 1e3, np.radians(P[:, 2])]))
        err = truth_errors(guess, truth)
        pf = np.abs(err.f_err.values)
        r["unseen_f_err_p50_p95"] = [float(np.nanpercentile(pf, q)) for q in (50, 95)]
        r["unseen_paired"] = float(np.isfinite(pf).sum() / np.isfinite(guess.modal.sel(param="f_n").values).sum())
        print(f"  campaign 48 postures {r['campaign_s']:.0f} s, fit {r['fit_s']:.0f} s, ok {100 * r['fit_ok']:.0f} %, "
              f"f error p50/p95/max {', '.join(f'{100 * v:.3f}' for v in r['fit_f_err_p50_p95_max'])} %; MTGP "
              f"{r['mtgp_train_s']:.0f} s, unseen f error p50/p95 "
              f"{', '.join(f'{100 * v:.2f}' for v in r['unseen_f_err_p50_p95'])} % "
              f"({100 * r['unseen_paired']:.0f} % of predicted modes paired with an exact one)", flush=True)
        rows[name] = r

    print()
    print(f"{'robot':<7}{'axes':>5}{'kin MJ-pin m':>14}{'kin URDF m':>12}{'FRF peak %':>12}  {'arm modes Hz':<36}"
          f"{'margin°':>8}{'fit ok':>8}{'fit f p95 %':>12}{'unseen f p50/p95 %':>20}{'paired':>8}")
    for name, r in rows.items():
        print(f"{name:<7}{r['n_axes']:>5}{r['kin_mj_pin_m']:>14.1e}{r['kin_urdf_m']:>12.1e}"
              f"{100 * r['frf_peak_err_max']:>12.3f}  {' '.join(f'{v:.1f}' for v in r['f_arm']):<36}"
              f"{r['margin_deg']:>8.1f}{100 * r['fit_ok']:>7.0f}%{100 * r['fit_f_err_p50_p95_max'][1]:>12.3f}"
              f"{100 * r['unseen_f_err_p50_p95'][0]:>13.2f} / {100 * r['unseen_f_err_p50_p95'][1]:<4.2f}"
              f"{100 * r['unseen_paired']:>7.0f}%")
    out = {"robots": names, "frf_peak_err_max": float(max(all_peaks)), "kinematics_err_max_m": kin_max,
           "kinematics_urdf_err_max_m": max(r["kin_urdf_m"] for r in rows.values()),
           "fit_f_err_p95": {n: r["fit_f_err_p50_p95_max"][1] for n, r in rows.items()},
           "unseen_f_err_p95": {n: r["unseen_f_err_p50_p95"][1] for n, r in rows.items()},
           "bundled_same": all(r["bundled_same"] for r in rows.values())}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
