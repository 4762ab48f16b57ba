"""Veering modes learnt as one cluster, through quantities that stay smooth (METHODS.md §2, §5).

Where two or more modes approach in frequency as the posture changes (veering), their individual
parameters turn sharply: the mode vectors rotate into each other within a few millimetres of
tool-tip travel and the damping ratios exchange. On the IRB6660 stand-in the low band's modes 2-5
(14-36 Hz, ζ 6-19 %) do this over the seed's grid, and no learner follows them: trained on the
*exact* parameters, a single-task GP's cross-validated R² is 0.31 and −0.80 for modes 3 and 5
(bench/predict.py).

What stays smooth is what the cluster does as a whole. Its poles are the eigenvalues of the system
restricted to the cluster's invariant subspace, and that subspace's spectral projector is analytic in
the posture as long as the cluster stays apart from the other modes (Kato's perturbation theory). So
the coefficients of the cluster's characteristic polynomial and its residue moments

    Π_r (z − z_r) = z^n + a_1 z^(n−1) + … + a_n,     M_k = Σ_r R_r z_r^k,  k = 0 … n−1,
    z_r = (λ_r − c) / ρ,                             R_r = φR_r φL_rᵀ  (4 × 4),

are smooth, while each λ_r, R_r alone is not. ``c`` and ``ρ`` centre and scale the poles over the
training postures so that the Vandermonde system that takes the moments back to residues is well
conditioned. The residues are gauge free (φR c, φL / c give the same R_r), so no normalisation of
the mode vectors enters what is learnt either. Back from learnt invariants: the poles are the
polynomial's roots (sorted by frequency), the residues solve ``Σ_r z_r^k R_r = M_k``, and each R_r's
best rank-one part gives φR and φL (φL normalised on the mode's reference element).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["ModeCluster", "veering_clusters", "cluster_features", "round_off_features", "cluster_residues",
           "cluster_modes", "poles_of", "pole_features", "cluster_poles", "FEATURES_PER_MODE"]

# per mode: a_j (complex) and M_k (4 × 4 complex)
FEATURES_PER_MODE = 2 + 2 * 16


@dataclass(frozen=True)
class ModeCluster:
    """Modes learnt together.

    Attributes
    ----------
    modes : tuple of int
        Positions of the cluster's modes on the dataset's ``mode`` dimension, in order of frequency
        at every posture.
    center : complex
        Centre of the cluster's poles over the training postures, rad/s.
    radius : float
        Largest distance of a pole from ``center``, rad/s.
    """

    modes: tuple
    center: complex
    radius: float

    @property
    def n_features(self) -> int:
        return FEATURES_PER_MODE * len(self.modes)

    def feature_names(self) -> list[str]:
        n = len(self.modes)
        tag = "cluster" + "-".join(str(m) for m in self.modes)
        names = [f"{tag}:a{j}_{part}" for j in range(1, n + 1) for part in ("re", "im")]
        names += [f"{tag}:M{k}_{o}{i}_{part}" for k in range(n) for o in range(4) for i in range(4)
                  for part in ("re", "im")]
        return names


def poles_of(f_n: np.ndarray, zeta: np.ndarray) -> np.ndarray:
    """λ = −ζω + iω√(1−ζ²), rad/s, same shape."""
    w = 2 * np.pi * np.asarray(f_n, float)
    z = np.asarray(zeta, float)
    return -z * w + 1j * w * np.sqrt(1 - z**2)


def veering_clusters(f_n: np.ndarray, zeta: np.ndarray, bands, *, overlap: float = 1.0) -> list[ModeCluster]:
    """Groups of consecutive modes of one band that come close over the postures.

    Modes ``r`` and ``r + 1`` (in order of frequency) join when at some posture their frequencies
    are closer than ``overlap`` times their half-power bandwidths' sum, ``f_{r+1} − f_r <
    overlap (ζ_r f_r + ζ_{r+1} f_{r+1})``: there their peaks merge and their shapes mix.

    Parameters
    ----------
    f_n, zeta : ndarray, shape (n_postures, n_modes)
        In order of frequency within each band at every posture (NaN where a mode is missing).
    bands : sequence of str, length n_modes

    Returns
    -------
    list of ModeCluster
        Clusters of two or more modes; a posture missing any of a cluster's modes is left out of
        its centre and radius (and of what is learnt for it).
    """
    f_n, zeta = np.asarray(f_n, float), np.asarray(zeta, float)
    bands = np.asarray(bands, str)
    with np.errstate(invalid="ignore"):
        bw = zeta * f_n
        close = np.nanmin(np.where(np.isfinite(f_n[:, 1:] + f_n[:, :-1]),
                                   (f_n[:, 1:] - f_n[:, :-1]) / (bw[:, 1:] + bw[:, :-1]), np.inf), axis=0)
    clusters, run = [], [0]
    for r in range(1, f_n.shape[1] + 1):
        if r < f_n.shape[1] and bands[r] == bands[r - 1] and close[r - 1] < overlap:
            run.append(r)
            continue
        if len(run) > 1:
            lam = poles_of(f_n[:, run], zeta[:, run])
            lam = lam[np.isfinite(lam).all(axis=1)]
            if len(lam):
                c = complex(lam.mean())
                clusters.append(ModeCluster(tuple(run), c, float(np.abs(lam - c).max())))
        run = [r]
    return clusters


def cluster_features(cluster: ModeCluster, poles: np.ndarray, phi_r: np.ndarray,
                     phi_l: np.ndarray) -> np.ndarray:
    """The smooth invariants of a cluster at each posture.

    Parameters
    ----------
    poles : ndarray, shape (n_postures, n), complex, rad/s
    phi_r, phi_l : ndarray, shape (n_postures, n, 4), complex
        1X, 1Y, 1aX, 1aY, any normalisation (only ``φR φLᵀ`` enters).

    Returns
    -------
    ndarray, shape (n_postures, cluster.n_features)
        Real and imaginary parts of a_1 … a_n, then of M_0 … M_{n−1} (row-major 4 × 4); NaN rows
        where a mode is missing.
    """
    n = len(cluster.modes)
    z = (np.asarray(poles) - cluster.center) / cluster.radius
    R = np.einsum("pro,pri->proi", phi_r, phi_l)                      # (P, n, 4, 4)
    out = np.full((len(z), cluster.n_features), np.nan)
    for p in range(len(z)):
        if not (np.all(np.isfinite(z[p])) and np.all(np.isfinite(R[p]))):
            continue
        a = np.poly(z[p])[1:]                                         # monic: drop the leading 1
        M = np.stack([np.einsum("r,roi->oi", z[p] ** k, R[p]) for k in range(n)])
        c = np.concatenate([a, M.ravel()])
        out[p] = np.column_stack([c.real, c.imag]).ravel()
    return out


def pole_features(cluster: ModeCluster, poles: np.ndarray) -> np.ndarray:
    """The cluster's characteristic polynomial alone: the first ``2 n`` columns of
    :func:`cluster_features` (Re, Im of a_1 … a_n), shape (n_postures, 2 n); NaN rows where a
    pole is missing."""
    z = (np.asarray(poles) - cluster.center) / cluster.radius
    out = np.full((len(z), 2 * len(cluster.modes)), np.nan)
    ok = np.isfinite(z).all(axis=1)
    a = np.array([np.poly(q)[1:] for q in z[ok]]).reshape(-1, len(cluster.modes))
    out[ok] = np.stack([a.real, a.imag], axis=-1).reshape(len(a), -1)
    return out


def _monic_roots(c: np.ndarray) -> np.ndarray:
    """Roots of ``z^n + c_1 z^(n−1) + … + c_n`` per row of ``c`` (k, n): the eigenvalues of each
    companion matrix, all at once (what ``np.roots`` does for one), shape (k, n)."""
    k, n = c.shape
    comp = np.zeros((k, n, n), complex)
    comp[:, 0, :] = -c
    comp[:, np.arange(1, n), np.arange(n - 1)] = 1.0
    return np.linalg.eigvals(comp) if k else np.zeros((0, n), complex)


def cluster_poles(cluster: ModeCluster, features: np.ndarray,
                  features_std: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray | None]:
    """The poles from (learnt) polynomial coefficients, and to first order their frequencies' and
    damping ratios' standard deviations.

    Parameters
    ----------
    features : ndarray, shape (n_postures, ≥ 2 n)
        Re, Im of a_1 … a_n first (:func:`pole_features`, or :func:`cluster_features`).
    features_std : ndarray, same shape, optional
        Their standard deviations, taken as independent.

    Returns
    -------
    poles : ndarray, shape (n_postures, n), complex, rad/s
        In order of frequency; NaN where a root leaves the upper half plane.
    std : ndarray, shape (n_postures, n, 2), or None
        Standard deviations of f_n (Hz) and ζ: a root moves by ``δz_r = −Σ_j δa_j z_r^(n−j) /
        p′(z_r)``.
    """
    n = len(cluster.modes)
    features = np.atleast_2d(np.asarray(features, float))
    c = features[:, 0:2 * n:2] + 1j * features[:, 1:2 * n:2]
    poles = np.full((len(c), n), np.nan, complex)
    std = None if features_std is None else np.full((len(c), n, 2), np.nan)
    rows = np.flatnonzero(np.all(np.isfinite(c), axis=1))
    if not len(rows):
        return poles, std
    z = _monic_roots(c[rows])
    lam = cluster.center + cluster.radius * z
    order = np.argsort(lam.imag, axis=1)
    z, lam = np.take_along_axis(z, order, 1), np.take_along_axis(lam, order, 1)
    up = np.all(lam.imag > 0, axis=1)
    rows, z, lam = rows[up], z[up], lam[up]
    poles[rows] = lam
    if std is None:
        return poles, std
    s = np.asarray(features_std, float)[rows, :2 * n]
    powers = z[..., None] ** np.arange(n - 1, -1, -1)                      # z_r^(n−j), j = 1 … n
    a = np.concatenate([np.ones((len(rows), 1)), c[rows]], axis=1)[:, :n]   # a_0 = 1, a_1 … a_(n−1)
    slope = (powers * ((n - np.arange(n)) * a)[:, None, :]).sum(-1)        # p′(z_r)
    dz = -cluster.radius * powers / slope[..., None]                        # (postures, modes, coefficients)
    w = np.abs(lam)
    var = np.zeros((len(rows), n, 2))
    for part, sd in ((1.0, s[:, 0::2]), (1j, s[:, 1::2])):                 # δa_j real, then imaginary
        d_lam = part * dz
        d_w = np.real(np.conj(lam)[..., None] * d_lam) / w[..., None]
        d_zeta = (-d_lam.real - (-lam.real / w)[..., None] * d_w) / w[..., None]
        var[..., 0] += ((d_w / (2 * np.pi)) ** 2 * sd[:, None, :] ** 2).sum(-1)
        var[..., 1] += (d_zeta ** 2 * sd[:, None, :] ** 2).sum(-1)
    std[rows] = np.sqrt(var)
    return poles, std


def round_off_features(cluster: ModeCluster, features: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
    """Which features are round-off, shape (n_features,) bool: largest magnitude over the postures
    below ``rtol`` times the largest of their kind (all a_j; each M_k).

    Why: for classically damped modes the residues are imaginary and Re M_0 is zero up to round-off;
    standardised, that round-off is unit-variance noise, and a multi-task GP that shares one kernel
    among all features fits it (on a two-mode veering, 13 % error in the other features instead of
    0.06 %). Learners should take these as the constant 0.
    """
    F = np.abs(np.asarray(features, float))
    kind = np.array([n.split(":")[1].split("_")[0] for n in cluster.feature_names()])
    top = np.nanmax(F, axis=0)
    scale = np.array([np.nanmax(top[kind == k]) for k in kind])
    return top <= rtol * scale


def cluster_residues(cluster: ModeCluster, features: np.ndarray,
                     poles: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The cluster's poles and full residue matrices from (learnt) invariants.

    ``Σ_r R_r / (s − λ_r)`` equals the rational function of the invariants exactly (partial
    fractions), so these rebuild the cluster's receptance without the error that forcing each R_r to
    rank one (:func:`cluster_modes`) adds.

    Parameters
    ----------
    features : ndarray, shape (n_postures, cluster.n_features)
    poles : ndarray, shape (n_postures, n), complex, rad/s, optional
        Poles known better than the invariants' polynomial gives them (a tight sub-cluster's own
        polynomial, :func:`cluster_poles`), in order of frequency; the residues then solve the
        moments with these. NaN entries fall back to the polynomial's roots.

    Returns
    -------
    poles : ndarray, shape (n_postures, n), complex, rad/s
        In order of frequency.
    residues : ndarray, shape (n_postures, n, 4, 4), complex, m/N·rad/s
        ``R_r`` with rows (out) and columns (inp) 1X, 1Y, 1aX, 1aY. NaN where the features are not
        finite or a root leaves the upper half plane (no oscillating mode).
    """
    n = len(cluster.modes)
    features = np.atleast_2d(np.asarray(features, float))
    if features.shape[1] != cluster.n_features:
        raise InputError(f"{features.shape[1]} features for a cluster of {n} modes "
                         f"({cluster.n_features} expected)")
    P = len(features)
    given = None
    if poles is not None:
        given = np.asarray(poles, complex)
        if given.shape != (P, n):
            raise InputError(f"poles must have shape ({P}, {n}), got {given.shape}")
    poles, residues = np.full((P, n), np.nan, complex), np.full((P, n, 4, 4), np.nan, complex)
    c = features[:, 0::2] + 1j * features[:, 1::2]
    rows = np.flatnonzero(np.all(np.isfinite(c), axis=1))
    z = _monic_roots(c[rows, :n])
    lam = cluster.center + cluster.radius * z
    order = np.argsort(lam.imag, axis=1)
    z, lam = np.take_along_axis(z, order, 1), np.take_along_axis(lam, order, 1)
    up = np.all(lam.imag > 0, axis=1)
    rows, z, lam = rows[up], z[up], lam[up]
    if given is not None:
        known = np.isfinite(given[rows])
        lam = np.where(known, given[rows], lam)
        z = np.where(known, (given[rows] - cluster.center) / cluster.radius, z)
    V = z[:, None, :] ** np.arange(n)[None, :, None]                   # (postures, k, r)
    poles[rows] = lam
    if len(rows):
        residues[rows] = np.linalg.solve(V, c[rows, n:].reshape(len(rows), n, 16)).reshape(len(rows), n, 4, 4)
    return poles, residues


