"""Blind calibration bench (issue 38): "real robots" with every ordinary parameter drawn, half of
them with a structural effect too, measured by a time-domain impact campaign, calibrated and
diagnosed, and scored against their exact modes and what was hidden.

Per robot (``bench/truth/robot.py``'s ``draw_truth`` builds its MJCF by text edits, not by rmbench's
parameter code; half stand on a foundation that tilts):

1. a 16-posture campaign (seed grid, drawn) in the time domain, commanded by the nominal robot's
   inverse kinematics, written to UFF58 and read back with the test design as the experimenter
   believes it (nominal robot named), so only FRFs, postures and the design survive;
2. robots 2, 3, 6, 7, ... (half) also carry one structural effect (``truth.structural``: plain MJCF
   edits, a turned sensor applied to the measured signals, never the diagnosis's variant code): in
   the library (a foundation sliding sideways, a tool holder 3-5 times off, a body 30-60 % heavier,
   a sensor turned 6-12°, the spindle spinning) on 2, 3, 10, 11, ..., out of it (a hose package on a
   spring, a tendon coupling two joints, a mass 0.25-0.4 m off a body's origin) on 6, 7, 14, 15, ...;
   whether it shows is decided without the method (``truth.visibility``: the exact FRFs with and
   without it against the campaign's noise on an independent draw, as ``bench/blind_frf.py``
   decides). Sizes are never enlarged and draws never redrawn (issue 79): an invisible draw is
   counted and reported apart (``invisible``), kept in the file, not scored;
3. ``gap diagnose --calibrate`` with every group (12 postures calibrated and searched, 4 held out);
   with ``--plain``, ``rmbench.calibrate.calibrate`` alone on the measured modes (no structural
   half; ``--groups``);
4. scores: held-out frequency and damping errors per measured mode before and after; each
   parameter against its truth (log-scaled ones within 5 %, centres of mass within 5 mm, the base
   within 5 % or 2 µrad/(kN·m); those a structural effect also moves are not scored), whether an
   identifiable one sits on a bound, whether the 95 % interval covers the truth; the calibrated
   model against the truth's exact modes at 200 unseen postures (quasi-random in the grid's box,
   modes a test must see: inside a band and above 1 % of its peak), paired by MAC and frequency;
   the verdict and the effect ranked first against what was hidden;
5. the calibration's own seconds, and separately the default 24-parameter calibration timed on
   one robot with the machine otherwise idle (``--time-default``).

A fresh seed is drawn per run unless ``--seed`` is given, and printed. Each robot's measured FRFs
are kept in ``bench/.cache/`` (or ``--cache DIR``; keyed by seed, robot, method and a digest of
the robot measured, its MJCF and spindle speed: the campaign does not depend on the calibration's
code), so a rerun on changed code measures nothing again; ``--only`` runs the
robots named. Cases go to a JSON-lines file keyed by seed, settings and a digest of the code it runs (its syntax tree without docstrings: a
comment does not start a new run); a rerun with the same key resumes, another key starts a new
file. A robot that cannot hold a posture is rejected: counted, printed and kept in the file, never
silently redrawn. With ``--scheduler ADDRESS`` the robots run on an existing dask cluster, one a
single-threaded worker (its workers need rmbench and the file system of the cache), and
are written as they finish: the same lines as a run here, but for the seconds.

Last line: ``{"cases", "heldout_f_p95_before", "heldout_f_p95_after", "zeta_p95_after",
"ident_within5", "coverage95", "gap_top1_after_calibration", "unexplained_ok",
"spread_false_structural", "calibrate_s", "real_f_mean_before", "real_f_mean_after"}`` (the
real-robot keys come from ``bench/calibrate_real.py`` when its result file exists; top 1 is strict:
the verdict "explained" and the hidden effect ranked first). Its ``gap_rejected_draws`` are the
invisible draws by effect (``kind@location``; until issue 81 the draws rejected as hidden after
enlarging), ``gap_scaled`` is ``[0, effects drawn]`` (no effect is enlarged any more) and
``invisible`` counts the invisible draws; the second line's ``rejected_as_misses`` counts them as
misses of their class.

usage: python bench/calibrate.py [--robots 40] [--seed S] [--workers 2] [--method time] [--plain]
                                 [--groups G] [--gap-groups G] [--time-default] [--only I,J,...]
                                 [--cache DIR] [--scheduler ADDRESS]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import sys
import tempfile
import time
import warnings
import xml.etree.ElementTree as ET
from collections import Counter
from functools import partial
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from _stats import code_digest, fresh_seed, open_lines, resumed_cases, ship_bench_modules, wilson  # noqa: E402
from truth.robot import draw_truth  # noqa: E402
from truth.structural import apply_effect, draw_effect, turned_signals  # noqa: E402
from truth.visibility import visibility  # noqa: E402

from rmbench.calibrate import (CalibrationSettings, ModalModel, TestDesign, calibrate, error_summary,  # noqa: E402
                               load_modal_data)
from rmbench.calibrate.residual import pair  # noqa: E402
from rmbench.parallel import map_cases  # noqa: E402
from rmbench.robot import Posture, Robot, seed_grid  # noqa: E402
from rmbench.robot.parameters import ParameterSet, parse_groups  # noqa: E402

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
CACHE = HERE / ".cache"
N_UNSEEN = 200
N_CAMPAIGN = 16        # postures of a robot's campaign (the seed grid's 112, drawn)


def _digest() -> str:
    import rmbench

    src = Path(rmbench.__file__).parent
    # the FRF diagnosis's modules and the selection engine it shares, not the tracker's, the
    # cases' or the plots'; the truth it is scored on (bench/truth)
    gap = list(src.joinpath("gap", "frf").glob("*.py")) + list(src.joinpath("gap").glob("*.py"))
    gap = [p for p in gap if p.name != "plot.py"]
    files = (list(src.joinpath("calibrate").glob("*.py")) + gap
             + [src / "robot" / "parameters.py", Path(__file__)]
             + [HERE / "truth" / f"{m}.py" for m in ("ordinary", "robot", "structural", "visibility")])
    return code_digest(files)


def _toml(robot: str, postures, method: str, seed: int, commands_from: str | None, *, placement=None,
          rpm: float = 0.0, bands: dict | None = None) -> str:
    """The campaign's TOML: ``seed_full``'s bands, each updated by ``bands`` where given
    (``{"high": {"f_max": 3500.0, "pulse_ms": 0.25}}``: band keys, and the hammer's ``pulse_ms``,
    ``peak_n``)."""
    from rmbench.impact import load_config

    base = load_config("seed_full")
    for band, edits in (bands or {}).items():
        b = base.bands[band]
        hammer = b.hammer.model_copy(update={k: v for k, v in edits.items() if k in ("pulse_ms", "peak_n")})
        b = b.model_copy(update={k: v for k, v in edits.items() if k not in ("pulse_ms", "peak_n")} | {"hammer": hammer})
        base.bands[band] = b
    rows = ", ".join(f"[{1e3 * p.x:.6g}, {1e3 * p.y:.6g}, {np.degrees(p.theta):.6g}]" for p in postures)
    lines = ['name = "calibration bench"', f"seed = {seed}", f'method = "{method}"', "[robot]",
             f'name = "{robot}"', 'tool = "dummy"' if commands_from is None else ""]
    if commands_from:
        lines.append(f'commands_from = "{commands_from}"')
    if rpm:
        lines.append(f"spindle_rpm = {rpm:.6g}")
    lines += ["[grid]", 'kind = "list"', f"postures = [{rows}]"]
    for band, b in base.bands.items():
        lines += [f"[bands.{band}]", f"f_min = {b.f_min}", f"f_max = {b.f_max}", f'sensor = "{b.sensor}"',
                  f"s_1a_mm = {b.s_1a_mm}", f"sample_rate = {b.sample_rate}", f"line_spacing = {b.line_spacing}",
                  f"[bands.{band}.hammer]", f"pulse_ms = {b.hammer.pulse_ms}", f"peak_n = {b.hammer.peak_n}"]
        if placement is not None and any(placement[band]["misalignment_deg"]) \
                or placement is not None and any(placement[band]["position_error_mm"]):
            pe = ", ".join(f"{x:.6g}" for x in placement[band]["position_error_mm"])
            ma = ", ".join(f"{x:.6g}" for x in placement[band]["misalignment_deg"])
            lines += [f"[bands.{band}.placement]", f"position_error_mm = [{pe}]", f"misalignment_deg = [{ma}]"]
    return "\n".join(ln for ln in lines if ln is not None) + "\n"


def measure(truth_xml: str, postures, method: str, seed: int, workers: int, tmp: Path, *, placement=None,
            rpm: float = 0.0, fit: bool = True, bands: dict | None = None):
    """Campaign on the truth, through UFF58, as the experimenter's data (ModalData, fitted; or
    the FRF dataset read back, ``fit=False``); ``bands`` edits the bands (:func:`_toml`)."""
    from rmbench.impact import open_campaign, parse_config, run_campaign
    from rmbench.io import read_uff58, write_uff58

    path = tmp / "real.xml"
    path.write_text(truth_xml)
    true_toml = _toml(str(path), postures, method, seed, commands_from="irb6660", placement=placement, rpm=rpm,
                      bands=bands)
    run_campaign(parse_config(true_toml), tmp / "measured.nc", toml=true_toml, workers=workers, progress=False)
    ds = open_campaign(tmp / "measured.nc")
    if "ok" in ds.coords and not ds.ok.values.all():
        raise RuntimeError("the real robot could not hold a posture")
    ds.attrs.clear()
    ds.attrs["config"] = _toml("irb6660", postures, method, seed, None, bands=bands)
    write_uff58(ds[["H"]], tmp / "uff")
    back = read_uff58(tmp / "uff")
    if not fit:
        return back.load()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return load_modal_data(back, workers=workers)


def measured(xml: str, postures, args, seed: int, i: int, *, placement=None, rpm: float = 0.0):
    """The FRF dataset of robot ``i`` read back from UFF58, from the cache or measured (then cached:
    written whole, so an interrupted run leaves no half file)."""
    import xarray as xr

    import hashlib

    size = "" if len(postures) == N_CAMPAIGN else f"_p{len(postures)}"
    # the robot itself in the name: keyed by seed, robot and size alone, a draw made after a
    # rejected one read the rejected draw's campaign at the same size (seed 16587, robot 2: a tool
    # holder read a heavier forearm's, χ² 763.9 both)
    robot = hashlib.sha256(repr((xml, placement, float(rpm))).encode()).hexdigest()[:10]
    cache = Path(args.cache)
    path = cache / f"calibrate_s{seed}_{i}{size}_{robot}_{args.method}.nc"
    if path.exists():
        return xr.open_dataset(path).load()
    tmp = Path(tempfile.mkdtemp(prefix="rmbench_cal_"))
    try:
        ds = measure(xml, postures, args.method, seed * 1000 + i, args.workers, tmp, placement=placement,
                     rpm=rpm, fit=False)
        cache.mkdir(parents=True, exist_ok=True)
        ds.to_netcdf(tmp / "ds.nc")
        shutil.move(tmp / "ds.nc", path)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return ds


def unseen_postures(rng, n=N_UNSEEN) -> list[Posture]:
    """Quasi-random (scrambled Sobol) postures in the seed grid's box."""
    from scipy.stats import qmc

    s = qmc.Sobol(3, scramble=True, seed=rng).random_base2(int(np.ceil(np.log2(n))))[:n]
    lo, hi = np.array([1300, -300, -60]), np.array([1900, 300, 60])
    return [Posture.from_mm_deg(*(lo + (hi - lo) * r)) for r in s]


