"""Peaks of predicted against true FRFs: the scores of a tool-change prediction (issue 16)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import find_peaks

__all__ = ["PeakError", "peak_errors"]


@dataclass(frozen=True)
class PeakError:
    """One peak of a true FRF and the prediction's counterpart.

    Attributes
    ----------
    entry : str
        ``"1X/1X"`` style (response/force).
    f_true, f_pred : float
        Peak frequencies, Hz (parabolic interpolation of |H| over the three lines at the top).
    amp_true, amp_pred : float
        Peak magnitudes, m/N.
    """

    entry: str
    f_true: float
    f_pred: float
    amp_true: float
    amp_pred: float

    @property
    def amp_err(self) -> float:
        return self.amp_pred / self.amp_true - 1

    @property
    def freq_err(self) -> float:
        return self.f_pred / self.f_true - 1


def _top(freq, mag, k):
    """Parabolic peak through lines k-1, k, k+1 of |H|: (frequency, magnitude)."""
    if k <= 0 or k >= len(mag) - 1:
        return float(freq[k]), float(mag[k])
    a, b, c = mag[k - 1], mag[k], mag[k + 1]
    den = a - 2 * b + c
    d = 0.5 * (a - c) / den if den != 0 else 0.0
    return float(freq[k] + d * (freq[1] - freq[0])), float(b - 0.25 * (a - c) * d)


def peak_errors(freq: np.ndarray, pred: np.ndarray, truth: np.ndarray, labels: list[str], *,
                prominence: float = 0.1, search: int = 3) -> list[PeakError]:
    """Every peak of each true FRF (prominence ≥ ``prominence`` × its maximum) against the prediction.

    Parameters
    ----------
    freq : ndarray, shape (n_freq,), Hz (evenly spaced)
    pred, truth : ndarray, shape (n_freq, n_entries), complex
    labels : list of str, one per entry
    search : int
        The predicted peak is the largest |H| within ± this many lines of the true peak.
    """
    out = []
    for j, label in enumerate(labels):
        t, p = np.abs(truth[:, j]), np.abs(pred[:, j])
        peaks, _ = find_peaks(t, prominence=prominence * t.max())
        for k in peaks:
            lo, hi = max(0, k - search), min(len(p), k + search + 1)
            if not np.all(np.isfinite(p[lo:hi])):
                out.append(PeakError(label, *_top(freq, t, k)[:1], np.nan, float(t[k]), np.nan))
                continue
            kp = lo + int(np.argmax(p[lo:hi]))
            ft, at = _top(freq, t, k)
            fp, ap = _top(freq, p, kp)
            out.append(PeakError(label, ft, fp, at, ap))
    return out
