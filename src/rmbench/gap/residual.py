"""Measured modes against model modes: pairing and the normalised gap of each mode.

Modes are paired per posture and band by MAC of their residue matrices (``φR φLᵀ``, the 16 FRF
entries' share of the mode, which needs no normalisation of the eigenvectors) and frequency
together (METHODS.md §11), Hungarian assignment. Each measured mode then gives four numbers, each
divided by its uncertainty — the measurement's standard error and a floor for what a test and a
modal fit cannot resolve better:

- frequency ``ln(f_model / f_meas)``, floor 0.1 %;
- damping ``ln(ζ_model / ζ_meas)``, floor 3 %;
- residue scale ``ln(|R_model| / |R_meas|)`` (modal mass, sensor gain), floor 3 %;
- residue shape ``√(1 − MAC)``, floor 0.02 (MAC 0.9996).

A measured mode with no model partner scores ``UNPAIRED`` on its first slot; model modes visible
above 1 % of the band's peak with no measured partner add ``UNPAIRED`` each to one slot per
posture and band. The vector has a fixed layout for a given measurement, so least squares can
move the model freely.

The modes say nothing of what lies between and beyond them — the residual flexibility of a tool
contact, a sensor's gain — so the FRFs themselves enter too: per entry and per quarter of each
band, the mean log-magnitude gap over a dozen lines, divided by the noise of that mean (from the
coherence, or from the modal fit's residual when the data carry none) and a floor of 3 %.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment

__all__ = ["FLOORS", "UNPAIRED", "Pairing", "pair", "mode_residuals", "n_slots", "SLOT_NAMES",
           "FrfTarget", "frf_target", "frf_residuals", "FRF_FLOOR", "FRF_SEGMENTS"]

FLOORS = {"f": 1e-3, "zeta": 0.03, "scale": 0.03, "shape": 0.02}
UNPAIRED = 10.0           # a missing or surplus mode weighs as a 10-sigma gap
_FREQ_SCALE = 0.15        # pairing: 15 % in frequency weighs as much as MAC 0 → 1
_MAX_COST = 1.5
_VISIBLE = 0.01           # a model mode this strong must be seen in the data
SLOT_NAMES = ("f", "zeta", "scale", "shape")


@dataclass(frozen=True)
class Pairing:
    """Which measured mode goes with which model mode at one posture and band.

    Attributes
    ----------
    meas : ndarray of int
        Index of the measured mode of each pair.
    model : ndarray of int
        Index of the model mode of each pair.
    unpaired_meas : ndarray of int
    unpaired_model : ndarray of int
        Model modes visible above 1 % of the band's peak with no measured partner.
    """

    meas: np.ndarray
    model: np.ndarray
    unpaired_meas: np.ndarray
    unpaired_model: np.ndarray


def _mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC between rows of ``a`` (n, k) and rows of ``b`` (m, k): shape (n, m)."""
    num = np.abs(a.conj() @ b.T) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=1), np.sum(np.abs(b) ** 2, axis=1))
    return num / np.where(den > 0, den, 1.0)


def pair(meas, model) -> Pairing:
    """Pair measured and model modes of one posture and band (MAC of residues and frequency)."""
    n, m = len(meas), len(model)
    if n == 0 or m == 0:
        vis = np.flatnonzero(model.peak >= _VISIBLE) if m else np.zeros(0, int)
        return Pairing(np.zeros(0, int), np.zeros(0, int), np.arange(n), vis)
    mac = _mac(meas.residue.reshape(n, -1), model.residue.reshape(m, -1))
    # a measured mode without shape (a table of frequencies and dampings) pairs by frequency
    mac = np.where(np.isfinite(mac), mac, 1.0)
    cost = (1 - mac) + np.abs(np.log(model.f_n[None, :] / meas.f_n[:, None])) / _FREQ_SCALE
    rows, cols = linear_sum_assignment(cost)
    good = cost[rows, cols] <= _MAX_COST
    rows, cols = rows[good], cols[good]
    um = np.setdiff1d(np.arange(n), rows)
    rest = np.setdiff1d(np.arange(m), cols)
    return Pairing(rows, cols, um, rest[model.peak[rest] >= _VISIBLE])


def n_slots(meas_modes: list[dict], bands) -> int:
    """Length of the residual vector of these measurements: 4 a measured mode, 1 a band."""
    return sum(4 * len(per[b]) + 1 for per in meas_modes for b in bands if b in per)