def exact_errors(truth: Robot, calibrated: Robot, nominal: Robot, design, postures) -> dict:
    """Frequency errors of the calibrated model against the truth's exact modes (what a test sees)."""
    q = np.array([nominal.ik(p).q for p in postures])
    empty = ParameterSet([])
    mt = ModalModel(truth, empty, design, q, ("low", "high"))
    mc = ModalModel(calibrated, empty, design, q, ("low", "high"))
    mn = ModalModel(nominal, empty, design, q, ("low", "high"))
    errs = {"after": [], "before": []}
    unpaired = {"after": 0, "before": 0}
    u = np.zeros(0)
    for p in range(len(q)):
        for b in ("low", "high"):
            t = mt.modes(u, p, b)
            keep = (t.peak >= 0.01) & t.inside
            t = type(t)(f_n=t.f_n[keep], zeta=t.zeta[keep], residue=t.residue[keep], peak=t.peak[keep],
                        inside=t.inside[keep])
            for key, model in (("after", mc), ("before", mn)):
                m = model.modes(u, p, b)
                pr = pair(t, m)
                errs[key] += list(np.abs(m.f_n[pr.model] / t.f_n[pr.meas] - 1))
                unpaired[key] += len(pr.unpaired_meas)
    return {k: {"f_p95": float(np.percentile(v, 95)), "f_mean": float(np.mean(v)), "n": len(v),
                "unpaired": unpaired[k]} for k, v in errs.items()}


