"""MDOF modal fitting (issue 4): accuracy against ground truth and against sdypy-EMA, and speed.

1. The seed's full campaign (time domain, default noise; run here unless ``--data`` gives one) is
   fitted by rmbench fully automatically (2 workers): per tracked mode, the 95th percentile over
   postures of |f error| and |ζ error| and the 5th percentile of MAC(φR), MAC(φL); the share of
   postures where a mode meets all of f ≤ 0.5 %, ζ ≤ 10 %, MAC ≥ 0.98; the reconstruction NMSE.
   Scored per exact mode (ground-truth numbering) over the postures where the truth has it.
2. The same FRFs of a posture subset fitted by sdypy-EMA (LSCF + LSFD per reference, poles picked
   at the exact natural frequencies: its best case), errors and time beside rmbench's.
3. One posture (both bands) on one core.

Last line: one JSON object with the headline figures (per mode, then the worst mode).

usage: python bench/modal_vs_sdypy.py [--data CAMPAIGN.nc] [--sdypy-postures 16]
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core per process, as the targets say
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from rmbench.impact import load_config, open_campaign, run_campaign  # noqa: E402
from rmbench.modal.campaign_fit import fit_campaign, truth_scores  # noqa: E402

sys.path.insert(0, str(Path(__file__).parent))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--data", default=None)
    ap.add_argument("--sdypy-postures", type=int, default=16)
    args = ap.parse_args()
    if args.data:
        data = Path(args.data)
    else:
        data = Path(tempfile.mkdtemp()) / "seed_full.nc"
        run_campaign(load_config("seed_full"), data, workers=2, progress=False)
    ds = open_campaign(data)

    t0 = time.perf_counter()
    fit = fit_campaign(ds, workers=2)
    t_fit = time.perf_counter() - t0
    n_post = ds.sizes["posture"]
    print(f"rmbench: {n_post} postures fitted in {t_fit:.1f} s on 2 workers (target <= 60 s); "
          f"{int(fit.fit_ok.sum())} of {fit.fit_ok.size} band fits ok (not flagged); "
          f"{fit.sizes['mode']} tracked modes")
    scores = truth_scores(fit, ds)
    print("  per exact mode, over the postures where the truth has it (a mode the fit missed fails):")
    print(f"  {'mode':>4} {'band':>5} {'f_n Hz':>8} {'postures':>9} {'|f err| p95':>12} {'|zeta err| p95':>15} "
          f"{'MAC p05':>8} {'postures ok':>12}")
    for m in range(scores.sizes["truth_mode"]):
        r = scores.isel(truth_mode=m)
        print(f"  {m + 1:>4} {str(r.band.values):>5} {float(r.f_n):8.2f} {int(r.present):9d} "
              f"{float(r.f_err_p95):12.5f} {float(r.zeta_err_p95):15.4f} {float(r.mac_p05):8.4f} "
              f"{float(r.ok_frac):12.3f}")
    f_p95, z_p95 = scores.f_err_p95.values, scores.zeta_err_p95.values
    mac_p05, ok_frac = scores.mac_p05.values, scores.ok_frac.values
    direct = fit.nmse.values[..., [0, 1, 2, 3], [0, 1, 2, 3]]
    print(f"  reconstruction NMSE of the direct FRFs in band: p95 {np.nanpercentile(direct, 95):.5f}, "
          f"all 16 FRFs p95 {np.nanpercentile(fit.nmse.values, 95):.5f} (target <= 0.01)")

    # sdypy-EMA on a subset of postures, per band, poles picked at the exact frequencies
    from _sdypy_peer import sdypy_fit

    subset = np.linspace(0, n_post - 1, min(args.sdypy_postures, n_post)).astype(int)
    sd_f, sd_z, rm_f, rm_z, t_sd, t_rm = [], [], [], [], 0.0, 0.0
    from rmbench.modal.campaign_fit import fit_posture

    for p in subset:
        for band in ("low", "high"):
            sel = ds.band.values == band
            exact = ds.modal_exact.values[p]
            em = [m for m in range(exact.shape[0]) if ds.mode_band.values[m] == band and np.isfinite(exact[m, 0])]
            f_ex, z_ex = exact[em, 0], exact[em, 1]
            r = sdypy_fit(ds.freq.values[sel], ds.H.values[p][sel], f_ex)
            t_sd += r["seconds"]
            sd_f.append(np.abs(np.asarray(r["f_n"]) - f_ex) / f_ex)
            sd_z.append(np.abs(np.asarray(r["zeta"]) - z_ex) / z_ex)
            t1 = time.perf_counter()
            rr = fit_posture(ds.freq.values[sel], ds.H.values[p][sel], ds.coherence.values[p][sel])
            t_rm += time.perf_counter() - t1
            if rr["ok"]:
                for fn, z in zip(f_ex, z_ex):
                    j = int(np.argmin(np.abs(rr["params"][:, 0] - fn)))
                    rm_f.append(abs(rr["params"][j, 0] - fn) / fn)
                    rm_z.append(abs(rr["params"][j, 1] - z) / z)
    sd_f = np.concatenate([x.ravel() for x in sd_f])
    sd_z = np.concatenate([x.ravel() for x in sd_z])
    print(f"\nSame FRFs, {len(subset)} postures x 2 bands (sdypy: each of the 4 references fitted apart):")
    print(f"  {'':>10} {'|f err| p95':>12} {'|zeta err| p95':>15} {'time s':>8}")
    print(f"  {'rmbench':>10} {np.percentile(rm_f, 95):12.5f} {np.percentile(rm_z, 95):15.4f} {t_rm:8.2f}")
    print(f"  {'sdypy-EMA':>10} {np.nanpercentile(sd_f, 95):12.5f} {np.nanpercentile(sd_z, 95):15.4f} {t_sd:8.2f}")
    print(f"  time ratio rmbench / sdypy-EMA: {t_rm / t_sd:.2f}")

    # one posture, both bands, one core
    times = []
    for p in subset[:5]:
        t1 = time.perf_counter()
        for band in ("low", "high"):
            sel = ds.band.values == band
            fit_posture(ds.freq.values[sel], ds.H.values[p][sel], ds.coherence.values[p][sel])
        times.append(time.perf_counter() - t1)
    print(f"\nOne posture, both bands, one core: median {np.median(times):.3f} s (target <= 1 s)")
    print(json.dumps({"f_err_p95": round(float(np.nanmax(f_p95)), 6), "zeta_err_p95": round(float(np.nanmax(z_p95)), 5),
                      "mac_p05": round(float(np.nanmin(mac_p05)), 5), "postures_ok_frac": round(float(min(ok_frac)), 4),
                      "campaign_fit_s": round(t_fit, 2),
                      "sdypy_f_err_p95": round(float(np.nanpercentile(sd_f, 95)), 6),
                      "sdypy_zeta_err_p95": round(float(np.nanpercentile(sd_z, 95)), 5),
                      "time_ratio_rmbench_over_sdypy": round(t_rm / t_sd, 3)}))


if __name__ == "__main__":
    main()