def cluster_modes(cluster: ModeCluster, features: np.ndarray, refs) -> tuple[np.ndarray, ...]:
    """The cluster's modes back from (learnt) invariants, each residue cut to its best rank-one
    part (the modal stage's parameterisation).

    Parameters
    ----------
    features : ndarray, shape (n_postures, cluster.n_features)
    refs : sequence of int, length n
        Element (0-3: 1X, 1Y, 1aX, 1aY) at which each mode's φL is 1, in order of frequency.

    Returns
    -------
    f_n : ndarray, shape (n_postures, n), Hz
    zeta : ndarray, shape (n_postures, n)
    phi_r, phi_l : ndarray, shape (n_postures, n, 4), complex
        In order of frequency; NaN where :func:`cluster_residues` gives NaN.
    """
    lam, R = cluster_residues(cluster, features)
    n = len(cluster.modes)
    w = np.abs(lam)
    f_n, zeta = w / (2 * np.pi), -lam.real / w
    phi_r, phi_l = np.full(R.shape[:3], np.nan, complex), np.full(R.shape[:3], np.nan, complex)
    for p in np.flatnonzero(np.isfinite(lam).all(axis=1)):
        for r in range(n):
            u, s, vh = np.linalg.svd(R[p, r])
            # R ≈ s u vᴴ = φR φLᵀ: φL = conj(v) / conj(v)[e], φR = s u conj(v)[e]  (vh[0] = conj(v))
            v, e = vh[0], int(refs[r])
            phi_l[p, r] = v / v[e]
            phi_r[p, r] = s[0] * u[:, 0] * v[e]
    return f_n, zeta, phi_r, phi_l