def score_params(cal, truth: dict) -> list[dict]:
    out = []
    for p in cal.params:
        t = truth.get(p.name)
        if t is None:
            continue
        if p.name.endswith("tilt_compliance"):
            t_disp = t / 1e-9
            ok = abs(p.value - t_disp) <= max(0.05 * t_disp, 2.0)
        elif ".com_" in p.name:
            t_disp = 1e3 * t
            ok = abs(p.value - t_disp) <= 5.0
        else:
            t_disp = t
            ok = abs(p.value / t - 1) <= 0.05
        out.append({"name": p.name, "true": t_disp, "value": p.value, "interval": list(p.interval),
                    "identifiability": p.identifiability, "within5": bool(ok), "on_bound": p.on_bound,
                    "covered": bool(p.interval[0] <= t_disp <= p.interval[1])})
    return out


def run_case(i: int, seed: int, args) -> dict:
    rng = np.random.default_rng([seed, i])
    nominal = Robot.load("irb6660", tool="dummy")
    xml, truth = draw_truth(nominal.xml, rng, base=bool(i % 2))
    grid = seed_grid()
    postures = [grid[k] for k in sorted(rng.choice(len(grid), args.campaign, replace=False))]
    t0 = time.perf_counter()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = load_modal_data(measured(xml, postures, args, seed, i), workers=args.workers)
    t1 = time.perf_counter()
    held = list(range(1, args.campaign, 4))     # a quarter held out: 1, 5, 9, 13 of 16
    settings = CalibrationSettings(groups=parse_groups(args.groups), workers=args.workers)
    cal = calibrate(nominal, data, held=held, settings=settings)
    t2 = time.perf_counter()
    truth_robot = Robot(xml, name="truth", tool="dummy")
    cal_robot = Robot(cal.xml, name="calibrated", tool="dummy")
    unseen = exact_errors(truth_robot, cal_robot, nominal, data.design, unseen_postures(rng, args.unseen))
    rows = cal.modes_held
    return {"index": i, "seed": seed, "base": bool(i % 2), "groups": list(settings.groups),
            "heldout": {k: [r for r in v] for k, v in rows.items()},
            "heldout_summary": cal.heldout_summary(), "params": score_params(cal, truth),
            "unseen": unseen, "chi2_per_residual": [cal.chi2_before / cal.n_residuals,
                                                    cal.chi2_after / cal.n_residuals],
            "iterations": cal.iterations, "notes": list(cal.notes),
            "seconds": {"measure": round(t1 - t0, 1), "calibrate": round(t2 - t1, 1),
                        "score": round(time.perf_counter() - t2, 1)}}


