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

Modes closer than their bandwidths trade their parameters off in any fit (the modal stage resolves
modes down to one half-power bandwidth apart, and a weak neighbour left out biases the strong
one), so each floor grows with a mode's overlap ``o = (ζ_i f_i + ζ_j f_j) / |f_i − f_j|`` with its
nearest measured neighbour ``j``: frequency by ``0.1 ζ o``, damping, scale and shape by
``0.2 o`` (added in quadrature). A model mode overlapping a stronger one, or one already
paired, that much (``o ≥ 1``) is not one a test must resolve.

A measured mode with no model partner scores ``UNPAIRED`` on its first slot; model modes inside
the band, above 1 % of its peak and resolvable with no measured partner add ``UNPAIRED`` each to one slot per
posture and band. The vector has a fixed layout for a given measurement, so least squares can
move the model freely.

The modes say nothing of what lies between and beyond them — the residual flexibility of a tool
contact, a sensor's gain — so the FRFs themselves enter too: per entry and per quarter of each
band, the mean log-magnitude gap over a dozen lines, divided by the noise of that mean (from the
coherence, or from the modal fit's residual when the data carry none), the hammer's direction
scatter and a floor of 3 %. A hand-held hammer hits a few tenths of a degree off its axis, and
that error is the same at every line of a hit: a cross entry (X response to a Y hit) picks up
``δ H(i, j')`` from the direct response to the other direction ``j'``, which averaging lines does
not reduce. Its relative size, ``σ_δ / √n_avg · |H(i, j')| / |H(i, j)|``, enters each segment's
uncertainty unreduced (:func:`hammer_leak`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.modeshape import pair_modes

__all__ = ["overlap", "FLOORS", "UNPAIRED", "Pairing", "pair", "mode_residuals", "n_slots", "SLOT_NAMES", "penalties",
           "coarse_residuals", "FrfTarget", "frf_target", "frf_residuals", "FRF_FLOOR", "FRF_SEGMENTS", "hammer_leak"]

FLOORS = {"f": 1e-3, "zeta": 0.03, "scale": 0.03, "shape": 0.02}
UNPAIRED = 10.0           # a missing or surplus mode weighs as a 10-sigma gap
_FREQ_SCALE = 0.15        # pairing: 15 % in frequency weighs as much as MAC 0 → 1
_MAX_COST = 1.5
_VISIBLE = 0.01           # a model mode this strong must be seen in the data
_F_OVERLAP = 0.1          # frequency uncertainty per unit overlap, in units of ζ
_OVERLAP = 0.2            # damping, scale and shape uncertainty per unit overlap
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


def pair(meas, model) -> Pairing:
    """Pair measured and model modes of one posture and band (MAC of residues and frequency)."""
    n, m = len(meas), len(model)
    if n == 0 or m == 0:
        vis = np.flatnonzero(_must_see(model)) if m else np.zeros(0, int)
        return Pairing(np.zeros(0, int), np.zeros(0, int), np.arange(n), vis)
    # a measured mode without shape (a table of frequencies and dampings) pairs by frequency
    rows, cols = pair_modes(meas.f_n, model.f_n, meas.residue, model.residue, freq_scale=_FREQ_SCALE,
                            max_cost=_MAX_COST)
    um = np.setdiff1d(np.arange(n), rows)
    rest = np.setdiff1d(np.arange(m), cols)
    missing = rest[_must_see(model)[rest]]
    if len(missing) and len(cols):
        # a model mode within the bandwidth of a paired one is part of a cluster the test may
        # show as one mode, whichever of the two the pairing took
        f, z = model.f_n, np.abs(model.zeta)
        with np.errstate(divide="ignore"):
            o = (z[missing, None] * f[missing, None] + z[None, cols] * f[None, cols]) / np.abs(
                f[missing, None] - f[None, cols])
        missing = missing[~np.any(o >= 1.0, axis=1)]
    return Pairing(rows, cols, um, missing)


def _must_see(model) -> np.ndarray:
    """Model modes a test must find: inside the band, above 1 % of its peak, and not lost in
    the bandwidth of a stronger mode."""
    f, z, peak = model.f_n, np.abs(model.zeta), model.peak
    with np.errstate(divide="ignore"):
        o = (z[:, None] * f[:, None] + z[None, :] * f[None, :]) / np.abs(f[:, None] - f[None, :])
    hidden = np.any((o >= 1.0) & (peak[None, :] > peak[:, None]), axis=1)
    return (peak >= _VISIBLE) & model.inside & ~hidden


def overlap(f_n: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """Modal overlap of each mode with its nearest neighbour: ``(ζ_i f_i + ζ_j f_j) / |f_i − f_j|``
    maximised over ``j`` (0 for a lone mode), shape (n,)."""
    f, z = np.asarray(f_n, float), np.abs(np.asarray(zeta, float))
    if len(f) < 2:
        return np.zeros(len(f))
    with np.errstate(divide="ignore", invalid="ignore"):
        o = (z[:, None] * f[:, None] + z[None, :] * f[None, :]) / np.abs(f[:, None] - f[None, :])
    np.fill_diagonal(o, 0.0)
    return np.nan_to_num(o, nan=0.0, posinf=1e3).max(axis=1)


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
        o = overlap(meas.f_n, meas.zeta)[i]
        zeta = np.abs(meas.zeta[i])
        f_rel = np.hypot(_finite(meas.f_std[i] / meas.f_n[i]), _F_OVERLAP * zeta * o)
        z_rel = np.hypot(_finite(meas.zeta_std[i] / zeta), _OVERLAP * o)
        r_rel = np.hypot(_finite(meas.residue_std[i]), _OVERLAP * o)
        with np.errstate(invalid="ignore", divide="ignore"):
            e[i, 0] = np.log(model.f_n[j] / meas.f_n[i]) / np.hypot(f_rel, FLOORS["f"])
            e[i, 1] = np.log(np.abs(model.zeta[j] / meas.zeta[i])) / np.hypot(z_rel, FLOORS["zeta"])
            rm = model.residue[j].reshape(len(j), -1)
            rd = meas.residue[i].reshape(len(i), -1)
            e[i, 2] = (np.log(np.linalg.norm(rm, axis=1) / np.linalg.norm(rd, axis=1))
                       / np.hypot(r_rel, FLOORS["scale"]))
            mac = np.abs(np.sum(rd.conj() * rm, axis=1)) ** 2 / (
                np.sum(np.abs(rd) ** 2, axis=1) * np.sum(np.abs(rm) ** 2, axis=1))
            e[i, 3] = np.sqrt(np.clip(1 - mac, 0, 1)) / np.hypot(r_rel, FLOORS["shape"])
        e[~np.isfinite(e)] = 0.0   # no shape measured: nothing to compare
    extra = UNPAIRED * np.sqrt(len(pairing.unpaired_model))
    return np.append(e.ravel(), extra), pairing


_COARSE_F = 0.02          # coarse stage: frequency uncertainty (relative)
_COARSE_SCALE = 0.4       # coarse pairing: 40 % in frequency weighs as much as MAC 0 -> 1
_COARSE_MISSING = np.log(1.5) / _COARSE_F   # an unpaired mode weighs as a 50 % frequency error


def coarse_residuals(meas, model, pairing: Pairing | None = None) -> tuple[np.ndarray, Pairing]:
    """The coarse stage's residual of one posture and band, in the layout of
    :func:`mode_residuals` (4 slots a measured mode, 1 a band): each
    measured mode's frequency error over 2 %, paired by MAC and frequency in a window of ±50 %.

    Far from the truth (a robot whose gearboxes and foundation differ from the data sheet by tens
    of per cent) the fine residual's floors (0.1 % in frequency) make losing a mode cheaper than
    pairing it 15 % off; here a lost mode costs more than any pairing, so the fit moves toward
    pairing every mode.
    """
    n = len(meas)
    if pairing is None:
        rows, cols = pair_modes(meas.f_n, model.f_n, meas.residue, model.residue, freq_scale=_COARSE_SCALE,
                                window=1.5, zero=1.0)
        pairing = Pairing(rows, cols, np.setdiff1d(np.arange(n), rows), np.zeros(0, int))
    e = np.zeros((n, 4))
    e[pairing.unpaired_meas, 0] = _COARSE_MISSING
    e[pairing.meas, 0] = np.log(model.f_n[pairing.model] / meas.f_n[pairing.meas]) / _COARSE_F
    return np.append(e.ravel(), 0.0), pairing


def _finite(x):
    return np.where(np.isfinite(x), x, 0.0)


def penalties(e: np.ndarray) -> np.ndarray:
    """Which slots of a residual vector carry the pairing's penalty rather than a normalised gap,
    shape (n,) of bool.

    A measured mode without a model partner scores exactly ``UNPAIRED`` and ``k`` surplus model
    modes exactly ``UNPAIRED √k`` (:func:`mode_residuals`), values a gap divided by its
    uncertainty takes with probability zero. They weigh in χ² and in a fit; a test that reads
    the residuals as normal deviates (the largest of them against the Bonferroni bound) must
    leave them out: a mode the modal fit merged with its neighbour or missed is not a 10σ gap,
    and a real one shows in the FRF segments around it too.
    """
    e = np.abs(np.asarray(e, float))
    k = np.rint((e / UNPAIRED) ** 2)
    return (k >= 1) & (e == UNPAIRED * np.sqrt(k))


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


def hammer_leak(H: np.ndarray, coords, scatter: float, averages: int) -> np.ndarray:
    """Relative error of each line and entry from the hammer's direction scatter.

    Parameters
    ----------
    H : ndarray, shape (n_freq, n_out, n_in)
        Measured FRFs; inputs named by ``coords`` ("1X", "1aY", ...).
    scatter : float
        Standard deviation of the hit direction in the XY plane, rad.
    averages : int
        Hits averaged per FRF.

    Returns
    -------
    ndarray, shape (n_freq, n_out, n_in): ``σ_δ / √n · |H(i, j')| / |H(i, j)|`` with ``j'`` the
    hit in the other direction at the same point (0 where the data have no such hit).
    """
    coords = [str(c) for c in coords]
    out = np.zeros(H.shape)
    mag = np.maximum(np.abs(H), 1e-300)
    for j, c in enumerate(coords):
        other = c[:-1] + {"X": "Y", "Y": "X"}.get(c[-1], c[-1])
        if other != c and other in coords:
            out[:, :, j] = mag[:, :, coords.index(other)] / mag[:, :, j]
    return scatter / np.sqrt(max(averages, 1)) * out


def frf_target(freq, H, noise_rel, leak_rel=None) -> FrfTarget:
    """Reduce one band's measured FRF: ``noise_rel`` (n_freq, 4, 4) is each line's relative noise,
    independent from line to line; ``leak_rel`` (same shape, optional) an error common to all
    lines of a hit (:func:`hammer_leak`), which a segment's mean does not reduce."""
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
        if leak_rel is not None:
            noise = np.hypot(noise, np.sqrt(np.mean(leak_rel[lines] ** 2, axis=0)))
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
