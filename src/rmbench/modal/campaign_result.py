"""A campaign's modal fit that describes itself: :class:`CampaignFit` over the modal dataset of
:func:`~rmbench.modal.campaign_fit.fit_campaign`.

    res = CampaignFit(fit_campaign(ds))
    print(res.summary())          # postures, bands, tracked modes, band fits that need a look
    res.to_dict()                 # strict JSON: each posture's bands' verdicts and modes
    res.plot()                    # fitted natural frequencies over the postures
    res.truth_errors()            # where the campaign had ground truth: percentiles of the errors

The dataset stays the result (netCDF, the other stages read it); this is its account.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr

from rmbench.io.strict_json import jsonable
from rmbench.modal.campaign_fit import COORDS, mode_vectors

__all__ = ["CampaignFit"]

_UNITS = {"f_n": "Hz", "zeta": "ratio", "phiR": "s/kg", "phiL": "1"}


@dataclass(frozen=True)
class CampaignFit:
    """The account of a campaign's modal fit.

    Attributes
    ----------
    modal : xarray.Dataset
        :func:`~rmbench.modal.campaign_fit.fit_campaign`'s dataset (``modal``, ``modal_std``,
        ``fit_ok``, ``fit_reason``, ``fit_notes``, the per-mode evidence; ``f_err``... with truth).
    """

    modal: xr.Dataset

    def truth_errors(self) -> dict | None:
        """Percentiles of the fitted modes' errors against the campaign's exact ones over every
        (posture, mode): ``f_err_p95`` and ``zeta_err_p95`` (of the absolute relative errors),
        ``mac_phiR_p05`` and ``mac_phiL_p05``; None for a campaign without ground truth."""
        res = self.modal
        if "f_err" not in res:
            return None
        return {"f_err_p95": float(np.nanpercentile(np.abs(res.f_err), 95)),
                "zeta_err_p95": float(np.nanpercentile(np.abs(res.zeta_err), 95)),
                "mac_phiR_p05": float(np.nanpercentile(res.mac_phiR, 5)),
                "mac_phiL_p05": float(np.nanpercentile(res.mac_phiL, 5))}

    def summary(self, bands=None) -> str:
        """A few readable lines: postures, bands and tracked modes (per band of ``bands``, default
        the fitted ones), the fitting time (s), the band fits that need a look and why, and the
        errors against ground truth where there is some (:meth:`truth_errors`)."""
        res = self.modal
        bands = [str(b) for b in res.fit_band.values] if bands is None else bands
        ok = res.fit_ok.values
        lines = [f"fitted {res.sizes['posture']} postures x {res.sizes['fit_band']} bands, "
                 f"{res.sizes['mode']} tracked modes "
                 f"({', '.join(f'{b}: {int((res.mode_band == b).sum())}' for b in bands)}) in "
                 f"{res.attrs['fit_seconds']:.1f} s; {int(ok.sum())} of {ok.size} band fits ok"]
        lines += [f"  posture {p}, {res.fit_band.values[bi]} band needs a look: {res.fit_reason.values[p, bi]}"
                  for p, bi in np.argwhere(~ok)]
        err = self.truth_errors()
        if err is not None:
            lines.append(f"  against ground truth: |f error| p95 {err['f_err_p95']:.4f}, "
                         f"|zeta error| p95 {err['zeta_err_p95']:.4f}, "
                         f"MAC phiR p05 {err['mac_phiR_p05']:.4f}, phiL p05 {err['mac_phiL_p05']:.4f}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """Strict JSON types: per posture each band's verdict (``fit_ok``, ``fit_reason``,
        ``notes``) and each fitted mode's f_n (Hz), ζ, standard errors, evidence, φL and φR
        (``[re, im]`` per coordinate; ``units``); a one-posture campaign as that posture alone."""
        res = self.modal
        if res.sizes["posture"] == 1:
            out = {"fit_ok": bool(res.fit_ok.values[0].all()), "bands": self._bands_of(0),
                   "modes": self._modes_of(0), "units": _UNITS}
        else:
            out = {"postures": [{"index": int(p), "fit_ok": bool(res.fit_ok.values[p].all()),
                                 "bands": self._bands_of(p), "modes": self._modes_of(p)}
                                for p in range(res.sizes["posture"])], "units": _UNITS}
        return jsonable(out)

    def plot(self, ax=None):
        """The fitted natural frequencies over the postures, one series per tracked mode (Hz, log
        scale); band fits that need a look are marked on the posture axis.

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        from rmbench.modal.plot import plot_campaign_frequencies

        return plot_campaign_frequencies(self.modal, ax=ax)

    def _modes_of(self, p: int) -> list:
        res, out = self.modal, []
        for m in range(res.sizes["mode"]):
            prm = res.modal.values[p, m]
            if not np.isfinite(prm[0]):
                continue
            r, l = mode_vectors(res, p, m)
            out.append({"f_n": prm[0], "zeta": prm[1], "band": str(res.mode_band.values[m]),
                        "f_n_std": res.modal_std.values[p, m, 0],
                        "zeta_std": res.modal_std.values[p, m, 1],
                        "uncertain": bool(res.mode_uncertain.values[p, m]),
                        "delta_bic": res.mode_delta_bic.values[p, m],
                        "share": res.mode_share.values[p, m],
                        "stable_orders": int(res.mode_stable_orders.values[p, m]),
                        "phiL": {c: [l[i].real, l[i].imag] for i, c in enumerate(COORDS)},
                        "phiR": {c: [r[i].real, r[i].imag] for i, c in enumerate(COORDS)}})
        return out

    def _bands_of(self, p: int) -> dict:
        res = self.modal
        return {str(b): {"fit_ok": bool(res.fit_ok.values[p, i]),
                         "fit_reason": str(res.fit_reason.values[p, i]),
                         "notes": [n for n in str(res.fit_notes.values[p, i]).split("; ") if n]}
                for i, b in enumerate(res.fit_band.values)}
