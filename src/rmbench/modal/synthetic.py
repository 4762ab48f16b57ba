"""Known MDOF systems to test a modal fitter on: seed 000's Table B1 and random systems.

A fitter is judged by its rate of correct fits over many noise draws and systems, and by whether it
knows when it has failed (``bench/modal_robustness.py``). This module makes the systems, their noisy
band FRFs, and scores a fit against the modes that made the data.

Vocabulary: ``freq`` in Hz, poles in rad/s, receptance in m/N, φR in s/kg, φL dimensionless.
The half-power bandwidth of a mode is ``2 ζ f_n`` (Hz); two modes are *separated by s bandwidths*
when ``|f_i − f_j| = s (ζ_i f_i + ζ_j f_j)`` (the mean of their bandwidths).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rmbench.modal.mdof import synthesize
from rmbench.modeshape import mac, pair_modes

__all__ = ["MdofSystem", "FitScore", "table_b1", "random_system", "add_noise", "score_fit",
           "separation", "poles_of"]

# Table B1 of seed 000 (identified modal parameters at the representative posture): f_n in Hz,
# ζ in %, φL and φR·1e7 (s/kg) at 1X, 1Y, 1aX, 1aY (METHODS.md §2).
_TABLE_B1 = [
    (10.44, 1.16, [1.55 - 1.12j, 0.54 + 0.70j, 0.20 - 1.80j, 1],
     [19.04 - 8.83j, -2.26 + 5.44j, 17.90 - 8.68j, -2.28 + 5.42j]),
    (13.11, 7.98, [0.13 + 0.04j, 1.00 + 0.03j, 0.16 - 0.001j, 1],
     [28.60 - 37.61j, -80.28 - 286.20j, 19.77 - 52.51j, -83.08 - 289.94j]),
    (15.24, 6.05, [-7.73 + 11.96j, 0.84 - 0.58j, -7.63 + 12.29j, 1],
     [-22.17 + 4.47j, 1.56 + 2.70j, -21.01 + 5.14j, 1.28 + 2.96j]),
    (15.96, 2.08, [-2.89 + 1.52j, 0.66 + 0.05j, -2.73 + 1.39j, 1],
     [12.89 + 69.23j, -0.25 - 14.60j, 12.60 + 65.55j, -0.56 - 13.83j]),
    (21.17, 5.04, [0.08 + 0.02j, 1.01 + 0.02j, 0.13 + 0.03j, 1],
     [-4.27 - 27.81j, -63.86 - 326.41j, -8.77 - 37.14j, -62.74 - 327.64j]),
    (844.46, 9.92, [0.15 + 0.48j, 0.87 + 0.29j, 0.11 + 0.34j, 1],
     [241.37 + 10.54j, 578.91 - 1642.99j, 299.70 - 240.88j, 475.05 - 1405.91j]),
    (863.46, 5.89, [-1.72 + 2.31j, 0.41 + 0.77j, -1.27 + 1.65j, 1],
     [-551.97 + 131.80j, 215.69 + 277.06j, -458.39 + 171.29j, 131.43 + 245.93j]),
    (884.06, 1.42, [-0.06 + 2.61j, 0.45 + 1.37j, -1.02 + 2.40j, 1],
     [-69.69 + 101.74j, 24.62 + 46.83j, -59.94 + 96.89j, 14.62 + 49.69j]),
    (895.58, 2.30, [-0.72 + 0.10j, 1.19 + 0.69j, -0.69 + 0.03j, 1],
     [285.42 + 80.93j, -407.64 - 244.84j, 194.78 + 34.62j, -319.32 - 205.79j]),
]
_B1_BANDS = {"low": (5.0, 30.0, 0.05), "high": (750.0, 1000.0, 0.5)}


@dataclass(frozen=True)
class MdofSystem:
    """A known MDOF system and the band it is tested in.

    Attributes
    ----------
    freq : ndarray, shape (n_freq,), Hz
        Uniform lines of the band.
    f_n : ndarray, shape (n_modes,), Hz
        Natural frequencies of all modes, in band and outside (these act as residuals).
    zeta : ndarray, shape (n_modes,)
    phi_r : ndarray, shape (n_modes, 4), complex, s/kg
    phi_l : ndarray, shape (n_modes, 4), complex
        ``phi_l[:, 3] == 1`` (METHODS.md §2 normalisation).
    name : str
    """

    freq: np.ndarray
    f_n: np.ndarray
    zeta: np.ndarray
    phi_r: np.ndarray
    phi_l: np.ndarray
    name: str = ""

    def __post_init__(self):
        n = len(self.f_n)
        if len(self.zeta) != n or self.phi_r.shape != (n, 4) or self.phi_l.shape != (n, 4):
            raise ValueError("f_n, zeta, phi_r (n, 4) and phi_l (n, 4) must describe the same modes")
        if np.any(np.diff(self.freq) <= 0):
            raise ValueError("freq must be increasing")

    @property
    def poles(self) -> np.ndarray:
        """One pole per conjugate pair, rad/s, shape (n_modes,)."""
        return poles_of(self.f_n, self.zeta)

    @property
    def in_band(self) -> np.ndarray:
        """Which modes lie inside the band, bool, shape (n_modes,)."""
        return (self.f_n >= self.freq[0]) & (self.f_n <= self.freq[-1])

    @property
    def min_separation(self) -> float:
        """Smallest separation of two in-band modes in half-power bandwidths (inf for one mode)."""
        return separation(self.f_n[self.in_band], self.zeta[self.in_band])

    def frf(self) -> np.ndarray:
        """Exact receptance of all modes on ``freq``, shape (n_freq, 4, 4), complex, m/N."""
        return synthesize(self.freq, self.poles, self.phi_r, self.phi_l)


@dataclass(frozen=True)
class FitScore:
    """How a fit compares with the system that made the data.

    Attributes
    ----------
    correct : bool
        Every in-band mode found within the tolerances, and no other mode returned.
    missing : ndarray, shape (n_missing,), Hz
        In-band modes with no fitted mode within the tolerances.
    spurious : ndarray, shape (n_spurious,), Hz
        Fitted modes that match no in-band mode.
    f_err, zeta_err : ndarray, shape (n_in_band,)
        Relative errors of the paired fitted mode (NaN where none).
    mac_r, mac_l : ndarray, shape (n_in_band,)
        MAC of φR and φL against the truth (NaN where none).
    reason : str
        What is wrong, one line ("" when correct).
    """

    correct: bool
    missing: np.ndarray
    spurious: np.ndarray
    f_err: np.ndarray
    zeta_err: np.ndarray
    mac_r: np.ndarray
    mac_l: np.ndarray
    reason: str = field(default="")


def poles_of(f_n, zeta) -> np.ndarray:
    """Poles ``−ζ ω_n + i ω_n √(1 − ζ²)`` (rad/s) of natural frequencies (Hz) and damping ratios."""
    wn = 2 * np.pi * np.asarray(f_n, float)
    zeta = np.asarray(zeta, float)
    return -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)


def separation(f_n, zeta) -> float:
    """Smallest separation of neighbouring modes in half-power bandwidths (mean of the pair's)."""
    order = np.argsort(f_n)
    f, z = np.asarray(f_n, float)[order], np.asarray(zeta, float)[order]
    if len(f) < 2:
        return float("inf")
    return float(np.min(np.diff(f) / (z[1:] * f[1:] + z[:-1] * f[:-1])))


def table_b1(band: str) -> MdofSystem:
    """Seed 000's Table B1 (all 9 modes) on the lines of one of its bands.

    Parameters
    ----------
    band : {"low", "high"}
        ``"low"``: 5-30 Hz at 0.05 Hz (5 modes in band); ``"high"``: 750-1000 Hz at 0.5 Hz (4).
    """
    if band not in _B1_BANDS:
        raise ValueError(f"band must be 'low' or 'high', got {band!r}")
    lo, hi, df = _B1_BANDS[band]
    freq = np.arange(lo, hi + 1e-9, df)
    return MdofSystem(freq=freq, f_n=np.array([r[0] for r in _TABLE_B1]),
                      zeta=np.array([r[1] for r in _TABLE_B1]) / 100,
                      phi_r=np.array([r[3] for r in _TABLE_B1], complex) * 1e-7,
                      phi_l=np.array([r[2] for r in _TABLE_B1], complex), name=f"table_b1_{band}")


def random_system(rng: np.random.Generator, *, n_modes: tuple[int, int] = (3, 12),
                  zeta: tuple[float, float] = (0.005, 0.15),
                  separation: tuple[float, float] = (1.0, 8.0), close_share: float = 0.3,
                  close: tuple[float, float] = (1.0, 1.5), lines_per_bandwidth: float = 3.0,
                  max_lines: int = 1500, out_of_band: int = 2) -> MdofSystem:
    """A random non-reciprocal MDOF system in a band that holds ``n_modes`` of its modes.

    In-band modes: damping ratios log-uniform in ``zeta``; neighbours ``s`` half-power bandwidths
    apart, ``s`` log-uniform in ``separation`` except for a share ``close_share`` of the pairs,
    uniform in ``close`` (close modes). Mode shapes: φR complex with a random imaginary share
    (real modes to fully complex ones); φL a random blend of φR's direction (reciprocal) and an
    independent vector (non-reciprocal), ``φL[1aY] = 1``; each mode scaled so that its peak
    response (Frobenius norm of its residue over ``ζ ω_n``) is log-uniform over a decade. Up to
    ``out_of_band`` modes below and above the band make the residual terms matter. The band
    reaches two half-power bandwidths (and at least 2 %) past the outer modes; the line spacing
    gives the narrowest mode ``lines_per_bandwidth`` lines in its half-power bandwidth.
    A draw needing more than ``max_lines`` lines is drawn again (so systems spanning very wide
    bands with very light damping are under-represented; the bench prints what it drew).

    Returns
    -------
    MdofSystem
    """
    for _ in range(1000):
        n = int(rng.integers(n_modes[0], n_modes[1] + 1))
        z = np.exp(rng.uniform(np.log(zeta[0]), np.log(zeta[1]), n))
        f = np.empty(n)
        f[0] = np.exp(rng.uniform(np.log(10.0), np.log(1000.0)))
        for r in range(1, n):
            if rng.random() < close_share:
                s = rng.uniform(*close)
            else:
                s = np.exp(rng.uniform(np.log(separation[0]), np.log(separation[1])))
            # Δf = s (ζ_a f_a + ζ_b f_b) solved for f_b
            if s * z[r] >= 0.9:
                break
            f[r] = f[r - 1] * (1 + s * z[r - 1]) / (1 - s * z[r])
        else:
            lo = min(f[0] * (1 - 2 * z[0]), f[0] * 0.98)
            hi = max(f[-1] * (1 + 2 * z[-1]), f[-1] * 1.02)
            df = np.min(2 * z * f) / lines_per_bandwidth
            n_lines = int(np.ceil((hi - lo) / df)) + 1
            if n_lines <= max_lines and lo > 0:
                break
    else:  # pragma: no cover - the loop draws a usable system within a few tries
        raise RuntimeError("no random system within max_lines after 1000 draws")
    freq = np.linspace(lo, hi, n_lines)
    n_below = int(rng.integers(0, out_of_band + 1))
    n_above = int(rng.integers(0, out_of_band + 1))
    f_out = np.concatenate([lo * rng.uniform(0.3, 0.8, n_below), hi * rng.uniform(1.25, 3.0, n_above)])
    z_out = np.exp(rng.uniform(np.log(zeta[0]), np.log(zeta[1]), len(f_out)))
    f_all, z_all = np.concatenate([f, f_out]), np.concatenate([z, z_out])
    m = len(f_all)
    imag_share = np.exp(rng.uniform(np.log(0.02), np.log(1.0), (m, 1)))
    phi_r = rng.standard_normal((m, 4)) + 1j * imag_share * rng.standard_normal((m, 4))
    own = rng.standard_normal((m, 4)) + 1j * imag_share * rng.standard_normal((m, 4))
    blend = rng.uniform(0.0, 1.0, (m, 1))
    unit = phi_r / np.linalg.norm(phi_r, axis=1, keepdims=True)
    phi_l = blend * unit + (1 - blend) * own / np.linalg.norm(own, axis=1, keepdims=True)
    # keep 1aY away from zero so that the normalisation φL[1aY] = 1 is well conditioned
    small = np.abs(phi_l[:, 3]) < 0.3 * np.abs(phi_l).max(axis=1)
    phi_l[small, 3] = 0.3 * np.abs(phi_l[small]).max(axis=1) * np.exp(2j * np.pi * rng.random(small.sum()))
    phi_l = phi_l / phi_l[:, 3:4]
    peak = np.exp(rng.uniform(np.log(0.1), 0.0, m))
    wn = 2 * np.pi * f_all
    size = np.linalg.norm(phi_r, axis=1) * np.linalg.norm(phi_l, axis=1) / (z_all * wn)
    phi_r = phi_r * (peak / size)[:, None] * 1e-6
    order = np.argsort(f_all)
    return MdofSystem(freq=freq, f_n=f_all[order], zeta=z_all[order], phi_r=phi_r[order],
                      phi_l=phi_l[order], name="random")


def add_noise(H: np.ndarray, level: float, rng: np.random.Generator) -> np.ndarray:
    """``H`` plus complex Gaussian noise of rms ``level`` times each FRF's peak magnitude.

    Parameters
    ----------
    H : ndarray, shape (n_freq, n_out, n_in), complex
    level : float
        E.g. 0.01 for 1 % of each FRF's peak.
    """
    peak = np.abs(H).max(axis=0)
    noise = rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape)
    return H + level * peak * noise / np.sqrt(2)


