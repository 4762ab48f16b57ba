"""The results of an FRF gap diagnosis: each ranked effect with its held-out evidence
(:class:`EffectResult`), the diagnosis (:class:`Diagnosis`) and the calibrated noise tests of
:func:`~rmbench.gap.frf.diagnosis.remaining_gap` (:class:`RemainingGap`), each with its JSON form."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from rmbench.gap.frf.where import GapMap
from rmbench.gap.selection import VERDICTS, Verdict

__all__ = ["Verdict", "VERDICTS", "EffectResult", "Diagnosis", "RemainingGap", "model_row", "step_seconds"]

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
        """The result's fields by name for JSON output (``shrink_interval`` as a two-element list;
        ``params`` in their units, ``shrink`` and ``confidence`` dimensionless)."""
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
    verdict : Verdict
        ``"explained"``, ``"unexplained"``, ``"model form"`` or ``"no significant gap"``.
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
    form : dict or None
        With ``settings.calibrate``: the calibrated model's lack-of-fit test at the held-out
        postures (:meth:`rmbench.calibrate.form.FormCheck.to_dict`); where it fails and no effect
        explains the gap, the verdict is "model form".
    """

    verdict: Verdict
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
    form: dict | None = None

    def __post_init__(self):
        if self.verdict not in VERDICTS:
            raise ValueError(f"unknown verdict {self.verdict!r}")

    def to_dict(self, variant_path: str | None = None) -> dict:
        """The CLI's ``--json`` and ``diagnosis.json``: verdict, effects best first, where, the
        updated variant's path ``variant_path``, timings, notes, calibration and confirmation."""
        return {"verdict": self.verdict, "effects": [e.to_dict() for e in self.effects],
                "where": {**self.where.summary(), "describe": self.where.describe(),
                          "localisation": self.localisation},
                "equivalent": [list(g) for g in self.equivalent],
                "nominal_chi2_per_residual": self.nominal_chi2 / max(self.n_residuals, 1),
                "nominal_peak_residual": self.nominal_peak,
                "design_changes": list(self.design_changes),
                "variant": variant_path, "seconds": self.seconds, "notes": list(self.notes),
                "calibration": self.calibration, "confirmation": self.confirmation, "form": self.form}

    def to_json(self, variant_path: str | None = None) -> dict:
        """:meth:`to_dict` (the name the CLI and older callers use)."""
        return self.to_dict(variant_path)

    def summary(self) -> str:
        """A few lines for a person: the verdict, the chosen effects with their held-out shrink
        and confidence (or the closest candidates), and where the nominal model's gap lies."""
        per = self.nominal_chi2 / max(self.n_residuals, 1)
        lines = [f"verdict: {self.verdict} (nominal χ²/residual {per:.3g} over {self.n_residuals} residuals, "
                 f"peak {self.nominal_peak:.3g})"]
        for e in [e for e in self.effects if e.chosen] or list(self.effects[:3]):
            lo, hi = e.shrink_interval
            lines.append(f"{'chosen' if e.chosen else 'candidate'} {e.name}: {e.description}; held-out shrink "
                         f"{e.shrink:.2f} [{lo:.2f}, {hi:.2f}], confidence {e.confidence:.2f}")
        lines.append(f"where: {self.localisation}")
        if self.form is not None:
            f = self.form
            lines.append(f"form: {'wrong' if f['flagged'] else 'consistent'} at the held-out postures "
                         f"(frequencies χ² {f['chi2']:.4g} on {f['n']} modes, p {f['p']:.2g}, {f['beyond']} beyond 3σ)")
        return "\n".join(lines)

    def plot(self, ax=None):
        """The ranked effects' held-out shrink of the gap with its 95 % bootstrap interval, the
        chosen ones green, each with its confidence (:func:`rmbench.gap.plot.plot_effects`).

        Parameters
        ----------
        ax : matplotlib.axes.Axes, optional
            Drawn into; a new figure's by default.

        Returns
        -------
        matplotlib.axes.Axes
        """
        from rmbench.gap.plot import plot_effects

        return plot_effects(self, ax)

    def save(self, directory: str | Path) -> dict:
        """Write ``diagnosis.json``, ``effects.csv``, ``gap_modes.csv`` (and
        ``gap_modes_after.csv``, the updated model's gap, when there is one), the figures and the
        updated variant (``variant.xml``, when there is one) into ``directory``
        (:func:`rmbench.gap.frf.files.write_diagnosis`).

        Returns
        -------
        dict
            ``{"json", "effects", "modes", "modes_after", "variant", "calibrated", "figures"}``
            paths.
        """
        from rmbench.gap.frf.files import write_diagnosis

        return write_diagnosis(self, directory)


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
        """The fields by name for JSON output: the χ² (dimensionless), residual count and largest
        residual of the first test, both verdicts, the null recalibration's account (or None) and
        the time taken, s."""
        return {"chi2_all": self.chi2_all, "n_all": self.n_all, "peak_all": self.peak_all,
                "first_significant": self.first_significant, "null": self.null,
                "significant": self.significant, "seconds": self.seconds}


def model_row(f, w: float) -> dict:
    """A scored model's row of :attr:`Diagnosis.models`: ``f`` a
    :class:`~rmbench.gap.frf.search.Fitted`, ``w`` its selection weight."""
    return {"name": f.name, "params": {e.name: e.params_dict(v) for e, v in zip(f.effects, f.values)},
            "chi2_train": f.chi2_train, "n_train": f.n_train, "chi2_held": f.chi2_held,
            "n_held": f.n_held, "peak_held": f.peak_held, "score": f.score, "weight": float(w),
            "chi2_held_posture": [float(c) for c in f.chi2_held_posture]}


def step_seconds(t: dict) -> dict:
    """Seconds of each step of ``t`` (``{step: time.perf_counter() at its end}``, ``"start"``
    first), and the total."""
    keys = list(t)
    return {k: round(t[k] - t[keys[i - 1]], 3) for i, k in enumerate(keys) if i > 0} | {
        "total": round(t[keys[-1]] - t[keys[0]], 3)}
