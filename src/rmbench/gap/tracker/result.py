"""The result of a tracker gap diagnosis: each ranked source with its evidence
(:class:`SourceResult`), a fitted model's positions (:class:`FittedPose`) and the diagnosis
(:class:`TrackerDiagnosis`) with its JSON form, summary and figure; its files are
:mod:`rmbench.gap.tracker.files`'s."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rmbench.gap.jsonable import jsonable
from rmbench.gap.selection import VERDICTS, Verdict
from rmbench.gap.tracker.sources import PoseModel
from rmbench.gap.tracker.where import PoseErrorMap

__all__ = ["SourceResult", "FittedPose", "TrackerDiagnosis"]


@dataclass(frozen=True)
class SourceResult:
    """One ranked source with its evidence.

    Attributes
    ----------
    name, kind, location : str
    params : dict
        Fitted parameters, SI.
    description : str
        The same in user units.
    share : float
        Share of the held-out mean squared error it removes within the chosen model (0 if not
        chosen); the chosen shares sum to the model's reduction.
    confidence : float
        Share of bootstrap resamples of the held-out configurations whose winning model holds it
        and leaves noise. Inside "unexplained" or "model form" (no model leaves noise), a chosen
        source whose held-out drop added alone to the calibration is decisive and that no joint's
        generic augmentation beats is named beside the gap: its share of the resamples won by a
        model holding it; 0 for the others.
    heldout_after : dict
        Held-out ``rms`` and ``max`` pose error (m) of the model with this source (the chosen
        model for a chosen source, the source alone otherwise).
    chosen : bool
    """

    name: str
    kind: str
    location: str
    params: dict
    description: str
    share: float
    confidence: float
    heldout_after: dict
    chosen: bool


class FittedPose:
    """A fitted model's TCP positions in the tracker frame (the registration included).

    Parameters
    ----------
    model : PoseModel
    sources, values : sequences
        The model's sources and one parameter array each.
    rotation, translation : ndarray
        Registration: tracker-frame position = R p + t.
    """

    def __init__(self, model: PoseModel, sources, values, rotation, translation):
        self.model = model
        self.sources, self.values = tuple(sources), tuple(values)
        self.rotation, self.translation = np.asarray(rotation), np.asarray(translation)

    def position(self, q, drive=None) -> np.ndarray:
        """Positions at commands q (n, n_joint), rad, shape (n, 3), m; ``drive`` (n,): hours since
        the first reading, or kelvin above its temperature (thermal drift)."""
        p = self.model.positions(np.atleast_2d(np.asarray(q, float)), self.sources, self.values,
                                 drive=drive)
        return p @ self.rotation.T + self.translation


@dataclass(frozen=True)
class TrackerDiagnosis:
    """Result of :func:`diagnose_tracker`.

    Attributes
    ----------
    verdict : Verdict
        ``"explained"``, ``"unexplained"`` or ``"no significant gap"``.
    sources : tuple of SourceResult
        Chosen sources first (by share), then the others by held-out score.
    where : PoseErrorMap
    heldout_before, heldout_after : dict
        Held-out ``rms`` and ``max`` pose error, m, with ``rms_interval`` and ``max_interval``
        (95 % bootstrap over held-out configurations), and ``chi2_per_n``.
    shrink : float
        ``1 − rms_after / rms_before`` on the held-out configurations.
    shrink_interval : tuple of float
    equivalent : tuple of tuple of str
        Sources the data cannot tell apart (parallel signatures after the registration).
    absorbed : tuple of str
        Sources the base registration takes up entirely.
    values : dict
        ``{source name: parameter list}`` of the chosen model.
    models : tuple of dict
        Every scored model: name, k, training and held-out χ², score, weight.
    n_readings : int
    train, held : tuple of int
        Configuration labels.
    seconds : float
    notes : tuple of str
    calibration : dict or None
        With ``settings.calibrate``: each ordinary parameter's value, 95 % interval and
        identifiability (``params``) as the final model holds them, beside the sources it chose
        (``with``), the intervals' ``widening`` to the held-out lack of fit, and the held-out
        error before and after the calibration alone.
    form : dict or None
        With ``settings.calibrate``: the calibrated pose model's lack-of-fit test at the held-out
        configurations (``flagged``, ``chi2``, ``n``, ``p``, ``peak``); where it fails and no
        source explains the readings, the verdict is "model form".
    fitted, nominal_fitted : FittedPose
        The chosen (else the nominal) model and the registered nominal one.
    """

    verdict: Verdict
    sources: tuple
    where: PoseErrorMap
    heldout_before: dict
    heldout_after: dict
    shrink: float
    shrink_interval: tuple
    equivalent: tuple
    absorbed: tuple
    values: dict
    models: tuple
    n_readings: int
    train: tuple
    held: tuple
    seconds: float
    notes: tuple = field(default=())
    calibration: dict | None = None
    form: dict | None = None
    fitted: FittedPose | None = field(default=None, repr=False, compare=False)
    nominal_fitted: FittedPose | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        if self.verdict not in VERDICTS:
            raise ValueError(f"unknown verdict {self.verdict!r}; one of {', '.join(map(repr, VERDICTS))}")

    @property
    def chosen(self) -> tuple:
        """The sources of the chosen model (marked ``chosen``), in :attr:`sources`' order."""
        return tuple(s for s in self.sources if s.chosen)

    def to_dict(self) -> dict:
        """The CLI's ``--json`` and ``diagnosis.json``, in the FRF diagnosis's shape: verdict,
        effects (the sources) best first, where, variant (the chosen model's values), the held-out
        error before and after, the models scored, notes and calibration."""
        effects = [{"name": s.name, "location": s.location, "params": s.params,
                    "description": s.description,
                    "heldout_before": self.heldout_before, "heldout_after": s.heldout_after,
                    "shrink": (1 - s.heldout_after["rms"] / self.heldout_before["rms"]
                               if self.heldout_before["rms"] > 0 else 0.0),
                    "share": s.share, "confidence": s.confidence, "chosen": s.chosen}
                   for s in self.sources]
        return jsonable({"verdict": self.verdict, "effects": effects, "where": self.where.to_dict(),
                       "variant": self.values or None, "heldout_before": self.heldout_before,
                       "heldout_after": self.heldout_after, "shrink": self.shrink,
                       "shrink_interval": list(self.shrink_interval),
                       "equivalent": [list(g) for g in self.equivalent], "absorbed": list(self.absorbed),
                       "models": list(self.models), "n_readings": self.n_readings,
                       "seconds": self.seconds, "notes": list(self.notes), "calibration": self.calibration,
                       "form": self.form})

    def to_json(self) -> dict:
        """:meth:`to_dict` (the name the CLI and older callers use)."""
        return self.to_dict()

    def summary(self) -> str:
        """A few lines for a person: the verdict with the held-out error before and after, the
        chosen sources with their share of the error and confidence (or the closest candidates),
        and where the nominal model's error lies."""
        b, a = self.heldout_before, self.heldout_after
        lo, hi = self.shrink_interval
        lines = [f"verdict: {self.verdict} ({self.n_readings} readings; held-out rms {1e3 * b['rms']:.3f} -> "
                 f"{1e3 * a['rms']:.3f} mm, shrink {self.shrink:.2f} [{lo:.2f}, {hi:.2f}]; noise "
                 f"{1e3 * self.where.noise_rms:.3f} mm rms)"]
        for s in self.chosen or self.sources[:3]:
            what = f"{100 * s.share:.0f} % of the error" if s.chosen else \
                f"held-out rms {1e3 * s.heldout_after['rms']:.3f} mm alone"
            lines.append(f"{'chosen' if s.chosen else 'candidate'} {s.name}: {s.description}; {what}, "
                         f"confidence {s.confidence:.2f}")
        lines.append(f"where: {self.where.describe()}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """Draw into the matplotlib Axes ``ax`` (a new figure's by default) and return it: the
        held-out rms pose error with each ranked source against the nominal's and the chosen
        model's, with their 95 % bootstrap intervals, and the readings' noise
        (:func:`rmbench.gap.plot.plot_sources`)."""
        from rmbench.gap.plot import plot_sources

        return plot_sources(self, ax)

    def save(self, directory) -> dict:
        """Write ``diagnosis.json``, ``sources.csv`` and ``pose_errors.png`` into ``directory``
        (:func:`rmbench.gap.tracker.files.write_diagnosis`); their paths."""
        from rmbench.gap.tracker.files import write_diagnosis

        return write_diagnosis(self, directory)
