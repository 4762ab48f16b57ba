"""RCSA (issue 16): tool change and robot-supported part, scored against the simulated assemblies.

1. Finite-difference rotations (METHODS.md §3) against the simulator's exact rotational
   receptances at validation posture 2: exact translations at several spacings S (truncation), and
   the time-domain campaigns' measured translations at the seed's S (noise).
2. Tool change (METHODS.md §4), dummy rod -> 2-flute end mill: reference-tool time-domain campaigns
   (hand-held hammer, the seed's sensors and spacings) at the three validation postures, target-tool
   campaigns at validation posture 1 for the contact fit; the target's tip FRFs (H_1x1x, H_1x1y,
   H_1y1x, H_1y1y) predicted at postures 2 and 3 and scored at every peak of both bands against
   the simulated robot carrying the end mill (same joint commands). Repeated over independent
   campaign seeds (noise, hammer scatter, sensor calibration); both rotation methods; the target
   contact fitted either on the seed's high band (600-1400 Hz) of the reference and target
   campaigns, or on a tool calibration of both tools at validation posture 1 (the bundled
   ``tool_calibration`` config: high band to 3.5 kHz, steel tip), which holds the tool-on-holder
   mode (2.7 kHz) where the contact shows.
3. Contact identification: the fitted target contact against the one built into the simulator,
   from exact and from measured FRFs, on both bands; with the Timoshenko beam as the tools'
   substructure (as a lab would) and with the simulator's own two-segment tool (``tool_model=
   "lumped"``), which takes the beam's model-form error out and shows what the identification
   itself can do — over ``--cal-seeds`` tool calibrations; and the rotational damping's whole
   effect on the tip FRFs against the calibration's measurement error.
4. Robot-supported plate (METHODS.md §6): RCSA from the simulated robot and part FRFs against the
   simulated assembly: main low mode, amplitude reductions, rigid joint, 20 mm sensor offset.

Last line: ``{"tool_peak_err_max", "tool_peak_freq_err_max", "contact_param_err_max",
"contact_param_err_max_lumped", "part_low_mode_err", "reduction_err_pp"}`` (tool errors: worst over
seeds, postures 2-3, the seed's finite-difference method with the contact from the tool
calibration; contact: worst of the fitted k_t, c_t over seeds, from the tool calibration with the
beam model; ``_lumped``: worst of k_t, k_r, c_t over the calibrations with the simulator's own tool
and the translations at 1 and 1a).

usage: python bench/rcsa.py [--work DIR] [--seeds N] [--cal-seeds N]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
import warnings
from dataclasses import replace
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

from rmbench.impact import default_lines, load_config, run_campaign  # noqa: E402
from rmbench.rcsa import (FULL_COORDS, POINT_COORDS, campaign_receptance,  # noqa: E402
                          change_tool, full_receptance, identify_contact)
from rmbench.rcsa.contact import Contact  # noqa: E402
from rmbench.rcsa.support import support_study  # noqa: E402
from rmbench.rcsa.tool_change import predict_campaign_tool  # noqa: E402
from rmbench.robot import Posture, Robot, validation_postures  # noqa: E402
from rmbench.robot.tool import TOOLS, tool_xml  # noqa: E402

VP = [[1800.0, -200.0, 0.0], [1800.0, 200.0, 0.0], [1800.0, 200.0, 60.0]]
REF, TGT = TOOLS["dummy"], TOOLS["endmill"]


def campaign(work: Path, name: str, tool: str, postures, seed: int, *, ideal_hammer: bool = False) -> xr.Dataset:
    """The seed's campaign at ``postures``; ``ideal_hammer``: every hit exactly along X or Y (the
    hand-held hammer's 0.2° direction scatter off)."""
    out = work / f"{name}{'_ideal' if ideal_hammer else ''}_s{seed}.nc"
    if not out.exists():
        base = load_config("seed_full")
        bands = base.model_dump()["bands"]
        if ideal_hammer:
            for band in bands.values():
                band["hammer"]["direction_scatter_deg"] = 0.0
        cfg = base.with_overrides(name=name, seed=seed, robot_tool=tool, bands=bands,
                                  grid={"kind": "list", "postures": postures})
        run_campaign(cfg, out, workers=2, progress=False)
    return xr.load_dataset(out)


