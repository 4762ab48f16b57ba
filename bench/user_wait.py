"""What users wait for (issue 37): the user's commands on a fresh 112-posture campaign, each timed
as a whole process, as a user runs them on 2 cores.

1. Raw RK4: MuJoCo's ``mj_step`` on each band's simulation model at the campaign's time step, one
   core, in this process, before and after the campaign (the higher is kept): the step rate a
   campaign worker cannot beat.
2. ``rmbench campaign run seed_full`` (time domain, 2 workers): wall time, steps, steps per second
   per worker (steps / wall / workers, start-up included) against the raw rate.
3. ``rmbench modal fit`` of that campaign (2 workers).
4. ``rmbench predict train --model mtgp-grouped`` (veering clusters and out-of-band terms included).
5. The fit and the training started together: each one's time against its time alone.
6. Where the time goes: the top lines of a profile of one campaign posture, of the fits of four
   postures and of the training (cProfile, in this process, cumulative time).

Last line: ``{"fit112_s", "train_s", "campaign112_s", "steps_per_s_worker", "rk4_raw_steps_per_s",
"concurrent_slowdown_max"}``.

usage: python bench/user_wait.py [--work DIR] [--data CAMPAIGN.nc] [--workers 2] [--no-profile]
       (--data: skip the campaign run and time the rest on that campaign)
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
RMBENCH = [str(Path(sys.executable).with_name("rmbench"))]   # the installed command, as a user runs it


def run(args: list[str]) -> float:
    """Run one rmbench command as its own process; its wall time, s (a failure stops the bench)."""
    t0 = time.perf_counter()
    proc = subprocess.run(RMBENCH + args, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        sys.exit(f"rmbench {' '.join(args)} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    return wall


def together(commands: list[list[str]]) -> list[float]:
    """Start the commands at once; each one's wall time, s."""
    t0 = time.perf_counter()
    procs = [subprocess.Popen(RMBENCH + c, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
             for c in commands]
    walls = [0.0] * len(procs)
    pending = set(range(len(procs)))
    while pending:
        for i in list(pending):
            if procs[i].poll() is not None:
                walls[i] = time.perf_counter() - t0
                pending.discard(i)
                if procs[i].returncode != 0:
                    sys.exit(f"rmbench {' '.join(commands[i])} failed:\n{procs[i].stderr.read()[-2000:]}")
        time.sleep(0.05)
    return walls


def raw_rk4_rates(config: str = "seed_full") -> tuple[dict, float]:
    """MuJoCo's bare ``mj_step`` rate (steps/s, best of 3, one thread) on each band's simulation
    model at the grid's first posture and the campaign's time step, as ``{band: (dt, steps a
    posture, rate)}``, and the rate over a posture's mix of bands (Σ steps / Σ band steps / rate)."""
    from _profile import band_models, raw_rk4_rate

    from rmbench.impact import load_config
    from rmbench.impact.campaign import Campaign, postures_of

    cfg = load_config(config)
    campaign = Campaign.build(cfg)
    bands = band_models(campaign, postures_of(cfg, campaign.robot)[0])
    rates = {name: (dt, steps, max(raw_rk4_rate(op_sim, dt) for _ in range(3)))
             for name, (op_sim, dt, steps) in bands.items()}
    mixed = sum(s for _, s, _ in rates.values()) / sum(s / r for _, s, r in rates.values())
    return rates, mixed


def profiles(data: Path, modal: Path) -> None:
    """Where the time goes: the top lines of one campaign posture's, four postures' fits' and the
    training's profiles, in this process on one thread (as a worker runs)."""
    import xarray as xr
    from _profile import profile_top

    from rmbench.impact import load_config, open_campaign
    from rmbench.impact.campaign import Campaign, postures_of, run_posture
    from rmbench.modal.campaign_fit import fit_posture
    from rmbench.predict import PosturePredictor
    from rmbench.threads import limit_threads

    limit_threads(1)
    cfg = load_config("seed_full")
    campaign = Campaign.build(cfg)
    posture = postures_of(cfg, campaign.robot)[0]
    print("\nProfile: one campaign posture (both bands, 4 hits x 3 averages), one thread")
    print(profile_top(lambda: run_posture(campaign, 0, posture), 10, sort="tottime"))
    ds = open_campaign(data)

    def fits():
        for p in (0, 37, 74, 111):
            for band in ("low", "high"):
                sel = ds.band.values == band
                fit_posture(ds.freq.values[sel], ds.H.values[p][sel], ds.coherence.values[p][sel])

    print("\nProfile: modal fits of 4 postures x 2 bands, one thread")
    print(profile_top(fits, 14))
    modal_ds = xr.open_dataset(modal, engine="h5netcdf").load()
    # its learners one after the other in this thread, where the profiler sees them
    os.environ["RMBENCH_THREADS"] = "1"
    print("\nProfile: predict train (mtgp-grouped), one thread, its learners in turn")
    print(profile_top(lambda: PosturePredictor("mtgp-grouped").fit(modal_ds), 16, sort="tottime"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", default=None, help="folder for the files (default: a new temporary one)")
    ap.add_argument("--data", default=None, help="an existing 112-posture campaign: skip the campaign run")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-profile", action="store_true")
    args = ap.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="user_wait_"))
    work.mkdir(parents=True, exist_ok=True)
    print(f"host: {os.cpu_count()} cores; work folder {work}")

    import xarray as xr

    rates, raw = raw_rk4_rates()
    if args.data:
        data, t_campaign = Path(args.data), None
    else:
        data = work / "campaign.nc"
        t_campaign = run(["campaign", "run", "seed_full", "--out", str(data), "--workers", str(args.workers),
                          "--force", "--no-progress"])
        after, raw_after = raw_rk4_rates()
        if raw_after > raw:
            rates, raw = after, raw_after
    for name, (dt, steps, r) in rates.items():
        print(f"raw RK4 mj_step, {name} band model, dt {dt * 1e6:.2f} us, {steps} steps a posture: "
              f"{r:,.0f} steps/s (one core)")
    print(f"  over a posture's mix of steps: {raw:,.0f} steps/s (the higher of before and after the campaign)")
    with xr.open_dataset(data, engine="h5netcdf") as ds:
        steps, n_post = int(ds.steps.sum()), ds.sizes["posture"]
        worker_seconds = float(ds.seconds.sum())
    if t_campaign is not None:
        per_worker = steps / t_campaign / args.workers
        print(f"\nrmbench campaign run seed_full ({n_post} postures, {args.workers} workers): {t_campaign:.1f} s, "
              f"{steps / 1e6:.2f} M steps, {per_worker:,.0f} steps/s per worker (steps / wall / workers): "
              f"{per_worker / raw:.1%} of the raw RK4 rate (target >= 85 %)")
        print(f"  inside the workers: {steps / worker_seconds:,.0f} steps/s over the postures' own seconds")
    else:
        per_worker = None
        print(f"\ncampaign {data} given: not timed ({n_post} postures, {steps / 1e6:.2f} M steps)")

    modal = work / "modal.nc"
    t_fit = run(["modal", "fit", str(data), "--out", str(modal), "--workers", str(args.workers)])
    print(f"rmbench modal fit ({n_post} postures, {args.workers} workers): {t_fit:.1f} s (target <= 60 s)")
    t_train = run(["predict", "train", str(modal), "--model", "mtgp-grouped", "--out", str(work / "pred.npz")])
    print(f"rmbench predict train --model mtgp-grouped: {t_train:.1f} s (target <= 60 s)")
    t_fit2, t_train2 = together([["modal", "fit", str(data), "--out", str(work / "modal2.nc"),
                                  "--workers", str(args.workers)],
                                 ["predict", "train", str(modal), "--model", "mtgp-grouped",
                                  "--out", str(work / "pred2.npz")]])
    slow = max(t_fit2 / t_fit, t_train2 / t_train)
    print(f"started together: modal fit {t_fit2:.1f} s ({t_fit2 / t_fit:.2f}x alone), predict train "
          f"{t_train2:.1f} s ({t_train2 / t_train:.2f}x alone); target each <= 2.5x")

    if not args.no_profile:
        profiles(data, modal)

    print(json.dumps({"fit112_s": round(t_fit, 1), "train_s": round(t_train, 1),
                      "campaign112_s": None if t_campaign is None else round(t_campaign, 1),
                      "steps_per_s_worker": None if per_worker is None else round(per_worker),
                      "rk4_raw_steps_per_s": round(raw),
                      "concurrent_slowdown_max": round(slow, 2)}, allow_nan=False))


if __name__ == "__main__":
    main()
