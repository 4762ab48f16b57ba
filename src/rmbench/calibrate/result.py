"""What a calibration returns: the calibrated parameters with their account
(:class:`Calibration`, :class:`ParameterEstimate`), and the per-mode errors before and after that it
reports (:func:`mode_errors`, :func:`error_summary`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rmbench.calibrate.model import ModalModel
from rmbench.calibrate.residual import Pairing, pair
from rmbench.errors import RmbenchError
from rmbench.modeshape import mac

__all__ = ["ParameterEstimate", "Calibration", "mode_errors", "error_summary"]


@dataclass(frozen=True)
class ParameterEstimate:
    """One calibrated parameter, in its display unit (:attr:`Parameter.label`).

    Attributes
    ----------
    name, group, unit : str
    nominal, value : float
    interval : (float, float)
        95 % interval from the posterior covariance.
    identifiability : str
        ``"identifiable"``, ``"weak"`` or ``"not identifiable"``.
    shrink : float
        Posterior over prior standard deviation (0: determined exactly, 1: the data say nothing).
    on_bound : bool
        The estimate sits on its prior range's bound.
    """

    name: str
    group: str
    unit: str
    nominal: float
    value: float
    interval: tuple
    identifiability: str
    shrink: float
    on_bound: bool

    def to_dict(self) -> dict:
        """The estimate as plain JSON types: its name, group and display ``unit``, the nominal,
        calibrated value and 95 % ``interval`` (a two-element list) in that unit, its
        identifiability, ``posterior_over_prior_sd`` (the dimensionless shrink) and ``on_bound``."""
        return {"name": self.name, "group": self.group, "unit": self.unit, "nominal": self.nominal,
                "value": self.value, "interval": list(self.interval),
                "identifiability": self.identifiability, "posterior_over_prior_sd": self.shrink,
                "on_bound": self.on_bound}


@dataclass(frozen=True)
class Calibration:
    """A calibrated robot model and the account of what the data determined.

    Attributes
    ----------
    params : tuple of ParameterEstimate
    u : ndarray, shape (n_params,)
        Calibrated parameters in ``u`` (:mod:`rmbench.robot.parameters`).
    cov_u : ndarray, shape (n_params, n_params)
        Posterior covariance in ``u`` from the training postures (scaled by their χ² per degree
        of freedom where above 1).
    combinations : tuple of str
        Directions the data determine that no single parameter carries alone.
    chi2_before, chi2_after : float
        Training χ² (data part) of the nominal and the calibrated model; ``n_residuals`` entries.
    n_residuals : int
    chi2_prior : float
        The prior's part of the objective at the calibrated parameters, Σ (u/σ)² over the
        parameters with a prior: how far the calibration had to move them from the nominal, in
        prior standard deviations.
    train, held : tuple of int
        Posture indices fitted and held out.
    modes_train, modes_held : dict
        ``{"before": rows, "after": rows}`` per measured mode (:func:`mode_errors`).
    xml : str
        The calibrated MJCF (a comment on its first line names the source data).
    iterations : int
    seconds : float
    notes : tuple of str
    at_limit : bool
        The fit stopped at its limit of evaluations (``CalibrationSettings.max_iter``) rather
        than converging.
    chi2_held, n_held : float, int
        Data χ² of the calibrated model on the held-out postures and its number of residuals
        (0 and 0 without held-out postures).
    widening : float
        Factor on the intervals' half-widths beyond ``cov_u``'s: ``√(χ²_held/n_held)`` over the
        training scale where that is larger, else 1.
    """

    params: tuple
    u: np.ndarray
    cov_u: np.ndarray
    combinations: tuple
    chi2_before: float
    chi2_after: float
    n_residuals: int
    train: tuple
    held: tuple
    modes_train: dict
    modes_held: dict
    xml: str
    iterations: int
    seconds: float
    notes: tuple = field(default=())
    chi2_prior: float = 0.0
    at_limit: bool = False
    chi2_held: float = 0.0
    n_held: int = 0
    widening: float = 1.0

    @property
    def chi2_per_residual(self) -> dict:
        """Training χ² per residual ``{"before": ..., "after": ...}`` of the nominal and the
        calibrated model (about 1 where the model explains the data to its noise)."""
        n = max(self.n_residuals, 1)
        return {"before": self.chi2_before / n, "after": self.chi2_after / n}

    def heldout_summary(self) -> dict:
        """Mean and p95 of the held-out |f| and |ζ| errors before and after, unpaired counts."""
        return {k: error_summary(v) for k, v in self.modes_held.items()}

    def to_dict(self) -> dict:
        """The account as plain JSON types: estimates, combinations, χ² per residual, errors, notes."""
        return {"params": [p.to_dict() for p in self.params], "combinations": list(self.combinations),
                "chi2_per_residual": self.chi2_per_residual,
                "chi2_prior": self.chi2_prior,
                "chi2_per_residual_held": self.chi2_held / self.n_held if self.n_held else None,
                "interval_widening": self.widening,
                "n_residuals": self.n_residuals, "train": list(self.train), "held": list(self.held),
                "train_errors": {k: error_summary(v) for k, v in self.modes_train.items()},
                "heldout_errors": self.heldout_summary(),
                "heldout_modes": self.modes_held, "iterations": self.iterations,
                "at_limit": self.at_limit, "seconds": self.seconds, "notes": list(self.notes)}

    def to_json(self) -> dict:
        """:meth:`to_dict` (the name its callers first knew)."""
        return self.to_dict()

    def summary(self) -> str:
        """A few readable lines: χ² per residual before and after, the held-out errors, and the
        parameters the data identify (value, 95 % interval and unit)."""
        chi2 = self.chi2_per_residual
        lines = [f"calibrated on {len(self.train)} postures ({len(self.held)} held out), {len(self.params)} "
                 f"parameters, {self.iterations} evaluations{' (at its limit)' if self.at_limit else ''}",
                 f"χ²/residual {chi2['before']:.3g} before, {chi2['after']:.3g} after "
                 f"({self.n_residuals} residuals)"
                 + (f"; held out {self.chi2_held / self.n_held:.3g} ({self.n_held})" if self.n_held else "")]
        if self.modes_held:
            lines.append("held-out errors: " + _errors_line(self.heldout_summary()))
        known = [p for p in self.params if p.identifiability == "identifiable"]
        lines.append(f"identifiable: {len(known)} of {len(self.params)} parameters")
        lines += [f"  {p.name} {p.value:.4g} [{p.interval[0]:.4g}, {p.interval[1]:.4g}] {p.unit} "
                  f"(nominal {p.nominal:.4g})" for p in known]
        return "\n".join(lines)

    def plot(self, ax=None):
        """Each parameter's estimate and 95 % interval relative to its nominal, the identifiable
        ones marked (:func:`~rmbench.calibrate.plot.plot_estimates`).

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        from rmbench.calibrate.plot import plot_estimates

        return plot_estimates(self.params, ax=ax)