def run_robot(i: int, *, seed: int, args) -> dict:
    """Robot ``i``'s JSON line: its case, or why it was rejected."""
    try:
        return run_case(i, seed, args) if args.plain else run_gap_case(i, seed, args)
    except RuntimeError as err:     # counted, printed and kept: never silently redrawn
        return {"index": i, "seed": seed, "rejected": str(err)}


# the truth parameters a structural effect also moves: not scored (the calibration is right to
# put the effect elsewhere, or wrong in a way the gap search, not the parameter score, judges)
def touched_by(hidden) -> set:
    if hidden is None:
        return set()
    if hidden["kind"] == "tool_contact_stiffness":
        return {"tool_contact.translation", "tool_contact.rotation"}
    if hidden["kind"] in ("added_mass", "offset_mass"):
        return {f"{hidden['location']}.{f}" for f in ("mass", "com_x", "com_y", "com_z")}
    return set()


def _structural(nominal, xml: str, postures, args, seed: int, i: int, rng, in_library: bool):
    """The robot's structural effect (``truth.structural``, drawn from ``rng``), the spread robot's
    MJCF with it, and its visibility record (``truth.visibility``: decided without the method,
    never enlarged)."""
    effect = draw_effect(rng, in_library=in_library)
    root = ET.fromstring(xml)
    effect = apply_effect(root, effect, ET.fromstring(nominal.xml))
    xml_with = ET.tostring(root, encoding="unicode")
    vis = visibility(xml, xml_with, postures, seed * 1000 + i + 500, rpm_with=effect.rpm,
                     signals=partial(turned_signals, effect=effect), workers=args.workers)
    print(f"robot {i}: {effect.name}: χ² excess {vis['chi2_with'] - vis['chi2_null']:.4g} (threshold "
          f"{vis['threshold']:.4g}): {'visible' if vis['visible'] else 'invisible'}", flush=True)
    return effect, xml_with, vis