def calibration(work: Path, tool: str, seed: int, *, hammer: dict | None = None,
                noise_scale: float = 1.0) -> xr.Dataset:
    """The bundled tool calibration (validation posture 1, 600-3500 Hz, steel tip) with ``tool``;
    ``hammer``: high-band hammer settings changed, ``noise_scale``: the sensors' noise scaled."""
    tag = "" if hammer is None and noise_scale == 1.0 else "_" + "_".join(
        f"{k}{v:g}" for k, v in sorted((hammer or {}).items())) + f"_n{noise_scale:g}"
    out = work / f"cal_{tool}_s{seed}{tag}.nc"
    if not out.exists():
        cfg = load_config("tool_calibration")
        over = {}
        if hammer:
            bands = cfg.model_dump()["bands"]
            bands["high"]["hammer"].update(hammer)
            over["bands"] = bands
        cfg = cfg.with_overrides(seed=seed, robot_tool=tool, noise_scale=noise_scale, **over)
        run_campaign(cfg, out, workers=2, progress=False)
    return xr.load_dataset(out)


def fd_table(ref_ds: xr.Dataset) -> None:
    print("1. Finite-difference rotations against the exact ones, validation posture 2 "
          "(largest error of each entry relative to its peak over the band)")
    op = Robot.load("irb6660", tool="dummy").at(validation_postures()[1])
    print(f"  {'band':<6}{'input':<26}{'S mm':>6}{'L_xx':>8}{'N_xx':>8}{'P_xx':>8}{'P_yy':>8}{'L_xy':>8}")
    grid = default_lines()
    for band, f, s_list in (("low", grid["low"], (0.005, 0.0334)),
                            ("high", grid["high"], (0.005, 0.010, 0.013, 0.020, 0.030))):
        exact = op.frf(f, FULL_COORDS)
        rows = [(f"exact translations", s, full_receptance(op.frf(f, POINT_COORDS, s_1a=s), s)) for s in s_list]
        t = campaign_receptance(ref_ds, 1, band)
        rows.append(("measured (time domain)", float(ref_ds.attrs[f"sensor_spacing_{band}"]), t.values))
        ex = op.frf(t.freq.values, FULL_COORDS)
        for label, s, tt in rows:
            e = exact if tt.shape == exact.shape else ex
            err = np.max(np.abs(tt - e), axis=0) / np.max(np.abs(e), axis=0)
            print(f"  {band:<6}{label:<26}{1e3 * s:>6.1f}" + "".join(
                f"{100 * err[i, j]:>7.1f}%" for i, j in ((0, 1), (1, 0), (1, 1), (3, 3), (0, 3))))
    print("  (the tool's tip segment is rigid for 13.8 mm: below that S the difference is exact; "
          "above it the bending hinge truncates; noise grows as 1/S, 1/S² in P)\n")