def error_summary(rows) -> dict:
    """Mean and p95 of the paired modes' |f| and |ζ| errors, and the paired and unpaired counts, of
    :func:`mode_errors` rows (None where no mode paired)."""
    f = np.array([abs(r["f_err"]) for r in rows if r["paired"]])
    z = np.array([abs(r["zeta_err"]) for r in rows if r["paired"]])
    return {"f_err_mean": float(f.mean()) if len(f) else None,
            "f_err_p95": float(np.percentile(f, 95)) if len(f) else None,
            "zeta_err_mean": float(z.mean()) if len(z) else None,
            "zeta_err_p95": float(np.percentile(z, 95)) if len(z) else None,
            "paired": int(len(f)), "unpaired": int(sum(not r["paired"] for r in rows))}


def mode_errors(mm: ModalModel, u, data, postures) -> list[dict]:
    """Per measured mode at the given postures: its model partner's relative frequency and
    damping error (``model/measured − 1``), or unpaired.

    Rows: ``{"posture", "x_mm", "y_mm", "theta_deg", "band", "mode", "f_meas", "f_model",
    "zeta_meas", "zeta_model", "f_err", "zeta_err", "mac", "paired"}`` (None where unpaired).
    """
    rows = []
    for p in postures:
        post = data.postures[p]
        for b in data.bands:
            meas = data.modes[p].get(b)
            if meas is None or not len(meas):
                continue
            try:
                model = mm.modes(u, p, b)
                pr = pair(meas, model)
            except RmbenchError:
                model, pr = None, Pairing(np.zeros(0, int), np.zeros(0, int), np.arange(len(meas)), np.zeros(0, int))
            partner = dict(zip(pr.meas.tolist(), pr.model.tolist()))
            for i in range(len(meas)):
                j = partner.get(i)
                row = {"posture": int(p), "x_mm": 1e3 * post.x, "y_mm": 1e3 * post.y,
                       "theta_deg": float(np.degrees(post.theta)), "band": b,
                       "mode": int(meas.mode_id[i]) if meas.mode_id is not None else i,
                       "f_meas": float(meas.f_n[i]), "zeta_meas": float(meas.zeta[i]), "paired": j is not None,
                       "f_model": None, "zeta_model": None, "f_err": None, "zeta_err": None, "mac": None}
                if j is not None:
                    row.update(f_model=float(model.f_n[j]), zeta_model=float(model.zeta[j]),
                               f_err=float(model.f_n[j] / meas.f_n[i] - 1),
                               zeta_err=float(model.zeta[j] / meas.zeta[i] - 1))
                    rd, rm = meas.residue[i].ravel(), model.residue[j].ravel()
                    if np.all(np.isfinite(rd)):
                        row["mac"] = float(mac(rd, rm))
                rows.append(row)
    return rows


def _errors_line(summary: dict) -> str:
    """``|f| mean 2.1 % → 0.3 %, |ζ| mean 12 % → 4 %, unpaired 1 → 0`` from before and after
    summaries (:func:`error_summary`)."""
    before, after = summary["before"], summary["after"]

    def pct(x):
        return "–" if x is None else f"{100 * x:.2g} %"

    return (f"|f| mean {pct(before['f_err_mean'])} → {pct(after['f_err_mean'])}, "
            f"|ζ| mean {pct(before['zeta_err_mean'])} → {pct(after['zeta_err_mean'])}, "
            f"unpaired {before['unpaired']} → {after['unpaired']}")