def mode_residuals(meas, model, pairing: Pairing | None = None) -> tuple[np.ndarray, Pairing]:
    """Normalised gap of one posture and band: shape (4 n_meas + 1,), and the pairing used."""
    if pairing is None:
        pairing = pair(meas, model)
    n = len(meas)
    e = np.zeros((n, 4))
    e[pairing.unpaired_meas, 0] = UNPAIRED
    i, j = pairing.meas, pairing.model
    if len(i):
        f_rel = meas.f_std[i] / meas.f_n[i]
        z_rel = meas.zeta_std[i] / np.abs(meas.zeta[i])
        r_rel = meas.residue_std[i]
        with np.errstate(invalid="ignore", divide="ignore"):
            e[i, 0] = np.log(model.f_n[j] / meas.f_n[i]) / np.hypot(_finite(f_rel), FLOORS["f"])
            e[i, 1] = np.log(np.abs(model.zeta[j] / meas.zeta[i])) / np.hypot(_finite(z_rel), FLOORS["zeta"])
            rm = model.residue[j].reshape(len(j), -1)
            rd = meas.residue[i].reshape(len(i), -1)
            e[i, 2] = (np.log(np.linalg.norm(rm, axis=1) / np.linalg.norm(rd, axis=1))
                       / np.hypot(_finite(r_rel), FLOORS["scale"]))
            mac = np.abs(np.sum(rd.conj() * rm, axis=1)) ** 2 / (
                np.sum(np.abs(rd) ** 2, axis=1) * np.sum(np.abs(rm) ** 2, axis=1))
            e[i, 3] = np.sqrt(np.clip(1 - mac, 0, 1)) / np.hypot(_finite(r_rel), FLOORS["shape"])
        e[~np.isfinite(e)] = 0.0   # no shape measured: nothing to compare
    extra = UNPAIRED * np.sqrt(len(pairing.unpaired_model))
    return np.append(e.ravel(), extra), pairing


def _finite(x):
    return np.where(np.isfinite(x), x, 0.0)


FRF_FLOOR = 0.03          # relative: what an FRF measurement's calibration and a model can agree to
FRF_SEGMENTS = 4          # each band's lines in this many segments
_FRF_LINES = 12           # lines used per segment


@dataclass(frozen=True)
class FrfTarget:
    """The measured FRF of one posture and band, reduced to what the residual compares.

    Attributes
    ----------
    freq : ndarray, shape (n_lines,), Hz
        The lines used (evenly picked in each segment).
    segment : ndarray, shape (n_lines,), int
    log_mag : ndarray, shape (n_lines, 4, 4)
        Natural log of the measured magnitude.
    sigma : ndarray, shape (n_segments, 4, 4)
        Uncertainty of a segment's mean log magnitude (noise and floor).
    """

    freq: np.ndarray
    segment: np.ndarray
    log_mag: np.ndarray
    sigma: np.ndarray


def frf_target(freq, H, noise_rel) -> FrfTarget:
    """Reduce one band's measured FRF: ``noise_rel`` (n_freq, 4, 4) is each line's relative noise."""
    n = len(freq)
    edges = np.linspace(0, n, FRF_SEGMENTS + 1).round().astype(int)
    idx, seg = [], []
    for s in range(FRF_SEGMENTS):
        pick = np.unique(np.linspace(edges[s], edges[s + 1] - 1, _FRF_LINES).round().astype(int))
        idx.append(pick)
        seg.append(np.full(len(pick), s))
    idx, seg = np.concatenate(idx), np.concatenate(seg)
    sigma = np.empty((FRF_SEGMENTS, 4, 4))
    for s in range(FRF_SEGMENTS):
        lines = slice(edges[s], edges[s + 1])
        noise = np.sqrt(np.mean(noise_rel[lines] ** 2, axis=0) / max(edges[s + 1] - edges[s], 1))
        sigma[s] = np.hypot(noise, FRF_FLOOR)
    return FrfTarget(freq=np.asarray(freq)[idx], segment=seg, log_mag=np.log(np.abs(H[idx])),
                     sigma=sigma)


def frf_residuals(target: FrfTarget, H_model: np.ndarray) -> np.ndarray:
    """Normalised mean log-magnitude gap of each segment and entry: shape (n_segments * 16,)."""
    d = np.log(np.abs(H_model)) - target.log_mag
    out = np.empty((FRF_SEGMENTS, 4, 4))
    for s in range(FRF_SEGMENTS):
        out[s] = d[target.segment == s].mean(axis=0)
    return (out / target.sigma).ravel()