def diagnosed(nominal, ds, groups: str, workers: int):
    """``gap diagnose --calibrate`` of the measured FRFs ``ds``: ``groups`` calibrated on 12
    postures, 4 held out (a quarter)."""
    from rmbench.gap import DiagnosisSettings, diagnose

    settings = DiagnosisSettings(calibrate=parse_groups(groups), heldout=0.25)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return diagnose(nominal, ds, workers=workers, settings=settings)


def run_gap_case(i: int, seed: int, args) -> dict:
    """One robot of the gap half: the spread, on half of them a structural effect, measured and
    handed to ``gap diagnose --calibrate`` (which calibrates on 12 postures, holds 4 out)."""
    from types import SimpleNamespace

    from rmbench.gap import DiagnosisSettings, diagnose

    rng = np.random.default_rng([seed, i])
    nominal = Robot.load("irb6660", tool="dummy")
    xml, truth = draw_truth(nominal.xml, rng, base=bool(i % 2))
    grid = seed_grid()
    postures = [grid[k] for k in sorted(rng.choice(len(grid), 16, replace=False))]
    effect, hidden, rpm, vis = None, None, 0.0, None
    if (i // 2) % 2 == 1:            # half the robots: 2, 3, 6, 7, ...; in and out of the library by turns
        effect, xml, vis = _structural(nominal, xml, postures, args, seed, i, rng, in_library=(i // 4) % 2 == 0)
        hidden, rpm = effect.to_dict(), effect.rpm
        if not vis["visible"]:      # counted and reported apart, never enlarged or redrawn
            return {"index": i, "seed": seed, "base": bool(i % 2), "hidden": hidden, "visibility": vis,
                    "invisible": True}
    t0 = time.perf_counter()
    ds = measured(xml, postures, args, seed, i, rpm=rpm)
    if effect is not None:
        ds = turned_signals(ds, effect)
    t1 = time.perf_counter()
    dg = diagnosed(nominal, ds, args.gap_groups, args.workers)
    t2 = time.perf_counter()
    acct = dg.calibration
    skip = touched_by(hidden)
    est = [SimpleNamespace(name=p["name"], value=p["value"], interval=p["interval"],
                           identifiability=p["identifiability"], on_bound=p["on_bound"])
           for p in acct["params"] if p["name"] not in skip]
    truth_robot = Robot(xml, name="truth", tool="dummy", spindle_rpm=rpm)
    # the model the verdict hands the user: with the effect where one explains the gap
    final = dg.variant_xml if dg.verdict == "explained" and dg.variant_xml else dg.calibrated_xml
    cal_robot = Robot(final, name="calibrated", tool="dummy")
    from rmbench.calibrate.measured import measured_data
    from rmbench.calibrate import TestDesign

    design = TestDesign.of_dataset(measured_data(ds))
    unseen = exact_errors(truth_robot, cal_robot, nominal, design, unseen_postures(rng, args.unseen))
    top = dg.effects[0] if dg.effects else None
    return {"index": i, "seed": seed, "base": bool(i % 2), "groups": list(parse_groups(args.gap_groups)),
            "hidden": hidden, "visibility": vis, "verdict": dg.verdict,
            "top": None if top is None else {"name": top.name, "confidence": top.confidence,
                                             "shrink": top.shrink, "params": top.params,
                                             "chosen": top.chosen},
            "ranked": [[e.name, e.confidence, e.shrink] for e in dg.effects[:5]],
            "confirmation": dg.confirmation, "notes_gap": list(dg.notes),
            "heldout": acct["heldout_modes"], "params": score_params(SimpleNamespace(params=est), truth),
            # the hidden effect's own parameters, not scored (their truth is the effect's): what the
            # calibration made of them
            "touched": [{k: p[k] for k in ("name", "nominal", "value", "interval", "on_bound")}
                        for p in acct["params"] if p["name"] in skip],
            "unseen": unseen, "chi2_per_residual": [acct["chi2_per_residual"]["before"],
                                                    acct["chi2_per_residual"]["after"]],
            "iterations": acct["iterations"], "notes": list(acct["notes"]),
            "seconds": {"measure": round(t1 - t0, 1), "calibrate": round(acct["seconds"], 1),
                        "diagnose": round(t2 - t1, 1), "score": round(time.perf_counter() - t2, 1)}}


def summarise_gap(cases, invisible=()) -> dict:
    """The gap half's scores: top 1 on in-library effects, no attribution on out-of-library ones
    and on the spread alone, and the confidences' calibration; the ``invisible`` draws (their
    lines) counted by effect."""
    inl = [c for c in cases if c["hidden"] and c["hidden"]["in_library"]]
    out = [c for c in cases if c["hidden"] and not c["hidden"]["in_library"]]
    spread = [c for c in cases if not c["hidden"]]

    def top1(c):
        return c["verdict"] == "explained" and c["top"] is not None and c["top"]["name"] == c["hidden"]["name"]

    confident = [c for c in cases if c["verdict"] == "explained" and c["top"]["confidence"] >= 0.8]
    right = [bool(c["hidden"]) and top1(c) for c in confident]
    # an in-library effect the calibrated ordinary parameters reproduce to the held-out noise leaves
    # nothing to find in these data: counted in the strict figure, and reported apart
    seen = [c for c in inl if c["verdict"] != "no significant gap"]
    return {"in_library": len(inl), "out_of_library": len(out), "spread_only": len(spread),
            # no effect is enlarged (issue 79): [0, effects drawn]; the invisible draws by effect
            "scaled": [0, len(inl) + len(out) + len(invisible)],
            "rejected_draws": dict(Counter(c["hidden"]["name"] for c in invisible)),
            "gap_top1_after_calibration": float(np.mean([top1(c) for c in inl])) if inl else None,
            "in_library_absorbed": len(inl) - len(seen),
            "gap_top1_where_a_gap_remains": float(np.mean([top1(c) for c in seen])) if seen else None,
            "unexplained_strict": float(np.mean([c["verdict"] == "unexplained" for c in out])) if out else None,
            "unexplained_ok": float(np.mean([c["verdict"] != "explained" for c in out])) if out else None,
            "out_verdicts": {v: sum(c["verdict"] == v for c in out) for v in ("unexplained", "no significant gap",
                                                                               "explained")},
            "spread_false_structural": float(np.mean([c["verdict"] == "explained" for c in spread])) if spread else None,
            "confident_answers": len(confident),
            "confident_right": float(np.mean(right)) if right else None,
            "diagnose_s_median": float(np.median([c["seconds"]["diagnose"] for c in cases])) if cases else None}


def with_rejected_as_misses(cases, invisible=()) -> dict:
    """The gap half's rates with every invisible draw (``invisible``: their lines) counted as a case
    of its class and a miss (issue 78; until issue 81 the draws the bench rejected as hidden after
    enlarging them): the draws no test could see are outcomes too. Each rate as ``[k, n, rate,
    wilson_lo95, wilson_hi95]``; ``rejected_in_library``, ``rejected_out_of_library``: the
    invisible draws of each class."""
    inl = [c for c in cases if c["hidden"] and c["hidden"]["in_library"]]
    out = [c for c in cases if c["hidden"] and not c["hidden"]["in_library"]]
    spread = [c for c in cases if not c["hidden"]]
    rej_in = sum(bool(c["hidden"]["in_library"]) for c in invisible)
    rej_out = len(invisible) - rej_in

    def top1(c):
        return c["verdict"] == "explained" and c["top"] is not None and c["top"]["name"] == c["hidden"]["name"]

    def rated(k, n):
        lo, hi = wilson(k, n) if n else (None, None)
        return [k, n, round(k / n, 4) if n else None, None if lo is None else round(lo, 4),
                None if hi is None else round(hi, 4)]

    return {"rejected_in_library": rej_in, "rejected_out_of_library": rej_out,
            "gap_top1_after_calibration": rated(sum(map(top1, inl)), len(inl) + rej_in),
            "unexplained_strict": rated(sum(c["verdict"] == "unexplained" for c in out), len(out) + rej_out),
            "unexplained_ok": rated(sum(c["verdict"] != "explained" for c in out), len(out) + rej_out),
            "spread_false_structural": rated(sum(c["verdict"] == "explained" for c in spread), len(spread))}


def summarise(cases) -> dict:
    def errs(key, field):
        return np.array([abs(r[field]) for c in cases for r in c["heldout"][key] if r["paired"]])

    f_before, f_after, z_after = errs("before", "f_err"), errs("after", "f_err"), errs("after", "zeta_err")
    unpaired = sum(1 for c in cases for r in c["heldout"]["after"] if not r["paired"])
    total = sum(len(c["heldout"]["after"]) for c in cases)
    ident = [p for c in cases for p in c["params"] if p["identifiability"] == "identifiable"]
    allp = [p for c in cases for p in c["params"]]
    by_case_within = [np.mean([p["within5"] for p in c["params"] if p["identifiability"] == "identifiable"])
                      for c in cases if any(p["identifiability"] == "identifiable" for p in c["params"])]
    unseen_after = [c["unseen"]["after"]["f_p95"] for c in cases]
    unseen_before = [c["unseen"]["before"]["f_p95"] for c in cases]
    return {"cases": len(cases),
            "heldout_f_p95_before": float(np.percentile(f_before, 95)) if len(f_before) else None,
            "heldout_f_p95_after": float(np.percentile(f_after, 95)) if len(f_after) else None,
            "zeta_p95_after": float(np.percentile(z_after, 95)) if len(z_after) else None,
            "heldout_unpaired_after": unpaired, "heldout_modes": total,
            "ident_within5": float(np.mean([p["within5"] for p in ident])) if ident else None,
            "ident_within5_cases_90": float(np.mean([w >= 0.9 for w in by_case_within])) if by_case_within else None,
            "ident_on_bound": int(sum(p["on_bound"] for p in ident)), "n_identifiable": len(ident),
            "coverage95": float(np.mean([p["covered"] for p in allp])) if allp else None,
            "coverage95_identifiable": float(np.mean([p["covered"] for p in ident])) if ident else None,
            "unseen_f_p95_median_after": float(np.median(unseen_after)) if cases else None,
            "unseen_f_p95_median_before": float(np.median(unseen_before)) if cases else None,
            "unseen_f_p95_worst_after": float(np.max(unseen_after)) if cases else None,
            "calibrate_s_median": float(np.median([c["seconds"]["calibrate"] for c in cases])) if cases else None}


def time_default(workers: int) -> float:
    """Seconds of a default-groups (24-parameter) calibration on 12 postures of one drawn robot."""
    rng = np.random.default_rng(12345)
    nominal = Robot.load("irb6660", tool="dummy")
    xml, _ = draw_truth(nominal.xml, rng, base=False)
    grid = seed_grid()
    postures = [grid[k] for k in sorted(rng.choice(len(grid), 12, replace=False))]
    tmp = Path(tempfile.mkdtemp(prefix="rmbench_cal_"))
    try:
        data = measure(xml, postures, "linear", 1, workers, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    t0 = time.perf_counter()
    cal = calibrate(nominal, data, settings=CalibrationSettings(workers=workers))
    seconds = time.perf_counter() - t0
    print(f"default calibration: {len(cal.params)} parameters, 12 postures, {seconds:.1f} s, "
          f"{cal.iterations} evaluations", flush=True)
    return seconds


def _said(i: int, c: dict, plain: bool) -> str:
    """Robot ``i``'s line as printed when it finishes: its scores, or why it is not scored."""
    if "rejected" in c:
        return f"robot {i}: rejected ({c['rejected']})"
    if c.get("invisible"):
        vis = c["visibility"]
        return (f"robot {i}: {c['hidden']['name']} invisible (χ² excess {vis['chi2_with'] - vis['chi2_null']:.4g}, "
                f"threshold {vis['threshold']:.4g}), not scored")
    h = {k: error_summary(v) for k, v in c["heldout"].items()}
    return (f"robot {i} ({'base' if c['base'] else 'rigid'}): held-out f p95 {100 * h['before']['f_err_p95']:.2f} % -> "
            f"{100 * h['after']['f_err_p95']:.2f} %, zeta p95 {100 * h['after']['zeta_err_p95']:.1f} %, "
            f"unseen f p95 {100 * c['unseen']['after']['f_p95']:.2f} %, "
            f"{sum(p['identifiability'] == 'identifiable' for p in c['params'])} identifiable"
            + ("" if plain else f"; hidden {c['hidden']['name'] if c['hidden'] else 'none'}: {c['verdict']}"
               + (f", top {c['top']['name']} ({c['top']['confidence']:.2f}, shrink {c['top']['shrink']:.2f})"
                  if c["top"] else ""))
            + f"; {c['seconds']}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robots", type=int, default=40)
    ap.add_argument("--seed", type=int, default=None, help="default: a fresh one, printed")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--method", default="time", choices=("time", "linear"))
    ap.add_argument("--plain", action="store_true",
                    help="calibration only (rmbench.calibrate on the measured modes), no structural half")
    ap.add_argument("--groups", default="joints,damping,servo,masses,com,base", help="groups of --plain")
    ap.add_argument("--gap-groups", default="joints,damping,servo,masses,com,base,tool",
                    help="groups gap diagnose --calibrate calibrates")
    ap.add_argument("--time-default", action="store_true", help="time the default 24-parameter calibration")
    ap.add_argument("--only", default=None, metavar="I,J,...", help="run only these robots (indices)")
    ap.add_argument("--lines", default=None, help="JSON-lines file (default: bench/results/calibrate_<key>.jsonl)")
    ap.add_argument("--unseen", type=int, default=N_UNSEEN,
                    help="quasi-random unseen postures each calibrated model is checked at against the truth")
    ap.add_argument("--campaign", type=int, default=N_CAMPAIGN, metavar="N",
                    help=f"--plain: postures of each robot's campaign, a quarter held out (default {N_CAMPAIGN})")
    ap.add_argument("--cache", default=str(CACHE), metavar="DIR",
                    help="where the measured FRFs are kept and read back (default: bench/.cache; a fresh "
                         "folder measures every robot again)")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="address of an existing dask scheduler: the robots run on its cluster, one a worker")
    args = ap.parse_args(argv)
    seed = args.seed if args.seed is not None else fresh_seed()
    groups = args.groups if args.plain else "gap-" + args.gap_groups
    if not args.plain and args.campaign != N_CAMPAIGN or args.campaign < 5:
        ap.error(f"--campaign: at least 5 postures, and only with --plain (got {args.campaign})")
    size = "" if args.campaign == N_CAMPAIGN else f"_p{args.campaign}"
    key = f"s{seed}_{args.method}_{groups.replace(',', '-')}{size}_{_digest()}"
    print(f"seed {seed}; key {key}", flush=True)
    lines = Path(args.lines) if args.lines else RESULTS / f"calibrate_{key}.jsonl"
    lines.parent.mkdir(parents=True, exist_ok=True)
    done, rejected, invisible = {}, {}, {}
    for c in resumed_cases(lines, seed):
        (rejected if "rejected" in c else invisible if c.get("invisible") else done)[c["index"]] = c
    only = None if args.only is None else {int(x) for x in args.only.split(",") if x.strip()}
    todo = [i for i in range(args.robots)
            if not (i in done or i in rejected or i in invisible or (only is not None and i not in only))]
    if args.scheduler is not None:
        ship_bench_modules()
    # on a cluster a robot is one worker's: single-threaded inside, no worker processes of its own
    one = partial(run_robot, seed=seed, args=args if args.scheduler is None
                  else argparse.Namespace(**{**vars(args), "workers": 0}))
    for i, c in map_cases(one, todo, workers=1, scheduler=args.scheduler):
        with open_lines(lines, "a") as fh:
            fh.write(json.dumps(c) + "\n")
        (rejected if "rejected" in c else invisible if c.get("invisible") else done)[i] = c
        print(_said(i, c, args.plain), flush=True)
    cases = [done[i] for i in sorted(done)]
    s = summarise(cases)
    s["rejected"] = len(rejected)
    s["invisible"] = len(invisible)
    if not args.plain:
        s.update(summarise_gap(cases, list(invisible.values())))
        s["spread_only"] = summarise([c for c in cases if not c["hidden"]])
    print(json.dumps(s, indent=1))
    cal_s = time_default(args.workers) if args.time_default else s["calibrate_s_median"]
    real = {}
    real_path = RESULTS / "calibrate_real.json"
    if real_path.exists():
        real = json.loads(real_path.read_text())
    line = {"cases": s["cases"], "heldout_f_p95_before": s["heldout_f_p95_before"],
            "heldout_f_p95_after": s["heldout_f_p95_after"], "zeta_p95_after": s["zeta_p95_after"],
            "ident_within5": s["ident_within5"], "coverage95": s["coverage95"],
            "gap_top1_after_calibration": s.get("gap_top1_after_calibration"),
            "unexplained_ok": s.get("unexplained_ok"), "spread_false_structural": s.get("spread_false_structural"),
            "calibrate_s": cal_s, "gap_scaled": s.get("scaled"), "gap_rejected_draws": s.get("rejected_draws"),
            "invisible": s["invisible"],
            "real_f_mean_before": real.get("f_mean_before"),
            "real_f_mean_after": real.get("f_mean_after")}
    print(json.dumps(line))
    if not args.plain:
        # the second line: the invisible draws counted as misses
        print(json.dumps({"cases": s["cases"], "seed": seed,
                          "rejected_as_misses": with_rejected_as_misses(cases, list(invisible.values()))}))

if __name__ == "__main__":
    sys.exit(main())