def score_fit(f_n, zeta, phi_r, phi_l, system: MdofSystem, *, f_tol: float = 0.005,
              zeta_tol: float = 0.10, mac_min: float = 0.98) -> FitScore:
    """Score fitted modes against the in-band modes of ``system``.

    Fitted and true modes are paired (Hungarian) on ``|Δf| / (f_tol f) + (1 − MAC(φR))``; a pair is
    a match when the frequency is within ``f_tol``, the damping ratio within ``zeta_tol``
    (relative) and the MAC of φR and of φL at least ``mac_min``.

    Parameters
    ----------
    f_n, zeta : array_like, shape (n_fit,)
        Fitted natural frequencies (Hz) and damping ratios.
    phi_r, phi_l : array_like, shape (n_fit, 4), complex
    system : MdofSystem

    Returns
    -------
    FitScore
    """
    inb = system.in_band
    f0, z0 = system.f_n[inb], system.zeta[inb]
    r0, l0 = system.phi_r[inb], system.phi_l[inb]
    f_n, zeta = np.asarray(f_n, float), np.asarray(zeta, float)
    phi_r, phi_l = np.asarray(phi_r, complex), np.asarray(phi_l, complex)
    n0 = len(f0)
    f_err, z_err, mac_r, mac_l = (np.full(n0, np.nan) for _ in range(4))
    matched = np.zeros(n0, bool)
    used = np.zeros(len(f_n), bool)
    if len(f_n) and n0:
        rows, cols = pair_modes(f_n, f0, phi_r, r0, freq_scale=f_tol, freq="relative")
        for a, b in zip(rows, cols):
            f_err[b] = f_n[a] / f0[b] - 1
            z_err[b] = zeta[a] / z0[b] - 1
            mac_r[b] = mac(phi_r[a], r0[b])
            mac_l[b] = mac(phi_l[a], l0[b])
            ok = (abs(f_err[b]) <= f_tol and abs(z_err[b]) <= zeta_tol and mac_r[b] >= mac_min
                  and mac_l[b] >= mac_min)
            matched[b] = ok
            used[a] = ok
    missing, spurious = f0[~matched], f_n[~used]
    parts = []
    for b in np.flatnonzero(~matched):
        if np.isnan(f_err[b]):
            parts.append(f"{f0[b]:.4g} Hz not found")
        else:
            parts.append(f"{f0[b]:.4g} Hz off (f {f_err[b]:+.2%}, zeta {z_err[b]:+.1%}, "
                         f"MAC {mac_r[b]:.3f}/{mac_l[b]:.3f})")
    if len(spurious):
        parts.append(f"extra modes at {', '.join(f'{x:.4g}' for x in spurious)} Hz")
    return FitScore(correct=bool(matched.all() and not len(spurious)), missing=missing,
                    spurious=spurious, f_err=f_err, zeta_err=z_err, mac_r=mac_r, mac_l=mac_l,
                    reason="; ".join(parts))
