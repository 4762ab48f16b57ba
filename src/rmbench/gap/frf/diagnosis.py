"""Sim-to-real gap diagnosis on FRF data: where the model departs, which effect causes it, how far
the gap shrinks once the effect is in the model (METHODS.md §11).

::

    dg = diagnose("irb6660", "measured.nc")           # or a UFF58 directory, or a Dataset
    dg.verdict                                         # "explained" | "unexplained" | "no significant gap"
    dg.effects[0].name, dg.effects[0].shrink          # best first, held-out shrink of the gap
    dg.where.describe()                                # the nominal model's gap, by mode
    dg.save("diagnosis/")                              # figures, tables, the updated variant MJCF
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import xarray as xr

from rmbench.errors import InputError, RmbenchError, UnreachablePosture
from rmbench.calibrate.design import TestDesign
from rmbench.gap.frf.effects import Change, library
from rmbench.calibrate.measured import fit_measured, frf_targets, measured_data, postures_of
from rmbench.gap.frf.model import ModelBench
from rmbench.calibrate.residual import mode_residuals
from rmbench.gap.frf.search import GRID_PAIR, Fitted, Objective, Refiner, peak_residual, per_posture_chi2
from rmbench.gap.jsonable import write_whole
from rmbench.gap.selection import SearchSettings, bootstrap_shrink, confidences, selection_weights, significant
from rmbench.gap.frf.where import GapMap, gap_map
from rmbench.io.strict_json import strict_dumps
from rmbench.modeshape import mac

__all__ = ["diagnose", "diagnose_modes", "Diagnosis", "EffectResult", "load_data", "DiagnosisSettings",
           "SearchData", "structural_kinds", "remaining_gap", "RemainingGap"]

_DB = 20 / np.log(10)


@dataclass(frozen=True)
class DiagnosisSettings(SearchSettings):
    """How hard the diagnosis searches: :class:`~rmbench.gap.selection.SearchSettings` (held-out
    share of the postures, every other one in (θ, x, y) order at 0.5; refinement by
    re-simulation; noise test; bootstrap; kinds) and

    Attributes
    ----------
    pairs_of : int
        When no single effect explains the gap, this many second effects (the best of a screening
        on top of each of the two best singles) are paired with each and refined.
    max_train : int
        Most training postures used by the screening and the refinement (spread evenly).
    max_held : int
        Most held-out postures the candidates are scored on (spread evenly); postures beyond
        ``max_train + max_held`` enter the gap map and the significance test only.
    calibrate : tuple of str or None
        Parameter groups (:mod:`rmbench.robot.parameters`) calibrated on the training postures
        before the search (:mod:`rmbench.calibrate`); the search then runs on the calibrated
        model, for the structural effects only (the library's kinds other than the gearboxes',
        their damping's and the servos': a foundation or tool holder far outside its ordinary
        spread stays a candidate), each fitted jointly with the ordinary parameters
        (:mod:`rmbench.gap.frf.joint`).
    min_shrink : float
        Least held-out shrink of the rms normalised gap for an effect to be called the
        explanation: one that brings the gap to the noise only because the gap was small
        explains little.
    confirm : int
        With ``calibrate``, when the joint search explains nothing: how many of the kinds that
        map onto model parameters (tool holder, spindle bearings, foundation, a body's mass) are
        confirmed by a full recalibration with their best candidate in place, against a null
        recalibration (:mod:`rmbench.gap.frf.confirm`); 0 for none.
    """

    pairs_of: int = 3
    max_train: int = 16
    max_held: int = 32
    calibrate: tuple | None = None
    min_shrink: float = 0.5
    confirm: int = 4


@dataclass(frozen=True)
class EffectResult:
    """One ranked effect with its evidence.

    Attributes
    ----------
    name : str
        ``kind@location``.
    kind, location : str
        ``location`` is the MJCF name of the joint, actuator or body edited, ``BAND:COORD`` for a
        sensor, or ``tool_contact``, ``spindle``, ``base``.
    params : dict
        Fitted parameters in their units.
    description : str
    heldout_before, heldout_after : dict
        Held-out gap metrics of the nominal model and of the model with this effect (alone, or
        as part of the chosen model for the chosen effects): ``gap`` (rms normalised residual),
        ``f_err`` and ``zeta_err`` (mean relative errors of paired modes), ``mac`` (mean MAC of
        their residues), ``frf_db`` (rms FRF log-magnitude error, dB), ``unpaired``, ``failed``
        (postures the changed robot cannot hold).
    shrink : float
        ``1 − gap_after / gap_before`` on the held-out postures.
    shrink_interval : (float, float)
        95 % bootstrap interval over the held-out postures.
    confidence : float
        Sum of the weights of the scored models containing the effect: how often each model has
        the best held-out BIC over bootstrap resamples of the held-out postures.
    chosen : bool
        Part of the model the verdict rests on.
    """

    name: str
    kind: str
    location: str
    params: dict
    description: str
    heldout_before: dict
    heldout_after: dict
    shrink: float
    shrink_interval: tuple
    confidence: float
    chosen: bool = False

    def to_dict(self) -> dict:
        return {"name": self.name, "kind": self.kind, "location": self.location,
                "params": self.params, "description": self.description,
                "heldout_before": self.heldout_before, "heldout_after": self.heldout_after,
                "shrink": self.shrink, "shrink_interval": list(self.shrink_interval),
                "confidence": self.confidence, "chosen": self.chosen}


@dataclass(frozen=True)
class Diagnosis:
    """The diagnosis of one measurement against one nominal model.

    Attributes
    ----------
    verdict : str
        ``"explained"``, ``"unexplained"`` or ``"no significant gap"``.
    effects : tuple of EffectResult
        Best first: the chosen model's effects, then the other candidates by held-out score.
    where : GapMap
        The nominal model's gap.
    where_after : GapMap or None
        The updated model's gap (when explained).
    localisation : str
        Where the gap lies and which candidates come closest (for an unexplained gap).
    equivalent : tuple of tuple of str
        Candidate effects the data cannot tell apart (the same signature at every posture).
    nominal_chi2 : float
        The nominal model's χ² over all postures, and ``n_residuals`` their number.
    n_residuals : int
    nominal_peak : float
        The nominal model's largest normalised residual (absolute).
    variant_xml : str or None
        MJCF of the updated model (nominal robot plus the chosen effects that edit the robot).
    design_changes : tuple of str
        Chosen effects that belong to the test design (sensor placement), not to the robot.
    train, held : tuple of int
        Posture indices of the fits and of the held-out scoring.
    models : tuple of dict
        Every scored model: name, parameters, χ² train/held, score, weight.
    seconds : dict
        Time of each step.
    notes : tuple of str
    calibration : dict or None
        With ``settings.calibrate``: each parameter's nominal, value, 95 % interval and
        identifiability, and the held-out frequency and damping errors before and after
        (:meth:`rmbench.calibrate.Calibration.to_json`).
    calibrated_xml : str or None
        With ``settings.calibrate``: the calibrated MJCF without a structural effect (the one
        the structural search ran on, or the null recalibration where that is the better model).
        Where an effect explains the gap, ``variant_xml`` is the recalibration with it freed, the
        model ``calibration`` describes.
    confirmation : dict or None
        With ``settings.confirm``: the null recalibration and each confirmed candidate's held-out
        χ², noise test and shrink against the null (:mod:`rmbench.gap.frf.confirm`).
    """

    verdict: str
    effects: tuple
    where: GapMap
    where_after: GapMap | None
    localisation: str
    equivalent: tuple
    nominal_chi2: float
    n_residuals: int
    nominal_peak: float
    variant_xml: str | None
    design_changes: tuple
    train: tuple
    held: tuple
    models: tuple
    seconds: dict
    notes: tuple = field(default=())
    calibration: dict | None = None
    calibrated_xml: str | None = None
    confirmation: dict | None = None

    def __post_init__(self):
        if self.verdict not in ("explained", "unexplained", "no significant gap"):
            raise ValueError(f"unknown verdict {self.verdict!r}")

    def to_json(self, variant_path: str | None = None) -> dict:
        """The CLI's ``--json``: verdict, effects best first, where, variant path."""
        return {"verdict": self.verdict, "effects": [e.to_dict() for e in self.effects],
                "where": {**self.where.summary(), "describe": self.where.describe(),
                          "localisation": self.localisation},
                "equivalent": [list(g) for g in self.equivalent],
                "nominal_chi2_per_residual": self.nominal_chi2 / max(self.n_residuals, 1),
                "nominal_peak_residual": self.nominal_peak,
                "design_changes": list(self.design_changes),
                "variant": variant_path, "seconds": self.seconds, "notes": list(self.notes),
                "calibration": self.calibration, "confirmation": self.confirmation}

    def save(self, directory: str | Path) -> dict:
        """Write ``diagnosis.json``, ``effects.csv``, ``gap_modes.csv`` (and
        ``gap_modes_after.csv``, the updated model's gap, when there is one), the figures and the
        updated variant (``variant.xml``, when there is one) into ``directory``.

        Returns
        -------
        dict
            ``{"json", "effects", "modes", "modes_after", "variant", "calibrated", "figures"}``
            paths.
        """
        import csv

        from rmbench.gap.plot import plot_diagnosis

        d = Path(directory)
        d.mkdir(parents=True, exist_ok=True)
        out = {}
        variant = None
        if self.variant_xml is not None:
            variant = d / "variant.xml"
            write_whole(variant, self.variant_xml)
            out["variant"] = str(variant)
        if self.calibrated_xml is not None:
            write_whole(d / "calibrated.xml", self.calibrated_xml)
            out["calibrated"] = str(d / "calibrated.xml")
        with open(d / "effects.csv", "w", newline="") as fh:
            w = csv.writer(fh, lineterminator="\n")
            w.writerow(["rank", "name", "chosen", "description", "confidence", "shrink",
                        "gap_before", "gap_after", "f_err_before", "f_err_after", "frf_db_before",
                        "frf_db_after"])
            for i, e in enumerate(self.effects):
                w.writerow([i + 1, e.name, e.chosen, e.description, f"{e.confidence:.4g}",
                            f"{e.shrink:.4g}", f"{e.heldout_before['gap']:.4g}",
                            f"{e.heldout_after['gap']:.4g}", f"{e.heldout_before['f_err']:.4g}",
                            f"{e.heldout_after['f_err']:.4g}", f"{e.heldout_before['frf_db']:.4g}",
                            f"{e.heldout_after['frf_db']:.4g}"])
        cols = ["posture", "x", "y", "theta", "band", "mode", "f_meas", "f_model", "zeta_meas",
                "zeta_model", "df", "dzeta", "dscale", "mac", "significant"]
        for name, gm in (("gap_modes.csv", self.where), ("gap_modes_after.csv", self.where_after)):
            if gm is None:
                (d / name).unlink(missing_ok=True)      # an earlier diagnosis's, in the same folder
                continue
            with open(d / name, "w", newline="") as fh:
                w = csv.writer(fh, lineterminator="\n")
                w.writerow(cols + ["z_f", "z_zeta", "z_scale", "z_shape"])
                for r in gm.records:
                    w.writerow([r[c] for c in cols] + [f"{v:.4g}" for v in r["z"].values()])
        out["effects"] = str(d / "effects.csv")
        out["modes"] = str(d / "gap_modes.csv")
        if self.where_after is not None:
            out["modes_after"] = str(d / "gap_modes_after.csv")
        out["figures"] = [str(p) for p in plot_diagnosis(self, d)]
        write_whole(d / "diagnosis.json", strict_dumps(self.to_json(out.get("variant")), indent=2))
        out["json"] = str(d / "diagnosis.json")
        return out


def load_data(data) -> xr.Dataset:
    """A campaign dataset (netCDF path or Dataset) or a UFF58 directory, as a Dataset."""
    if isinstance(data, xr.Dataset):
        return data
    p = Path(data)
    if p.is_dir():
        from rmbench.io import read_uff58

        return read_uff58(p)
    from rmbench.impact import open_campaign

    return open_campaign(p)


def diagnose(nominal, data, *, test: str | None = None, tool=None, workers: int | None = None,
             settings: DiagnosisSettings = DiagnosisSettings(), progress=None) -> Diagnosis:
    """Diagnose the gap between a nominal model and measured FRFs.

    Parameters
    ----------
    nominal : str, Path or Robot
        The nominal robot: a bundled name or an MJCF path (with ``tool``), or a loaded Robot.
    data : str, Path or xarray.Dataset
        Measured FRFs: a campaign dataset (netCDF) or a UFF58 directory (``rmbench campaign
        export``, or a real robot's test). Only H, coherence, postures and the test design are
        read.
    test : str, optional
        Campaign TOML text of the test design, when the data carry none (or to override it).
    tool : str, optional
        The tool on the nominal robot (default: the robot's default tool).
    workers : int, optional
        Worker processes of the measurement's modal fit.
    progress : callable, optional
        ``progress(message)`` after each step.

    Returns
    -------
    Diagnosis

    Raises
    ------
    InputError
        Unreadable data, no test design, postures the model cannot reach, no overlap of the
        data's and the model's bands, data of another robot or sensor layout.
    """
    say = progress or (lambda msg: None)
    t = {"start": time.perf_counter()}
    robot, ds, design, bands, postures, bench, meas, frf, train, held = _prepared(
        nominal, data, test, tool, workers, settings, say, t)
    calibration = ordinary = None
    nominal_robot = robot
    if settings.calibrate:
        robot, calibration, ordinary, first = _calibrated(robot, design, postures, meas, frf, bands, train,
                                                          held, settings, workers, say, data)
        bench = ModelBench(robot, design, bench.q_cmd)
        t["calibrate"] = time.perf_counter()
    data = SearchData(robot, design, bench, tuple(meas), None if frf is None else tuple(frf), tuple(bands),
                      _xyt(ds), ds, tuple(train), tuple(held))
    dg = _diagnose(data, settings, workers, say, t, ordinary=ordinary)
    if calibration is None:
        return dg
    dg = replace(dg, calibration=calibration, calibrated_xml=robot.xml)
    if dg.verdict == "explained":
        dg = _spread_checked(dg, nominal_robot, first)
    # "no significant gap" too: a calibration that reached the noise only by pushing an ordinary
    # parameter onto the edge of its spread may have mimicked a structural effect (_pinned)
    if settings.confirm > 0 and dg.verdict in ("unexplained", "no significant gap"):
        dg = _confirmed(dg, nominal_robot, robot, bench.q_cmd, first, meas, frf, bands, train, held, ds,
                        settings, say, t)
    return dg


def _prepared(nominal, data, test, tool, workers, settings, say, t) -> tuple:
    """What every FRF diagnosis starts from: the robot, the measured dataset and its test design,
    the bands, postures and model bench, the measured modes and FRF targets, and the training and
    held-out postures."""
    from rmbench.robot import Robot

    robot = nominal if isinstance(nominal, Robot) else Robot.load(nominal, tool=tool)
    ds = measured_data(load_data(data))
    design = TestDesign.of_dataset(ds, test)
    bands = _bands(ds, design, robot)
    postures = postures_of(ds)
    try:
        bench = ModelBench.commanded(robot, design, postures)
    except UnreachablePosture as err:
        raise InputError(f"the data's postures are not this model's: {err}") from None
    say(f"nominal model at {len(postures)} postures")
    meas, fit = fit_measured(ds, bands, workers=workers)
    frf = frf_targets(ds, fit, bands, design.averages(), design.direction_scatter())
    t["fit"] = time.perf_counter()
    say("measured FRFs fitted")
    _check_match(bench, meas, bands)
    train, held = _split(ds, settings.heldout)
    train, held = _spread(train, settings.max_train), _spread(held, settings.max_held)
    return robot, ds, design, bands, postures, bench, meas, frf, train, held


@dataclass(frozen=True)
class RemainingGap:
    """Whether measured FRFs leave a gap once the ordinary parameters are calibrated: the two
    noise tests a calibrated :func:`diagnose` applies before it says "no significant gap", without
    the structural search between them.

    Attributes
    ----------
    chi2_all, n_all, peak_all : float, int, float
        The first calibration's χ² over every posture (its parameters refitted to first order,
        as the search's baseline), the number of residuals and the largest one (absolute).
    first_significant : bool
        Whether that gap exceeds the noise (the diagnosis's first test).
    null : dict or None
        Where the first test passed: the null recalibration with the FRFs
        (:func:`rmbench.gap.frf.confirm.confirm`), its held-out χ² (``chi2_held``, ``n_held``,
        ``peak_held``) and noise test (``significant``).
    significant : bool
        Both tests passed: a gap the ordinary parameters cannot take up.
    seconds : float
    """

    chi2_all: float
    n_all: int
    peak_all: float
    first_significant: bool
    null: dict | None
    significant: bool
    seconds: float

    def to_dict(self) -> dict:
        return {"chi2_all": self.chi2_all, "n_all": self.n_all, "peak_all": self.peak_all,
                "first_significant": self.first_significant, "null": self.null,
                "significant": self.significant, "seconds": self.seconds}


def remaining_gap(nominal, data, *, test: str | None = None, tool=None, workers: int | None = None,
                  settings: DiagnosisSettings = DiagnosisSettings(), progress=None) -> RemainingGap:
    """Whether a structural gap remains in ``data`` once ``settings.calibrate``'s ordinary
    parameters are calibrated: :func:`diagnose`'s calibration, its noise test over every posture
    and, where that passes, its null recalibration with the FRFs scored on the held-out postures;
    no structural search. A blind bench asks this of a hidden effect before it is measured: an
    effect the ordinary parameters take up whole leaves nothing any diagnosis could find.

    Parameters are :func:`diagnose`'s; ``settings.calibrate`` must name groups.

    Returns
    -------
    RemainingGap
    """
    from rmbench.gap.frf.confirm import confirm
    from rmbench.gap.frf.joint import JointObjective

    if not settings.calibrate:
        raise ValueError("remaining_gap needs settings.calibrate: the ordinary parameters to calibrate")
    say = progress or (lambda msg: None)
    t = {"start": time.perf_counter()}
    robot, ds, design, bands, postures, bench, meas, frf, train, held = _prepared(
        nominal, data, test, tool, workers, settings, say, t)
    fitted, _, ordinary, (cal, sub, cal_settings) = _calibrated(robot, design, postures, meas, frf, bands, train,
                                                               held, settings, workers, say, data)
    cal_bench = ModelBench(fitted, design, bench.q_cmd)
    obj_train = JointObjective(cal_bench, meas, frf, bands, train, ordinary)
    obj_all = JointObjective(cal_bench, meas, frf, bands, range(cal_bench.n_postures), ordinary,
                             fitted_on=obj_train)
    e_all = obj_all.vector(Change())
    chi2_all, peak_all = float(e_all @ e_all), float(abs(peak_residual(e_all)))
    first = bool(significant(chi2_all, obj_all.n, p=settings.p_noise, peak=peak_all))
    null = None
    if first:
        held_sub = list(range(len(train), len(train) + len(held)))
        run, _ = confirm(robot, sub, held_sub, cal, [], q_cmd=bench.q_cmd, meas=meas, frf=frf, bands=bands,
                         held=held, settings=cal_settings, p_noise=settings.p_noise,
                         min_shrink=settings.min_shrink, progress=say)
        null = run.to_dict()
    return RemainingGap(chi2_all, int(obj_all.n), peak_all, first, null,
                        bool(first and null["significant"]), round(time.perf_counter() - t["start"], 1))


# library kinds an ordinary-parameter group already fits (a foundation and a tool holder can be
# far outside their ordinary spread, a structural fault: their kinds stay in the search, fitted
# jointly with the calibrated parameters)
_COVERED = {"joints": "joint_stiffness", "damping": "joint_damping", "servo": "servo_stiffness"}


def structural_kinds(groups) -> tuple:
    """The library's kinds left to search once ``groups`` are calibrated."""
    from rmbench.gap.frf.effects import KINDS

    covered = {_COVERED[g] for g in groups if g in _COVERED}
    return tuple(k for k in KINDS if k not in covered)


def _calibrated(robot, design, postures, meas, frf, bands, train, held, settings, workers, say, data):
    """The nominal calibrated on the training postures: the calibrated robot, the calibration's
    account, its parameters linearised (:class:`~rmbench.gap.frf.joint.Ordinary`) and the
    :class:`~rmbench.calibrate.Calibration` itself (with the modal data it was fitted to, in
    training-then-held-out order, as ``(cal, data)``)."""
    from rmbench.calibrate import CalibrationSettings, ModalData, calibrate, linearisation
    from rmbench.gap.frf.joint import Ordinary
    from rmbench.robot import Robot

    name = data.name if isinstance(data, Path) else (Path(data).name if isinstance(data, str) else "dataset")
    md = ModalData(tuple(postures), tuple(meas), tuple(bands), design, name, tuple(frf))
    order = list(train) + list(held)
    sub = md.subset(order)
    cal_settings = CalibrationSettings(groups=tuple(settings.calibrate), workers=workers)
    held_sub = list(range(len(train), len(order)))
    cal = calibrate(robot, sub, held=held_sub, settings=cal_settings, progress=say)
    if cal.at_limit:
        # a fit still moving at its limit: the search would start from a model the ordinary
        # parameters have not finished with, and blame the rest of the way on a structural effect
        say(f"the calibration stopped at its limit of {cal_settings.max_iter} evaluations: continued "
            "from where it stopped")
        more = calibrate(robot, sub, held=held_sub, settings=cal_settings, progress=say,
                         start=dict(zip([p.name for p in cal.params], np.asarray(cal.u, float))))
        cal = replace(more, iterations=cal.iterations + more.iterations,
                      seconds=round(cal.seconds + more.seconds, 3))
    fitted = Robot(cal.xml, name=robot.name, tool=robot.tool, spindle_rpm=robot.spindle_rpm)
    account = cal.to_json()
    account["groups"] = list(settings.calibrate)
    blocks, z, names = linearisation(robot, sub, cal.u, range(len(order)), cal_settings)
    ordinary = Ordinary({(order[i], b): J for (i, b), (_, J) in blocks.items()}, z, names)
    say("calibrated parameters linearised for the joint search")
    return fitted, account, ordinary, (cal, sub, cal_settings)


def _confirmed(dg: Diagnosis, nominal, calibrated, q_cmd, first, meas, frf, bands, train, held, ds, settings,
               say, t) -> Diagnosis:
    """The diagnosis after the confirmable candidates were recalibrated in place, best-ranked
    first (:mod:`rmbench.gap.frf.confirm`): explained by the best of those whose held-out residual is noise,
    that closes ``min_shrink`` of the baseline's held-out gap and that left its ordinary spread;
    "no significant gap" when the null recalibration alone reaches the noise; otherwise
    unexplained as before."""
    from rmbench.gap.frf.confirm import confirm

    cal, sub, cal_settings = first
    # the search's library: the calibrated robot's (a lateral-only foundation where the
    # calibration mounted one)
    lib = {e.name: e for e in library(calibrated, sub.design)}
    pinned = _pinned(cal, lib)
    gap = dg.verdict == "unexplained"
    sizes = _fitted_sizes(dg.models)
    if gap:
        picks = _confirm_picks(dg.models, lib, settings.confirm)
        picks += [e for e in pinned if e not in picks]
    else:
        picks = pinned[:settings.confirm]
    if not picks:
        return dg
    held_sub = list(range(len(train), len(train) + len(held)))
    # the baseline: the better of the null recalibration and the first calibration (a short
    # recalibration can end worse than it started; a candidate must beat the best model without it)
    first_chi2 = float(dg.models[0]["chi2_held"])

    def explains(c, null_):
        return _confirms(c, null_, gap=gap, pinned=pinned, first_chi2=first_chi2, min_shrink=settings.min_shrink,
                         nominal=nominal, groups=cal_settings.groups)

    if pinned:
        say("on a bound of their spread after calibration, confirmed freed: " + ", ".join(e.name for e in pinned))
    null, done = confirm(nominal, sub, held_sub, cal, picks, q_cmd=q_cmd, meas=meas, frf=frf, bands=bands,
                         held=held, settings=cal_settings, p_noise=settings.p_noise,
                         min_shrink=settings.min_shrink, accept=explains, need_gap=gap, sizes=sizes,
                         progress=say)
    t["confirm"] = time.perf_counter()
    if null.chi2_held <= first_chi2:
        base = null
    else:
        first_obj = Objective(ModelBench(calibrated, sub.design, q_cmd), meas, frf, bands, held)
        base = replace(null, chi2_held=first_chi2, objective=first_obj,
                       chi2_held_posture=np.asarray(dg.models[0]["chi2_held_posture"]))
    record = {"null": null.to_dict(), "first_chi2_held": first_chi2,
              "candidates": [c.to_dict(base) for c in done], "min_shrink": settings.min_shrink,
              "pinned": [p.name for p in cal.params if p.on_bound and not np.isclose(p.value, p.nominal)]}
    notes = list(dg.notes)
    winners = [c for c in done if explains(c, null)]
    if not gap and not winners:
        notes.append(f"{', '.join(record['pinned'])} ended on a bound of the ordinary spread; recalibrated "
                     "with the structural effect behind it freed, no size beyond the spread explains the data "
                     "better: no structural effect is needed")
        return replace(dg, notes=tuple(notes), confirmation=record, seconds=_seconds(t))
    fits = [c for c in done if not c.significant and c.shrink_against(base) >= settings.min_shrink]
    if null.from_nominal and not null.significant:
        notes.append(f"{', '.join(c.effect.name for c in done if not c.significant)} reached the noise "
                     "recalibrated from the nominal, but so do the ordinary parameters alone, recalibrated "
                     "the same way: the gap was the first calibration's (it had stopped short of the data)")
    else:
        for c in fits:
            if c not in winners:
                notes.append(f"{c.effect.name} reaches the noise but stays within its ordinary spread: an "
                             "ordinary parameter, not a structural effect")
        for c in done:
            if gap and not c.significant and c not in fits and c not in winners:
                notes.append(f"{c.effect.name} reaches the noise but closes only {100 * c.shrink_against(base):.0f} % "
                             f"of the held-out gap (an explanation closes {100 * settings.min_shrink:.0f} %): "
                             "too little to tell apart from the noise's own share")
    if not winners:
        if not null.significant or fits:
            notes.append("recalibrated with the FRFs, the ordinary parameters bring the held-out gap "
                         "to the noise: no structural effect is needed")
            better = _better_calibration(dg, null, first_chi2, notes)
            return replace(dg, verdict="no significant gap", notes=tuple(notes), confirmation=record,
                           seconds=_seconds(t), **better)
        return replace(dg, notes=tuple(notes), confirmation=record, seconds=_seconds(t))
    return _explained(dg, winners, base, null, done, held, ds, settings, record, notes, gap, t)



def _confirms(c, null, *, gap: bool, pinned, first_chi2: float, min_shrink: float, nominal, groups) -> bool:
    """Whether the recalibration ``c`` with a structural effect freed explains the data, against
    the null recalibration ``null`` (no effect) and the first calibration's held-out χ²
    ``first_chi2``.

    Two rules, one per situation:

    * **The freed bound** (the effect behind an ordinary parameter the calibration left on a bound
      of its spread, ``pinned``): the candidate explains the data with less strain on the ordinary
      parameters (a lower training objective, data and prior), its held-out residual is noise, and
      its size lies beyond the spread with 95 % confidence. The held-out shrink is no measure here:
      the calibration, pressed against the bound, had already mimicked most of the effect, so even
      the truth closes little of what is left (calibration bench, seed 28832 robot 2: a tool holder
      ×3.40, the null 1.37 times the noise test's threshold, the freed holder to the noise at
      ×3.67, a shrink of 46 %).
    * **Any other candidate**, only where the null leaves a gap: held-out residual at the noise,
      at least ``min_shrink`` of the baseline's held-out rms gap closed (an effect that tidies up
      a small gap is no explanation: a 2 % spindle change for a 40 g mass at the tool tip), and
      for a kind an ordinary group also holds, a size outside that group's spread.
    """
    if c.significant:
        return False
    if c.effect in pinned and c.train_objective < null.train_objective and _beyond_spread(c, nominal, groups):
        return True
    if not gap:
        return False
    base_chi2 = min(null.chi2_held, first_chi2)
    # no gap is left to explain where the ordinary parameters alone reach the noise
    return bool(null.significant and base_chi2 > 0 and 1 - np.sqrt(c.chi2_held / base_chi2) >= min_shrink
                and not _within_spread(c, nominal, groups))


def _better_calibration(dg: Diagnosis, null, first_chi2: float, notes: list) -> dict:
    """The fields of ``dg`` that report the null recalibration as the calibration, where it is
    the better model without a structural effect (lower held-out χ² than the first calibration,
    ``first_chi2``), with a note in ``notes``; empty otherwise.

    The null continued the first calibration with the FRFs beside the modes; where the first had
    stopped short of the data (a local minimum of the modal residuals, a fit at its limit), the
    null's is the calibration the verdict rests on, and the one a user should take away."""
    if not null.chi2_held < first_chi2:
        return {}
    account = null.calibration.to_json()
    account["groups"] = list(dg.calibration["groups"])
    notes.append(f"the calibration reported is the recalibration with the FRFs, {null.rounds} round(s) from the "
                 f"first (held-out χ² {null.chi2_held:.4g} against {first_chi2:.4g} of the first)")
    return {"calibration": account, "calibrated_xml": null.calibration.xml}


def _explained(dg: Diagnosis, winners, base, null, done, held, ds, settings, record: dict, notes: list, gap: bool,
               t) -> Diagnosis:
    """The diagnosis explained by the best of the confirmed ``winners`` (by held-out χ² and its
    parameter count), its confidence the bootstrap selection frequency among ``base`` (the
    baseline: null recalibration or first calibration) and every candidate run (``done``)."""
    best = min(winners, key=lambda c: c.chi2_held + c.effect.n_params * np.log(max(c.n_held, 2)))
    # confidence: bootstrap selection frequency over the held-out postures among the null and
    # the confirmed candidates
    n_units = [best.objective.n_posture(p) for p in held]
    weights = selection_weights([base.chi2_held_posture] + [c.chi2_held_posture for c in done],
                                n_units, [0] + [c.effect.n_params for c in done])
    conf = float(weights[1 + done.index(best)])
    shrink, interval = bootstrap_shrink(base.chi2_held_posture, best.chi2_held_posture, settings.bootstrap)
    before, after = _metrics(base.objective, ds, Change()), _metrics(best.objective, ds, best.change)
    top = EffectResult(name=best.effect.name, kind=best.effect.kind, location=best.effect.location,
                       params=best.effect.params_dict(best.values), description=best.effect.describe(best.values),
                       heldout_before=before, heldout_after=after, shrink=shrink, shrink_interval=interval,
                       confidence=conf, chosen=True)
    rest = tuple(e for e in dg.effects if e.name != top.name)
    notes.append(f"confirmed by recalibration with {best.effect.name} freed: held-out χ²/residual "
                 f"{best.chi2_held / max(best.n_held, 1):.3g} against {base.chi2_held / max(base.n_held, 1):.3g} "
                 "without it (the first effect's shrink is against the better of the first calibration and "
                 "a recalibration without it)")
    if not gap:
        notes.append(f"the ordinary calibration reached the data only with {', '.join(record['pinned'])} on a "
                     f"bound of the spread (training objective {null.train_objective:.3g}, data and prior); with "
                     f"{best.effect.name} freed it is {best.train_objective:.3g} and the size lies beyond the "
                     "spread: the held-out shrink is small because the calibration had mimicked the effect")
    design_changes = (best.effect.describe(best.values),) if not best.change.is_null() else ()
    # the calibration the verdict rests on: the ordinary parameters refitted with the effect freed
    # beside them; the first calibration had bent them to mimic the effect
    account = best.calibration.to_json()
    account["groups"] = list(dg.calibration["groups"])
    notes.append(f"the calibration reported is the recalibration with {best.effect.name} freed")
    return replace(dg, verdict="explained", effects=(top,) + rest, variant_xml=best.calibration.xml,
                   design_changes=design_changes, notes=tuple(notes), confirmation=record, seconds=_seconds(t),
                   localisation=dg.where.describe(), calibration=account)


def _confirm_picks(models, lib: dict, n: int) -> list:
    """The candidates to confirm: the best-scored refined single of each confirmable kind (the
    tool holder, the spindle bearings, the foundation, a body's mass, a sensor's placement), then
    the kinds no refined single stands for (not a sensor: it is confirmed at its fitted size), at
    most ``n``, and the foundation always.

    One per kind rather than the best few overall: after a calibration has moved the ordinary
    parameters to mimic a structural effect, the first-order search can rank that effect below
    the others (a sliding foundation's sway is what the first joints' stiffness and the base's
    tilt mimic best), and the recalibration is what can tell them apart. The foundation is the
    effect the ordinary parameters mimic most completely (the base group's tilt and the links'
    centres of mass take a slide up), so it is confirmed even when four others rank above it:
    on the calibration bench (seed 17832, robot 2) a foundation sliding 94 µm/kN came fifth."""
    from rmbench.gap.frf.confirm import DESIGN_KINDS, confirmable

    best = {}
    for m in models:
        if len(m["params"]) != 1:
            continue
        name, = m["params"]
        effect = lib.get(name)
        if effect is None or not confirmable(effect):
            continue
        if effect.kind not in best or m["score"] < best[effect.kind][0]:
            best[effect.kind] = (m["score"], effect)
    picks = [e for _, e in sorted(best.values(), key=lambda x: x[0])]
    for effect in lib.values():
        # a sensor is confirmed at its fitted size: only a refined one
        if (confirmable(effect) and effect.kind not in ("added_mass",) + DESIGN_KINDS
                and effect.kind not in best):
            best[effect.kind] = (np.inf, effect)
            picks.append(effect)
    out = picks[:n]
    out += [e for e in picks[n:] if e.kind == "base_compliance"]
    return out


def _fitted_sizes(models) -> dict:
    """``{effect name: values}`` of every refined single (the size a sensor candidate is
    confirmed at), in the effect's units."""
    return {name: np.array(list(values.values()), float)
            for m in models if len(m["params"]) == 1 for name, values in m["params"].items()}


# ordinary parameters that stand for a confirmable structural effect when they end on a bound of
# their spread: a link's mass (a mass added to it), the tool holder, the foundation
def _pinned_effect(name: str) -> str | None:
    if name.endswith(".mass"):
        return f"added_mass@{name[:-len('.mass')]}"
    if name.startswith("tool_contact."):
        return "tool_contact_stiffness@tool_contact"
    if name.startswith("base."):
        return "base_compliance@base"
    return None


def _pinned(cal, lib: dict) -> list:
    """The confirmable effects behind the ordinary parameters the calibration ``cal`` left on a
    bound of their prior range (a spread-only robot leaves none there: 0 of 20 on the calibration
    bench's seeds 54196 and 57124), in the calibration's parameter order."""
    out = []
    for p in cal.params:
        # a parameter whose nominal is its bound (a rigid foundation) rests there by default
        effect = lib.get(_pinned_effect(p.name)) if p.on_bound and not np.isclose(p.value, p.nominal) else None
        if effect is not None and effect not in out:
            out.append(effect)
    return out


def _beyond_spread(c, nominal, groups) -> bool:
    """Whether some parameter a confirmed candidate freed that is also an ordinary parameter of
    ``groups`` has its 95 % interval wholly outside that parameter's prior range."""
    from rmbench.robot.parameters import parameter_set

    _, ordinary = parameter_set(nominal, groups)
    bounds = {p.name: (p.lower, p.upper) for p in ordinary}
    names = [p.name for p in c.calibration.params]
    u = np.asarray(c.calibration.u, float)
    sd = np.sqrt(np.clip(np.diag(np.asarray(c.calibration.cov_u, float)), 0, None))
    for n in c.freed:
        if n in bounds:
            i = names.index(n)
            lo, hi = u[i] - 1.96 * sd[i], u[i] + 1.96 * sd[i]
            if lo > bounds[n][1] or hi < bounds[n][0]:
                return True
    return False


def _spread_checked(dg: Diagnosis, nominal, first) -> Diagnosis:
    """The joint search's explanation, unless every effect it chose is an ordinary parameter of
    the calibration (the tool holder, a link's mass) that ends inside its ordinary spread: then
    the calibration's prior merely held that parameter back, and the gap is no structural one."""
    from rmbench.robot.parameters import parameter_set

    cal, _, cal_settings = first
    _, ordinary = parameter_set(nominal, cal_settings.groups)
    bounds = {p.name: (p.lower, p.upper) for p in ordinary}
    cal_u = dict(zip([p.name for p in cal.params], np.asarray(cal.u, float)))
    chosen = [e for e in dg.effects if e.chosen]
    totals = [_ordinary_total(e, cal_u, nominal) for e in chosen]
    if not chosen or any(t is None or not t or any(n not in bounds for n in t) for t in totals):
        return dg
    if not all(bounds[n][0] <= u <= bounds[n][1] for t in totals for n, u in t.items()):
        return dg
    names = ", ".join(e.name for e in chosen)
    note = (f"{names} closes the gap but stays within its ordinary spread (the calibration's prior held it "
            "back): an ordinary parameter, not a structural effect")
    return replace(dg, verdict="no significant gap", notes=dg.notes + (note,))


def _ordinary_total(effect: EffectResult, cal_u: dict, nominal) -> dict | None:
    """``{parameter: u}`` of an effect of the calibrated model's library on top of the first
    calibration, for the kinds an ordinary group also holds; None for the others."""
    if effect.kind == "tool_contact_stiffness":
        return {"tool_contact.translation": cal_u.get("tool_contact.translation", 0.0) + effect.params["ln_translation"],
                "tool_contact.rotation": cal_u.get("tool_contact.rotation", 0.0) + effect.params["ln_rotation"]}
    if effect.kind == "added_mass":
        name = f"{effect.location}.mass"
        m0 = float(nominal.model.body(effect.location).mass[0])
        m = m0 * np.exp(cal_u.get(name, 0.0)) + effect.params["mass"]
        return {name: float(np.log(max(m, 1e-9) / m0))}
    return None


def _within_spread(c, nominal, groups) -> bool:
    """Whether every parameter a confirmed candidate freed that is also an ordinary parameter of
    ``groups`` ended inside that parameter's ordinary prior range (±2σ)."""
    from rmbench.robot.parameters import parameter_set

    _, ordinary = parameter_set(nominal, groups)
    bounds = {p.name: (p.lower, p.upper) for p in ordinary}
    u = dict(zip([p.name for p in c.calibration.params], np.asarray(c.calibration.u, float)))
    shared = [n for n in c.freed if n in bounds]
    return bool(shared) and all(bounds[n][0] <= u[n] <= bounds[n][1] for n in shared)


@dataclass(frozen=True)
class SearchData:
    """What the search runs on, once the data are in.

    Attributes
    ----------
    robot : Robot
        The model searched from (the nominal, or the calibrated one).
    design : TestDesign
    bench : ModelBench
        ``robot`` under ``design`` at the measured postures.
    meas : tuple of dict
        Per posture, ``{band: MeasuredModes}``.
    frf : tuple of dict or None
        Per posture, ``{band: FrfTarget}``; None for modes alone (a modal table).
    bands : tuple of str
    xyt : ndarray, shape (n_postures, 3)
        Posture coordinates (x, y m; θ rad) of the gap map.
    ds : xarray.Dataset or None
        The measured FRFs (None for a modal table).
    train, held : tuple of int
        Posture indices the candidates are fitted on and scored on.
    """

    robot: object
    design: TestDesign
    bench: ModelBench
    meas: tuple
    frf: tuple | None
    bands: tuple
    xyt: np.ndarray
    ds: object
    train: tuple
    held: tuple


def diagnose_modes(robot, postures, meas, *, design: TestDesign, train, held, bands=("low", "high"),
                   settings: DiagnosisSettings = DiagnosisSettings(), workers: int | None = None,
                   notes=(), bench: ModelBench | None = None, progress=None) -> Diagnosis:
    """The search on measured modes alone (a modal table, no FRFs), on a split the caller chose.

    Parameters
    ----------
    robot : Robot
    postures : sequence of Posture
    meas : sequence of dict
        Per posture, ``{band: MeasuredModes}``.
    design : TestDesign
        The test design the modes were measured under.
    train, held : sequence of int
        Posture indices to fit the candidates on and to score them on.
    notes : sequence of str
        Carried into the diagnosis's notes (which fold this is, say).
    bench : ModelBench, optional
        ``robot`` under ``design`` at ``postures``, to share its caches between calls (folds).
    """
    bench = bench if bench is not None else ModelBench.commanded(robot, design, list(postures))
    xyt = np.array([[p.x, p.y, p.theta] for p in postures])
    data = SearchData(robot, design, bench, tuple(meas), None, tuple(bands), xyt, None, tuple(train),
                      tuple(held))
    return _diagnose(data, settings, workers, progress or (lambda msg: None), {"start": time.perf_counter()},
                     notes=notes)


def _diagnose(data: SearchData, settings, workers, say, t, notes=(), ordinary=None) -> Diagnosis:
    """The search, once the data are in: nominal gap, screening, refinement, pairs, verdict.

    With ``ordinary`` (a calibration's parameters, linearised) every candidate is fitted jointly
    with them on the modal residuals (:mod:`rmbench.gap.frf.joint`)."""
    robot, design, bench, meas, frf, bands = data.robot, data.design, data.bench, data.meas, data.frf, data.bands
    xyt, ds, train, held = data.xyt, data.ds, data.train, data.held
    n = bench.n_postures
    if ordinary is None:
        obj_all = Objective(bench, meas, frf, bands, range(n))
        obj_train = Objective(bench, meas, frf, bands, train)
        obj_held = Objective(bench, meas, frf, bands, held)
    else:
        from rmbench.gap.frf.joint import JointObjective

        obj_train = JointObjective(bench, meas, frf, bands, train, ordinary)
        obj_held = JointObjective(bench, meas, frf, bands, held, ordinary, fitted_on=obj_train)
        obj_all = JointObjective(bench, meas, frf, bands, range(n), ordinary, fitted_on=obj_train)
    nominal_change = Change()
    e_all = obj_all.vector(nominal_change)
    chi2_all, peak_all = float(e_all @ e_all), peak_residual(e_all)
    where = gap_map(bench, meas, ds, bands, nominal_change, xyt, averages=design.averages(),
                    scatter=design.direction_scatter())
    t["where"] = time.perf_counter()
    say("gap map")
    e_held = obj_held.vector(nominal_change)
    nom = Fitted((), (), obj_train.chi2(nominal_change), float(e_held @ e_held),
                 obj_train.n, obj_held.n, peak_held=peak_residual(e_held),
                 chi2_held_posture=per_posture_chi2(obj_held, e_held))
    notes = list(notes)
    effects = library(robot, design)
    if settings.kinds is not None:
        effects = [e for e in effects if e.kind in settings.kinds]
    if settings.calibrate:
        keep = structural_kinds(settings.calibrate)
        effects = [e for e in effects if e.kind in keep]
    if not significant(chi2_all, obj_all.n, p=settings.p_noise, peak=peak_all):
        t["end"] = time.perf_counter()
        return Diagnosis(verdict="no significant gap", effects=(), where=where, where_after=None,
                         localisation=where.describe(), equivalent=(), nominal_chi2=chi2_all,
                         n_residuals=obj_all.n, nominal_peak=peak_all, variant_xml=None, design_changes=(),
                         train=tuple(train), held=tuple(held),
                         models=(_model_row(nom, 1.0),), seconds=_seconds(t), notes=tuple(notes))
    with Refiner(obj_train, obj_held, workers=_cores(workers)) as refiner:
        # screening: every candidate, first order
        e0 = obj_train.vector(nominal_change)
        screens = refiner.screen(effects, e0)
        t["screen"] = time.perf_counter()
        say(f"screened {len(screens)} candidates")
        order = np.argsort([s.chi2 for s in screens])
        singles = refiner.run([((screens[i].effect,), (screens[i].values,))
                               for i in order[:settings.refine]])
        t["refine"] = time.perf_counter()
        say(f"refined {len(singles)} candidates")
        scored = [nom] + singles
        best = min(singles, key=lambda f: f.score)
        explained = _explains(best, nom, settings)
        if not explained and settings.pairs_of > 0:
            singles, pairs = _pairs(refiner, obj_train, effects, singles, screens, settings.pairs_of)
            if pairs:
                scored = [nom] + singles + pairs
                best = min(singles + pairs, key=lambda f: f.score)
                explained = _explains(best, nom, settings)
            t["pairs"] = time.perf_counter()
            say(f"fitted {len(pairs)} pairs")
    weights = _weights(scored, obj_held)
    verdict = "explained" if explained else "unexplained"
    chosen = best if explained else None
    results = _ranked(ds, obj_held, scored, weights, chosen, settings)
    equivalent = _equivalent(screens)
    variant_xml, design_changes, where_after = None, (), None
    if chosen is not None:
        robot_change = chosen.change().robot_part
        variant_xml = bench.robot_for(robot_change).xml if not robot_change.is_null() else robot.xml
        design_changes = tuple(e.describe(v) for e, v in zip(chosen.effects, chosen.values)
                               if e.kind.startswith("sensor_"))
        try:
            where_after = gap_map(bench, meas, ds, bands, chosen.change(), xyt,
                                  averages=design.averages(), scatter=design.direction_scatter())
        except RmbenchError as err:
            notes.append(f"no gap map of the updated model: {err}")
    localisation = where.describe() if explained else _localise(where, screens, e0)
    t["end"] = time.perf_counter()
    return Diagnosis(verdict=verdict, effects=tuple(results), where=where, where_after=where_after,
                     localisation=localisation, equivalent=equivalent, nominal_chi2=chi2_all,
                     n_residuals=obj_all.n, nominal_peak=peak_all, variant_xml=variant_xml, design_changes=design_changes,
                     train=tuple(train), held=tuple(held),
                     models=tuple(_model_row(f, w) for f, w in zip(scored, weights)),
                     seconds=_seconds(t), notes=tuple(notes))


# -- helpers -----------------------------------------------------------------------------------
def _pairs(refiner, obj_train, effects, singles, screens, pairs_of: int) -> tuple[list, list]:
    """Pairs on the best singles: the second effect screened on top of each base, the best
    ``pairs_of`` refined with it. Returns the singles (improved where a pair's effect alone,
    refitted from its value in the pair, beats them) and the pairs."""
    jobs = []
    # the second effect is screened on every other training posture (the pairs are refined on
    # all): half the cost, and the screening only has to rank
    coarse = obj_train.subset(obj_train.postures[::2])
    for first in _pair_bases(singles, _equivalent(screens)):
        base = first.change()
        e1 = coarse.vector(base)
        others = refiner.screen([e for e in effects if e.name != first.effects[0].name],
                                e1, base, grid=GRID_PAIR, postures=coarse.postures)
        jobs += [(first.effects + (sc.effect,), first.values + (sc.values,))
                 for sc in sorted(others, key=lambda s_: s_.chi2)[:pairs_of]]
    pairs = refiner.run(jobs)
    if pairs:
        # each effect of the best pair alone, refitted from its value in the pair: a single's
        # refinement can stall (at a bound, in a local minimum) where the pair's found the way,
        # and a pair whose second effect does nothing must lose to its first
        best_pair = min(pairs, key=lambda f: f.score)
        again = refiner.run([((e,), (v,)) for e, v in zip(best_pair.effects, best_pair.values)])
        singles = _better_singles(singles, again)
    return singles, pairs


def _explains(best: Fitted, nom: Fitted, settings) -> bool:
    """Whether ``best`` explains the gap: its held-out residual is noise, and it closed at least
    ``settings.min_shrink`` of the held-out rms gap (an effect that tidies up a small gap is no
    explanation of it)."""
    if significant(best.chi2_held, best.n_held, p=settings.p_noise, peak=best.peak_held):
        return False
    shrink = 1 - np.sqrt(best.chi2_held / nom.chi2_held) if nom.chi2_held > 0 else 0.0
    return bool(shrink >= settings.min_shrink)


def _bands(ds, design, robot) -> list[str]:
    """Bands present in the data, in the design and overlapping the model's bands."""
    data_bands = [b for b in ("low", "high") if np.any(ds.band.values == b)]
    if not data_bands:
        raise InputError("the data hold no low- or high-band lines")
    out = []
    for b in data_bands:
        if b not in design.band_names:
            raise InputError(f"the test design has no {b} band, which the data have")
        f = ds.freq.values[ds.band.values == b]
        m = robot.bands.get(b)
        if m is None or f[-1] <= m.f_min or f[0] >= m.f_max:
            raise InputError(f"the data's {b} band ({f[0]:g}-{f[-1]:g} Hz) does not overlap the "
                             f"model's ({m.f_min:g}-{m.f_max:g} Hz)" if m else
                             f"the model has no {b} band")
        out.append(b)
    return out


def _check_match(bench, meas, bands, *, least: float = 0.3) -> None:
    """Data of another robot or sensor layout: most measured modes have no model partner."""
    total = paired = 0
    for p in range(bench.n_postures):
        for b in bands:
            _, pairing = mode_residuals(meas[p][b], bench.modes(Change(), p, b))
            total += len(meas[p][b])
            paired += len(pairing.meas)
    if total == 0:
        raise InputError("no modes could be fitted in the measured data")
    if paired < least * total:
        raise InputError(f"the data do not look like this model under this test design: only "
                         f"{paired} of {total} measured modes have a model mode within 15 % in "
                         "frequency and alike in shape (another robot, tool or sensor layout?)")


def _split(ds, heldout: float) -> tuple[list[int], list[int]]:
    """Training and held-out postures: every other posture in (θ, x, y) order (a share
    ``heldout`` held out), so both cover the workspace."""
    n = ds.sizes["posture"]
    order = np.lexsort((ds.y.values, ds.x.values, ds.theta.values))
    if n < 2:
        raise InputError("a diagnosis needs at least 2 measured postures (fit on some, score on "
                         "the others)")
    k = max(1, min(n - 1, int(round(heldout * n))))
    step = n / k
    held = sorted({int(order[int(i * step + step / 2) % n]) for i in range(k)})
    train = [p for p in range(n) if p not in held]
    return train, held


def _cores(workers) -> int:
    import os

    return int(workers) if workers is not None else (os.cpu_count() or 1)


def _spread(train, most: int) -> list[int]:
    if len(train) <= most:
        return list(train)
    idx = np.linspace(0, len(train) - 1, most).round().astype(int)
    return [train[i] for i in idx]


def _pair_bases(singles, equivalent=(), *, within: float = 2.0) -> list:
    """The singles that pairs are built on: the best, and the next best that is not
    indistinguishable from it, if its training χ² is within a factor ``within`` of the best's (a
    look-alike repeats the best's pairs; a far worse second adds pairs the best's screening
    already offers: its partner would have to do the best's work)."""
    ranked = sorted(singles, key=lambda f: f.score)
    if not ranked:
        return []
    first = ranked[0]
    twins = {n for g in equivalent if first.effects[0].name in g for n in g}
    for f in ranked[1:]:
        if f.effects[0].name not in twins:
            return [first, f] if f.chi2_train <= within * first.chi2_train else [first]
    return [first]


def _better_singles(singles, refits) -> list:
    """``singles`` with each refit in place of the same effect's fit if it scores better (or added)."""
    out = {f.effects[0].name: f for f in singles}
    for f in refits:
        name = f.effects[0].name
        if name not in out or f.score < out[name].score:
            out[name] = f
    return list(out.values())


def _xyt(ds) -> np.ndarray:
    return np.column_stack([ds.x.values, ds.y.values, ds.theta.values])


def _weights(scored, held: Objective) -> np.ndarray:
    """Model weights: bootstrap selection frequencies over the held-out postures (see
    :mod:`rmbench.gap.selection`), or over-dispersed BIC weights with fewer than 4 of them."""
    n_post = len(held.postures)
    per = [f.chi2_held_posture for f in scored]
    if any(len(c) != n_post for c in per):     # no per-posture split: one unit
        per = [(f.chi2_held,) for f in scored]
        n_units = [held.n]
    else:
        n_units = [held.n_posture(p) for p in held.postures]
    return selection_weights(per, n_units, [f.k for f in scored])


def _metrics(held: Objective, ds, change) -> dict:
    """Held-out gap metrics of a model (see EffectResult)."""
    bench, meas, bands = held.bench, held.meas, held.bands
    f_err, z_err, macs, frf, unpaired, failed = [], [], [], [], 0, 0
    for p in held.postures:
        try:                  # each band's robot carries its own sensors
            models = {b: bench.modes(change, p, b) for b in bands}
        except RmbenchError:
            failed += 1       # the changed robot cannot hold this posture: counted, not compared
            continue
        for b in bands:
            mm, model = meas[p][b], models[b]
            _, pairing = mode_residuals(mm, model)
            i, j = pairing.meas, pairing.model
            unpaired += len(pairing.unpaired_meas) + len(pairing.unpaired_model)
            if len(i):
                f_err += list(np.abs(model.f_n[j] / mm.f_n[i] - 1))
                z_err += list(np.abs(model.zeta[j] / mm.zeta[i] - 1))
                for a, c in zip(i, j):
                    rd, rm = mm.residue[a].ravel(), model.residue[c].ravel()
                    macs.append(mac(rd, rm))
            if ds is not None:
                sel = ds.band.values == b
                h = ds.H.values[p][sel]
                hm = bench.frf(change, p, b, ds.freq.values[sel])
                frf.append(_DB * np.log(np.abs(hm) / np.abs(h)))
    gap = float(np.sqrt(held.per_posture(change).sum() / held.n))
    return {"gap": gap, "f_err": float(np.mean(f_err)) if f_err else np.nan,
            "zeta_err": float(np.mean(z_err)) if z_err else np.nan,
            "mac": float(np.mean(macs)) if macs else np.nan,
            "frf_db": (float(np.sqrt(np.nanmean(np.concatenate([x.ravel() for x in frf]) ** 2)))
                       if frf else float("nan")),
            "unpaired": int(unpaired), "failed": int(failed)}


def _shrink(held: Objective, before: Change, after: Change, n_boot: int, seed: int = 0):
    """Held-out shrink of the rms normalised gap and its 95 % bootstrap interval over postures."""
    return bootstrap_shrink(held.per_posture(before), held.per_posture(after), n_boot, seed)


def _ranked(ds, held, scored, weights, chosen, settings) -> list[EffectResult]:
    """The effects best first, with held-out evidence and confidences."""
    conf = confidences([[e.name for e in f.effects] for f in scored], weights)
    before = _metrics(held, ds, Change())
    out, seen = [], set()
    order = []
    singles = sorted([f for f in scored if len(f.effects) == 1], key=lambda f: f.score)
    if chosen is not None:
        # within the chosen model, the effect the held-out postures most often select comes
        # first; between equally certain ones, the one that alone explains the most
        alone = {f.effects[0].name: f.score for f in singles}
        order += sorted(((chosen, k) for k in range(len(chosen.effects))),
                        key=lambda fk: (-round(conf.get(fk[0].effects[fk[1]].name, 0.0), 6),
                                        alone.get(fk[0].effects[fk[1]].name, np.inf)))
    order += [(f, 0) for f in singles]
    for fitted, k in order:
        eff, val = fitted.effects[k], fitted.values[k]
        if eff.name in seen:
            continue
        seen.add(eff.name)
        is_chosen = chosen is not None and fitted is chosen
        change = fitted.change() if is_chosen else eff.change(val)
        after = _metrics(held, ds, change)
        shrink, interval = _shrink(held, Change(), change, settings.bootstrap)
        out.append(EffectResult(name=eff.name, kind=eff.kind, location=eff.location,
                                params=eff.params_dict(val), description=eff.describe(val),
                                heldout_before=before, heldout_after=after, shrink=shrink,
                                shrink_interval=interval, confidence=conf.get(eff.name, 0.0),
                                chosen=is_chosen))
    return out


def _equivalent(screens, *, cos_min: float = 0.995) -> tuple:
    """Groups of candidates whose first-order signatures coincide (|cos| ≥ ``cos_min``)."""
    vecs, names = [], []
    for s in screens:
        v = s.sensitivity[:, 0]
        norm = np.linalg.norm(v)
        if norm > 0:
            vecs.append(v / norm)
            names.append(s.effect.name)
    if len(vecs) < 2:
        return ()
    V = np.array(vecs)
    cos = np.abs(V @ V.T)
    groups, used = [], set()
    for i in range(len(names)):
        if i in used:
            continue
        g = [j for j in range(len(names)) if cos[i, j] >= cos_min]
        if len(g) > 1:
            used.update(g)
            groups.append(tuple(names[j] for j in g))
    return tuple(groups)


def _localise(where: GapMap, screens, e0) -> str:
    """For an unexplained gap: where it lies, and which candidates come closest to it."""
    chi0 = float(e0 @ e0)
    near = sorted(screens, key=lambda s: s.chi2)[:3]
    closest = ", ".join(f"{s.effect.name} (closes {100 * (1 - s.chi2 / chi0):.0f} % to first order)"
                        for s in near)
    return f"{where.describe()}; closest candidates: {closest}"


def _model_row(f: Fitted, w: float) -> dict:
    return {"name": f.name, "params": {e.name: e.params_dict(v) for e, v in zip(f.effects, f.values)},
            "chi2_train": f.chi2_train, "n_train": f.n_train, "chi2_held": f.chi2_held,
            "n_held": f.n_held, "peak_held": f.peak_held, "score": f.score, "weight": float(w),
            "chi2_held_posture": [float(c) for c in f.chi2_held_posture]}


def _seconds(t: dict) -> dict:
    keys = list(t)
    return {k: round(t[k] - t[keys[i - 1]], 3) for i, k in enumerate(keys) if i > 0} | {
        "total": round(t[keys[-1]] - t[keys[0]], 3)}
