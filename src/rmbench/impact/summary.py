"""What a campaign run comes to: postures measured and failed, steps simulated, time per posture.

:func:`~rmbench.impact.campaign.run_campaign` writes a dataset and returns its path;
:meth:`CampaignSummary.load` reads the account of that run back from the dataset (DATA.md's
per-posture ``ok``, ``reason``, ``steps`` and ``seconds``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rmbench.errors import InputError

__all__ = ["CampaignSummary"]


@dataclass(frozen=True)
class CampaignSummary:
    """The account of one campaign run.

    Attributes
    ----------
    out : str
        The dataset file.
    ok : ndarray, shape (n_postures,), bool
        Whether each posture was measured.
    reasons : tuple of str, length n_postures
        Why each posture failed ("" where it was measured).
    steps : ndarray, shape (n_postures,), int
        Integrator steps simulated per posture (0 with the linear method).
    seconds : ndarray, shape (n_postures,), s
        Wall time each posture took on its worker.
    kept : bool
        The file was already a finished run of this configuration: nothing was simulated.
    """

    out: str
    ok: np.ndarray
    reasons: tuple
    steps: np.ndarray
    seconds: np.ndarray
    kept: bool = False

    def __post_init__(self):
        n = len(self.ok)
        for name in ("reasons", "steps", "seconds"):
            if len(getattr(self, name)) != n:
                raise InputError(f"campaign summary: {name} has {len(getattr(self, name))} entries "
                                 f"for {n} postures")

    @classmethod
    def from_dataset(cls, ds, out: str | Path, *, kept: bool = False) -> "CampaignSummary":
        """The account held by a campaign dataset (``ok``, ``reason``, ``steps``, ``seconds``)."""
        for key in ("ok", "reason", "steps", "seconds"):
            if key not in ds:
                raise InputError(f"{out}: not a campaign run's dataset (no {key!r})")
        return cls(str(out), np.asarray(ds["ok"].values, bool), tuple(str(r) for r in ds["reason"].values),
                   np.asarray(ds["steps"].values, int), np.asarray(ds["seconds"].values, float), kept)

    @classmethod
    def load(cls, out: str | Path, *, kept: bool = False) -> "CampaignSummary":
        """The account of the campaign dataset at ``out`` (:func:`~rmbench.impact.open_campaign`)."""
        from rmbench.impact.dataset import open_campaign

        return cls.from_dataset(open_campaign(out), out, kept=kept)

    @property
    def n_postures(self) -> int:
        """Postures in the campaign."""
        return len(self.ok)

    @property
    def n_ok(self) -> int:
        """Postures measured."""
        return int(np.sum(self.ok))

    @property
    def failed(self) -> list[str]:
        """The distinct reasons postures failed, sorted."""
        return sorted({r for r, good in zip(self.reasons, self.ok) if not good})

    @property
    def steps_total(self) -> int:
        """Integrator steps simulated over all postures."""
        return int(np.sum(self.steps))

    def to_dict(self) -> dict:
        """Plain JSON types: file, postures, measured, failure reasons, steps, whether kept."""
        return {"out": self.out, "postures": self.n_postures, "ok": self.n_ok, "failed": self.failed,
                "steps": self.steps_total, "kept": self.kept}

    def summary(self) -> str:
        """A few readable lines: what was written (or kept), postures measured, steps simulated,
        and each distinct reason a posture failed."""
        if self.kept:
            lines = [f"{self.out} is a finished run of this configuration: kept, nothing simulated "
                     "(--force runs it again)"]
        else:
            lines = [f"wrote {self.out}: {self.n_ok} of {self.n_postures} postures measured, "
                     f"{self.steps_total} steps simulated"]
        lines += [f"  failed: {r}" for r in self.failed]
        return "\n".join(lines)

    def plot(self, ax=None):
        """Wall time per posture (s), measured postures in one colour, failed ones in another
        (:func:`~rmbench.impact.plot.plot_campaign_summary`).

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        from rmbench.impact.plot import plot_campaign_summary

        return plot_campaign_summary(self, ax=ax)