def lumped_identification(work: Path, ref_op, tgt_op, seed0: int, n_seeds: int) -> float:
    """Section 3's lines with the simulator's own tool as the substructure; returns the worst
    |error| of k_t, k_r, c_t over the calibrations (translations at 1 and 1a, all three free)."""
    free3, free4 = ("k_t", "k_r", "c_t"), ("k_t", "k_r", "c_t", "c_r")

    def errs(c):
        return np.array([c.k_t / TGT.k_t - 1, c.k_r / TGT.k_r - 1, c.c_t / TGT.c_t - 1, c.c_r / TGT.c_r - 1])

    f = np.arange(600.0, 3500.1, 2.0)
    for free in (free3, free4):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fit = identify_contact(ref_op.frf(f, FULL_COORDS), tgt_op.frf(f, ("1X", "1Y")), f, REF, TGT,
                                   free=free, tool_model="lumped")
        e = errs(fit.contact)
        print(f"  exact FRFs 600-3500 Hz, lumped tool model, free {','.join(free):<12} k_t {e[0]:+.4f}  "
              f"k_r {e[1]:+.4f}  c_t {e[2]:+.4f}  c_r {e[3]:+.4f}  at bound {list(fit.at_bound)}")
    # the calibration's as-tested exact FRFs (accelerometers' mass and cross-axis sensitivity in)
    cr0, ct0 = calibration(work, "dummy", seed0), calibration(work, "endmill", seed0)
    for ml, xa in ((False, False), (True, False), (True, True)):
        r = predict_campaign_tool(cr0.assign(H=cr0["H_exact"]), 0, TGT, calibration=(ct0.assign(H=ct0["H_exact"]), 0),
                                  calibration_reference=cr0.assign(H=cr0["H_exact"]), method="beam",
                                  tool_model="lumped", free=free3, bands=("high",), mass_loading=ml, cross_axis=xa,
                                  hit_offset=False)  # H_exact: hit at the nominal points
        e = errs(r.contact_fit.contact)
        print(f"  as-tested exact FRFs of the calibration (sensors on), lumped tool model, points, free k_t,k_r,c_t, "
              f"{'with' if ml else 'without'} the mass-loading correction, {'with' if xa else 'without'} the "
              f"cross-axis correction: k_t {e[0]:+.4f}  k_r {e[1]:+.4f}  c_t {e[2]:+.4f}")
    # the measurement's own share: the calibration with everything random off, then the hammer's
    # location scatter alone off (at the tip the hits can only land above the tip: a one-sided shift)
    for label, hammer, scale in (("noise and hit scatter off", dict(force_scatter=0.0, location_scatter_mm=0.0,
                                                                      direction_scatter_deg=0.0, load_cell_noise_n=0.0), 0.0),
                                 ("the hammer's location scatter off", dict(location_scatter_mm=0.0), 1.0)):
        pair = [calibration(work, tool, seed0, hammer=hammer, noise_scale=scale) for tool in ("dummy", "endmill")]
        r = predict_campaign_tool(pair[0], 0, TGT, calibration=(pair[1], 0), calibration_reference=pair[0],
                                  method="beam", tool_model="lumped", free=free3, bands=("high",))
        e = errs(r.contact_fit.contact)
        print(f"  measured calibration, {label} (seed {seed0}), lumped tool model, points, free k_t,k_r,c_t: "
              f"k_t {e[0]:+.4f}  k_r {e[1]:+.4f}  c_t {e[2]:+.4f}")
    rows = {}
    # (rotation method, free parameters, mass loading, cross axis, hit offset) taken off
    cases = (("beam", free3, True, True, True), ("beam", free3, True, True, False),
             ("beam", free3, True, False, True), ("beam", free3, False, True, True),
             ("difference", free3, True, True, True), ("beam", free4, True, True, True))
    for s in range(seed0, seed0 + n_seeds):
        cr, ct = calibration(work, "dummy", s), calibration(work, "endmill", s)
        for case in cases:
            method, free, ml, xa, ho = case
            r = predict_campaign_tool(cr, 0, TGT, calibration=(ct, 0), calibration_reference=cr, method=method,
                                      tool_model="lumped", free=free, bands=("high",), mass_loading=ml,
                                      cross_axis=xa, hit_offset=ho)
            rows.setdefault(case, []).append((errs(r.contact_fit.contact), "c_r" in r.contact_fit.at_bound))
    for (method, free, ml, xa, ho), v in rows.items():
        e = np.array([x[0] for x in v])
        label = ("points through the tool" if method == "beam" else "finite differences") + (
            "" if ml else ", no mass-loading correction") + ("" if xa else ", no cross-axis correction") + (
            "" if ho else ", no hit-offset correction")
        inside = int(np.sum(np.all(np.abs(e[:, :3]) <= 0.10, axis=1)))
        print(f"  measured calibrations, lumped tool model, {label}, free {','.join(free)}, {len(e)} seeds: "
              + ", ".join(f"{n} {100 * e[:, i].min():+.1f} .. {100 * e[:, i].max():+.1f} % (mean {100 * e[:, i].mean():+.1f})"
                          for i, n in enumerate(("k_t", "k_r", "c_t", "c_r")) if n in free)
              + f"; k_t, k_r, c_t all within 10 %: {inside}/{len(e)}"
              + (f"; c_r on its bound: {sum(x[1] for x in v)}/{len(v)}" if len(free) == 4 else ""))
    worst = float(np.abs(np.array([x[0] for x in rows["beam", free3, True, True, True]])[:, :3]).max())
    # what 10 % of k_r does to the tip FRFs, against the measurement's own error
    hi = ct0["band"].values == "high"
    fh = ct0["freq"].values[hi]
    q = ct0["q_cmd"].values[0]
    t_ref = Robot.load("irb6660", tool="dummy").at(q).frf(fh, FULL_COORDS)
    k = Contact.of(TGT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        base = change_tool(t_ref, fh, REF, TGT, tool_model="lumped").t[:, 0::2, 0::2]
        moved = change_tool(t_ref, fh, REF, TGT, tool_model="lumped",
                            target_contact=Contact(k.k_t, 1.1 * k.k_r, k.c_t, k.c_r)).t[:, 0::2, 0::2]
    d_kr = np.abs(moved - base).max(axis=0) / np.abs(base).max(axis=0)
    sel = {"out": ["1X", "1Y"], "inp": ["1X", "1Y"]}
    h_m = ct0["H"].isel(posture=0).sel(**sel).transpose("freq", "out", "inp").values[hi]
    h_x = ct0["H_exact"].isel(posture=0).sel(**sel).transpose("freq", "out", "inp").values[hi]
    e_m = np.abs(h_m - h_x) / np.abs(h_x).max(axis=0)
    print(f"  k_r: +10 % moves the direct tip entries by {100 * d_kr[0, 0]:.2f} / {100 * d_kr[1, 1]:.2f} % of their peaks; "
          f"the calibration's measured direct entries are off their as-tested exact values by up to "
          f"{100 * e_m[:, 0, 0].max():.2f} / {100 * e_m[:, 1, 1].max():.2f} % (median {100 * np.median(e_m[:, 0, 0]):.2f} / "
          f"{100 * np.median(e_m[:, 1, 1]):.2f} %, seed {seed0}) -- "
          + (f"10 % of k_r is {min(d_kr[0, 0] / e_m[:, 0, 0].max(), d_kr[1, 1] / e_m[:, 1, 1].max()):.1f} times "
             "the measurement's largest error" if min(d_kr[0, 0] / e_m[:, 0, 0].max(), d_kr[1, 1] / e_m[:, 1, 1].max()) > 1
             else "not identifiable within 10 % from measured FRFs"))
    # the rotational damping's whole effect on the tip entries
    tool_file = work / "endmill_no_c_r.xml"
    tool_file.write_text(tool_xml(replace(TGT, c_r=0.0)))
    with_cr = Robot.load("irb6660", tool="endmill").at(q).frf(fh, ("1X", "1Y"))
    without = Robot.load("irb6660", tool=tool_file).at(q).frf(fh, ("1X", "1Y"))
    effect = np.abs(with_cr - without).max(axis=0) / np.abs(with_cr).max(axis=0)
    print(f"  c_r: removing it altogether moves the direct tip entries (600-3500 Hz) by {100 * effect[0, 0]:.3f} / "
          f"{100 * effect[1, 1]:.3f} % of their peaks, "
          f"{min(e_m[:, 0, 0].max() / effect[0, 0], e_m[:, 1, 1].max() / effect[1, 1]):.0f} times less than the "
          "measurement's error above -- not identifiable from tip FRFs")
    return worst


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", help="folder for the campaigns (reused when present)")
    ap.add_argument("--seeds", type=int, default=5, help="independent campaign draws (default 5)")
    ap.add_argument("--cal-seeds", type=int, default=20,
                    help="tool calibrations for the contact identification's rates (default 20)")
    args = ap.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="rcsa_"))
    work.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    seeds = [2024 + k for k in range(args.seeds)]
    refs = {s: campaign(work, "ref", "dummy", VP, s) for s in seeds}
    tgts = {s: campaign(work, "tgt", "endmill", VP[:1], s) for s in seeds}
    cals = {s: (calibration(work, "dummy", s), calibration(work, "endmill", s)) for s in seeds}
    print(f"campaigns: {len(seeds)} seeds x (3 reference + 1 target postures, and a tool calibration of "
          f"each tool), {time.perf_counter() - t0:.0f} s\n")

    fd_table(refs[seeds[0]])

    print("2. Tool change dummy -> endmill: every peak of the four tip entries in both bands, "
          "target contact fitted at validation posture 1")
    print(f"  {'method, contact fitted on':<36}{'seed':>6}{'posture':>9}{'peaks':>7}{'amp err max':>13}"
          f"{'freq err max':>14}{'k_t fit':>10}{'c_t fit':>10}")
    worst = {}
    by_class = {}           # method -> {"direct": [], "cross": []} frequency errors of every peak
    cases = [(m, c) for m in ("difference", "beam") for c in ("calibration", "seed band")]
    names = {(m, c): f"{m}, {'calibration to 3.5 kHz' if c == 'calibration' else 'seed band'}" for m, c in cases}
    rates = {names[k]: [] for k in cases}
    fits = []
    for method, cal in cases:
        name = names[method, cal]
        for s in seeds:
            kw = ({"calibration": (cals[s][1], 0), "calibration_reference": cals[s][0]} if cal == "calibration"
                  else {"calibration": (tgts[s], 0)})
            for i in (1, 2):
                r = predict_campaign_tool(refs[s], i, TGT, method=method, **kw)
                amp = max(abs(p.amp_err) for p in r.peaks)
                fr = max(abs(p.freq_err) for p in r.peaks)
                k = r.bands["high"].target_contact
                worst.setdefault(name, []).append((amp, fr))
                for p in r.peaks:
                    cls = "cross" if p.entry in ("1X/1Y", "1Y/1X") else "direct"
                    by_class.setdefault(name, {"direct": [], "cross": []})[cls].append(
                        (abs(p.freq_err), abs(p.amp_err), p.entry, p.f_true))
                rates[name].append(amp <= 0.10 and fr <= 0.01)
                if i == 1:
                    fits.append((name, k))
                print(f"  {name:<36}{s:>6}{i + 1:>9}{len(r.peaks):>7}{100 * amp:>12.2f}%{100 * fr:>13.2f}%"
                      f"{k.k_t / TGT.k_t - 1:>+10.3f}{k.c_t / TGT.c_t - 1:>+10.3f}")
    for m, w in worst.items():
        a = np.array(w)
        print(f"  {m}: worst amplitude {100 * a[:, 0].max():.2f} %, worst frequency {100 * a[:, 1].max():.2f} %; "
              f"cases within 10 % and 1 %: {sum(rates[m])}/{len(rates[m])}")
        for cls, label in (("direct", "direct entries (1X/1X, 1Y/1Y)"), ("cross", "X<->Y cross entries")):
            e = by_class[m][cls]
            w = max(e)
            print(f"    {label:<31} {len(e):>3} peaks: worst frequency {100 * w[0]:.2f} % "
                  f"({w[2]} at {w[3]:.2f} Hz), worst amplitude {100 * max(x[1] for x in e):.2f} %")
    # the cross entries' peak frequencies with the hammer struck exactly along X and Y
    ideal = []
    for s in seeds[:3]:
        ref_i, tgt_i = (campaign(work, "ref", "dummy", VP, s, ideal_hammer=True),
                        campaign(work, "tgt", "endmill", VP[:1], s, ideal_hammer=True))
        for i in (1, 2):
            r = predict_campaign_tool(ref_i, i, TGT, calibration=(tgt_i, 0), method="difference")
            ideal += [(abs(p.freq_err), p.entry in ("1X/1Y", "1Y/1X")) for p in r.peaks]
    print(f"  ideal hammer (no direction scatter), seeds {seeds[0]}-{seeds[min(2, len(seeds) - 1)]}, difference: "
          f"worst frequency direct {100 * max(e for e, c in ideal if not c):.2f} %, "
          f"cross {100 * max(e for e, c in ideal if c):.2f} %")
    # catalogue contact and no shank change, first seed: what each ingredient is worth
    s = seeds[0]
    a = [predict_campaign_tool(refs[s], i, TGT, calibration=(cals[s][1], 0), calibration_reference=cals[s][0],
                               mass_loading=False) for i in (1, 2)]
    print(f"  seed {s}, accelerometers left off the substructures (no mass-loading correction): worst amplitude "
          f"{100 * max(abs(p.amp_err) for r in a for p in r.peaks):.2f} %, frequency "
          f"{100 * max(abs(p.freq_err) for r in a for p in r.peaks):.2f} %, fitted k_t "
          f"{a[0].bands['high'].target_contact.k_t / TGT.k_t - 1:+.3f}, c_t "
          f"{a[0].bands['high'].target_contact.c_t / TGT.c_t - 1:+.3f}")
    for label, kw in (("catalogue contact", {}), ("catalogue contact, no shank change", {"shank": False})):
        a = [predict_campaign_tool(refs[s], i, TGT, **kw) for i in (1, 2)]
        amp = max(abs(p.amp_err) for r in a for p in r.peaks)
        fr = max(abs(p.freq_err) for r in a for p in r.peaks)
        print(f"  seed {s}, {label}: worst amplitude {100 * amp:.2f} %, frequency {100 * fr:.2f} %")
    print()

    print("3. Contact identification at validation posture 1 (relative error against the simulator's "
          f"k_t {TGT.k_t:.3g}, k_r {TGT.k_r:.3g}, c_t {TGT.c_t:.3g}, c_r {TGT.c_r:.3g})")
    ref_op = Robot.load("irb6660", tool="dummy").at(refs[s]["q_cmd"].values[0])
    tgt_op = Robot.load("irb6660", tool="endmill").at(refs[s]["q_cmd"].values[0])
    for f_max in (1400.0, 3500.0):
        f = np.arange(600.0, f_max + 0.1, 2.0)
        for label, free in (("k_t, c_t (default)", ("k_t", "c_t")), ("k_t, k_r, c_t", ("k_t", "k_r", "c_t")),
                            ("all four", ("k_t", "k_r", "c_t", "c_r"))):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                fit = identify_contact(ref_op.frf(f, FULL_COORDS), tgt_op.frf(f, ("1X", "1Y")), f, REF, TGT,
                                       free=free)
            c = fit.contact
            print(f"  exact FRFs 600-{f_max:.0f} Hz, free {label:<19} k_t {c.k_t / TGT.k_t - 1:+.3f}  "
                  f"k_r {c.k_r / TGT.k_r - 1:+.3f}  c_t {c.c_t / TGT.c_t - 1:+.3f}  c_r {c.c_r / TGT.c_r - 1:+.3f}  "
                  f"at bound {list(fit.at_bound)}")
    f = default_lines()["high"]
    # what the exact-FRF c_t error is made of: the rotational contact held at the reference's values,
    # and the tool's structural damping (hysteretic in the beam, viscous at the first bending mode
    # in the simulator)
    exact_args = (ref_op.frf(f, FULL_COORDS), tgt_op.frf(f, ("1X", "1Y")), f)
    k_true = Contact.of(TGT)
    for label, kw in (("target's true k_r, c_r held", {"start": Contact(1.3 * k_true.k_t, k_true.k_r, 2 * k_true.c_t,
                                                                        k_true.c_r)}),
                      ("no tool structural damping", {"reference": replace(REF, loss_factor=1e-9),
                                                      "target": replace(TGT, loss_factor=1e-9)})):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            c = identify_contact(*exact_args, kw.get("reference", REF), kw.get("target", TGT),
                                 free=("k_t", "c_t"), start=kw.get("start")).contact
        print(f"  exact FRFs, free k_t, c_t, {label:<28} k_t {c.k_t / TGT.k_t - 1:+.3f}  c_t {c.c_t / TGT.c_t - 1:+.3f}")
    for case in cases:
        kt = np.array([k.k_t / TGT.k_t - 1 for m, k in fits if m == names[case]])
        ct = np.array([k.c_t / TGT.c_t - 1 for m, k in fits if m == names[case]])
        print(f"  measured FRFs ({names[case]}), over {len(kt)} seeds: k_t {100 * kt.min():+.1f} .. "
              f"{100 * kt.max():+.1f} %, c_t {100 * ct.min():+.1f} .. {100 * ct.max():+.1f} %")
    print("  the contact acts on the tool-on-holder mode (2.7 kHz, above the seed's band): from 600-1400 Hz "
          "its damping barely shows and c_t absorbs any model error; the calibration band holds the mode")
    main_case = names["difference", "calibration"]
    kt = np.array([k.k_t / TGT.k_t - 1 for m, k in fits if m == main_case])
    ct = np.array([k.c_t / TGT.c_t - 1 for m, k in fits if m == main_case])
    print("  k_r and c_r stay at the reference's values: the rotational contact's compliance is ~2 % of the "
          "overhang's bending compliance, so a 0.1 % beam-model error moves a fitted k_r by a factor of 2-27")
    lumped = lumped_identification(work, ref_op, tgt_op, seeds[0], args.cal_seeds)
    print()

    print("4. Robot-supported plate (irb6660 at 1800, 0, 0; plate 450 x 100 x 6 mm C45, K_x 2e7 N/m, "
          "preload 100 N)")
    robot = Robot.load("irb6660")
    q = robot.ik(Posture.from_mm_deg(1800, 0, 0)).q
    t1 = time.perf_counter()
    d = support_study(robot, q).to_dict()
    print(f"  part modes {', '.join(f'{x:.1f}' for x in d['part_modes_hz'][:3])} Hz (seed 212, 567); "
          f"robot's largest low peak {d['robot_low_mode_hz']:.2f} Hz")
    print(f"  assembled main low mode: simulated {d['low_mode_sim_hz']:.3f} Hz, RCSA {d['low_mode_rcsa_hz']:.3f} Hz, "
          f"error {100 * d['low_mode_err']:+.4f} % (seed: 29 -> 38 Hz, RCSA error 0.25 %)")
    for k in range(2):
        print(f"  reduction at part mode {k + 1}: simulated {100 * d['reduction_sim'][k]:.3f} %, RCSA "
              f"{100 * d['reduction_rcsa'][k]:.3f} %, rigid joint {100 * d['reduction_rcsa_rigid'][k]:.3f} % "
              f"(seed: {['99.96/99.96', '99.87/99.94'][k]} % measured/predicted)")
    print(f"  largest difference RCSA vs simulated assembly: {100 * d['rcsa_vs_sim_max_rel']:.3f} % of the peak "
          "(the preload's shift of the robot's equilibrium)")
    print(f"  sensor 20 mm off the joint fed to Eq. 6: up to {d['offset_db_near_part_mode_2']:.1f} dB off within "
          f"±10 % of part mode 2 (worst {d['offset_worst_db']:.1f} dB at {d['offset_worst_hz']:.1f} Hz); "
          f"Eqs. 12-14 with the sensor as its own coordinate: {100 * d['eq12_14_at_sensor_max_rel']:.3f} % of the peak")
    print(f"  ({time.perf_counter() - t1:.1f} s)\n")

    a = np.array(worst[main_case])
    print(json.dumps({
        "tool_peak_err_max": round(float(a[:, 0].max()), 4),
        "tool_peak_freq_err_max": round(float(a[:, 1].max()), 5),
        "contact_param_err_max": round(float(max(np.abs(kt).max(), np.abs(ct).max())), 4),
        "contact_param_err_max_lumped": round(lumped, 4),
        "part_low_mode_err": round(abs(float(d["low_mode_err"])), 6),
        "reduction_err_pp": round(float(d["reduction_err_pp"]), 6)}))


if __name__ == "__main__":
    main()
