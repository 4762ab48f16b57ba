"""Whether a calibrated model's form is right: its lack of fit at the postures it never saw.

After a calibration, the ordinary parameters have done all they can. If the model's form is right
(the robot differs from it only in those parameters), its frequencies at the held-out postures miss
the measured ones by no more than two things allow:

- the measurement's noise: the modal fit's own standard error of each frequency, times the factor
  :data:`KAPPA` (per band) by which those errors must grow to cover 95 % of the fitted frequencies'
  true errors on robots inside the model (``bench/noise_model.py``);
- the calibration's own uncertainty carried to those postures: ``σ_pred² = g Σ gᵀ``, with ``Σ`` the
  posterior covariance of the parameters (not widened by the fit's lack of fit, which is what is
  tested) and ``g`` each held-out frequency's sensitivity to them (forward differences of the exact
  linearisation, one step of a tenth of a prior standard deviation per parameter).

Each held-out measured mode gives ``z = ln(f_model / f_meas) / √((κ σ_meas)² + σ_pred²)``; a measured
mode the model cannot pair counts as :data:`~rmbench.calibrate.residual.UNPAIRED`. The model form
is called wrong ("model form") where ``Σ z²`` exceeds what ``n`` such residuals reach with
probability :data:`P_FORM` and at least two residuals lie beyond 3: a gap the ordinary parameters
cannot close, and not one stray mode. Frequencies alone are tested: a test measures them best, and
every form error moves them.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from scipy.stats import chi2 as chi2_dist

from rmbench.calibrate.model import ModalModel
from rmbench.calibrate.residual import UNPAIRED, pair
from rmbench.modeshape import pair_modes

__all__ = ["KAPPA", "P_FORM", "FormCheck", "form_check", "check_calibration"]

# the modal fit's standard errors' factor for 95 % coverage, per band, measured on six robots inside
# the model (bench/noise_model.py, seed 67771): the high band's errors are near their standard
# errors (92.4 % covered); the low band's are heavy-tailed (67.9 % covered, p95 0.19 % against
# standard errors of 0.002 %: close modes bias one another)
KAPPA = MappingProxyType({"low": 9.7, "high": 1.2})
P_FORM = 1e-3      # the test's level: a robot inside the model is called wrong this rarely
_STEP = 0.1        # finite-difference step, in prior standard deviations
_BEYOND = 3.0      # a residual this many of its standard deviations out is one the noise rarely gives


@dataclass(frozen=True)
class FormCheck:
    """The lack-of-fit test of a calibrated model at its held-out postures.

    Attributes
    ----------
    flagged : bool
        The model's form is wrong: the ordinary parameters cannot explain the held-out
        frequencies.
    chi2 : float
        ``Σ z²`` over the held-out measured modes.
    n : int
        Held-out measured modes tested.
    p : float
        Probability of a χ² this large from noise and the calibration's uncertainty alone.
    beyond : int
        Residuals beyond 3.
    rows : tuple of dict
        Per held-out measured mode: ``posture``, ``band``, ``f_meas`` (Hz), ``f_model`` (Hz or
        None where unpaired), ``sigma_meas`` and ``sigma_pred`` (relative), ``z``.
    kappa : dict
        The measured noise model's factor on the modal fit's standard errors, per band.
    """

    flagged: bool
    chi2: float
    n: int
    p: float
    beyond: int
    rows: tuple
    kappa: dict

    def to_dict(self) -> dict:
        """JSON-ready (strict: no NaN)."""
        return {"flagged": self.flagged, "chi2": self.chi2, "n": self.n, "p": self.p, "beyond": self.beyond,
                "kappa": self.kappa, "rows": [dict(r) for r in self.rows]}

    def summary(self) -> str:
        """One line: the verdict and its numbers."""
        what = "model form: the ordinary parameters cannot explain" if self.flagged else "form consistent with"
        return (f"{what} the held-out frequencies (χ² {self.chi2:.4g} on {self.n} modes, p {self.p:.2g}, "
                f"{self.beyond} beyond 3σ)")


def form_check(mm: ModalModel, data, u, cov_u, postures, *, kappa: dict = KAPPA) -> FormCheck:
    """Test a calibrated model's form on the postures ``postures`` it was not fitted to.

    Parameters
    ----------
    mm : ModalModel
        The model the calibration fitted (its parameters ``u``), at every posture of ``data``.
    data : ModalData
    u : ndarray, shape (k,)
        The calibrated parameters.
    cov_u : ndarray, shape (k, k)
        Their posterior covariance, not widened by the lack of fit.
    postures : sequence of int
        The held-out postures (indices into ``data``).
    kappa : dict
        The factor on the modal fit's standard errors per band (:data:`KAPPA`; a band it does not
        name takes the largest).
    """
    u = np.asarray(u, float)
    sigma = mm.params.sigma()
    rows = []
    for p in postures:
        for b in data.bands:
            meas = data.modes[p].get(b)
            if meas is None or not len(meas):
                continue
            model = mm.modes(u, p, b)
            pr = pair(meas, model)
            grads = _sensitivities(mm, u, sigma, p, b, model, pr.model)
            partner = dict(zip(pr.meas.tolist(), range(len(pr.model))))
            factor = kappa.get(b, max(kappa.values()))
            for i in range(len(meas)):
                s_meas = factor * float(meas.f_std[i]) / float(meas.f_n[i]) if np.isfinite(meas.f_std[i]) else 0.0
                k = partner.get(i)
                if k is None:
                    rows.append({"posture": int(p), "band": b, "f_meas": float(meas.f_n[i]), "f_model": None,
                                 "sigma_meas": s_meas, "sigma_pred": None, "z": UNPAIRED})
                    continue
                g = grads[k]
                s_pred = float(np.sqrt(max(g @ cov_u @ g, 0.0)))
                f_model = float(model.f_n[pr.model[k]])
                scale = np.hypot(s_meas, s_pred)
                z = float(np.log(f_model / meas.f_n[i]) / scale) if scale > 0 else UNPAIRED
                rows.append({"posture": int(p), "band": b, "f_meas": float(meas.f_n[i]), "f_model": f_model,
                             "sigma_meas": s_meas, "sigma_pred": s_pred, "z": z})
    z = np.array([r["z"] for r in rows], float)
    n = len(z)
    total = float(z @ z)
    p_value = float(chi2_dist.sf(total, n)) if n else 1.0
    beyond = int(np.sum(np.abs(z) > _BEYOND))
    return FormCheck(flagged=bool(n and p_value < P_FORM and beyond >= 2), chi2=total, n=n, p=p_value,
                     beyond=beyond, rows=tuple(rows), kappa=dict(kappa))


def check_calibration(robot, data, cal, settings, *, kappa: dict = KAPPA) -> FormCheck | None:
    """:func:`form_check` of a :class:`~rmbench.calibrate.result.Calibration` ``cal`` of the
    nominal ``robot`` to ``data`` with ``settings`` (its groups and extra parameters), on its
    held-out postures; None where it has none."""
    from rmbench.calibrate.fit import model_of

    if not cal.held:
        return None
    mm = model_of(robot, data, settings)
    cov = np.asarray(cal.cov_u, float) / max(float(cal.widening), 1.0) ** 2
    return form_check(mm, data, cal.u, cov, cal.held, kappa=kappa)


def _sensitivities(mm, u, sigma, posture: int, band: str, base, cols) -> np.ndarray:
    """``d ln f / d u`` of the model modes ``cols`` of ``base`` (the model at ``u``), shape
    (len(cols), k): forward differences, each stepped model's modes paired with the base's by
    shape and frequency so a mode is followed, not its rank."""
    out = np.zeros((len(cols), len(u)))
    upper = mm.params.upper()
    for j in range(len(u)):
        h = _STEP * sigma[j]
        if u[j] + h > upper[j]:
            h = -h          # a parameter on its upper bound: step back into the range
        stepped_u = u.copy()
        stepped_u[j] += h
        stepped = mm.modes(stepped_u, posture, band)
        rows, partner = pair_modes(base.f_n, stepped.f_n, base.residue, stepped.residue, freq_scale=0.05,
                                   max_cost=0.5)
        follow = dict(zip(rows.tolist(), partner.tolist()))
        for k, c in enumerate(cols):
            if c in follow:
                out[k, j] = np.log(stepped.f_n[follow[c]] / base.f_n[c]) / h
    return out
