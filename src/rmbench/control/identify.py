"""The measured-plant path: a robot mode identified from an FRF measurement (METHODS.md §8).

As in the seed's lab, the plant comes from a measurement: the disturbance voice coil shakes the
robot (band-limited random force), the accelerometer responds, and the H1 estimate (averaged
Hann-windowed segments, :mod:`rmbench.impact.estimate`) gives the accelerance ``a/d``. One mode is
fitted to it near its peak — ``1/H = K − M ω² + i ω B`` is linear in (M, K, B) for the
receptance ``H = −A/ω²`` — and :func:`~rmbench.control.plant.two_mass_plant` adds the reaction mass.
The same :func:`plant_from_frf` takes a real robot's measured accelerance.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from rmbench.control.closed_loop import Hardware, run_loop
from rmbench.control.plant import Plant, ReactionMass, reaction_mass, two_mass_plant
from rmbench.errors import InputError
from rmbench.impact.estimate import SpectralSums, h1

__all__ = ["ModeFit", "fit_mode", "plant_from_frf", "measure_accelerance", "measured_plant"]


@dataclass(frozen=True)
class ModeFit:
    """One mode as a mass-spring-damper seen at the suppressor: M kg, K N/m, B N·s/m."""

    M: float
    K: float
    B: float

    @property
    def f_n(self) -> float:
        return float(np.sqrt(self.K / self.M) / (2 * np.pi))

    @property
    def zeta(self) -> float:
        return float(self.B / (2 * np.sqrt(self.K * self.M)))


def fit_mode(freq, accelerance, f_min: float = 2.0, f_max: float = 40.0, *, band: float = 0.15) -> ModeFit:
    """Fit one mode to the largest accelerance peak in ``[f_min, f_max]`` Hz.

    Parameters
    ----------
    freq : array_like, shape (n,), Hz
    accelerance : array_like, shape (n,), complex, m/s²/N
    band : float
        Fit over ``f_peak (1 ± band)``, weighted by |H|² (the peak dominates, neighbours less).
    """
    freq = np.asarray(freq, float)
    acc = np.asarray(accelerance, complex)
    if freq.shape != acc.shape or freq.ndim != 1:
        raise InputError(f"freq and accelerance must be 1-D arrays of one length, got {freq.shape}, {acc.shape}")
    if not (np.all(np.isfinite(freq)) and np.all(np.isfinite(acc))):
        raise InputError("the FRF has NaN or infinite values")
    sel = (freq >= f_min) & (freq <= f_max) & (freq > 0)
    if np.count_nonzero(sel) < 5:
        raise InputError(f"the FRF has fewer than 5 lines within {f_min:g}-{f_max:g} Hz")
    i = np.flatnonzero(sel)[np.argmax(np.abs(acc[sel]))]
    fp = freq[i]
    near = sel & (np.abs(freq - fp) <= band * fp)
    w = 2 * np.pi * freq[near]
    h = -acc[near] / w**2  # receptance
    y = 1 / h
    wt = np.abs(h)
    # Re: K − M ω²;  Im: B ω
    A = np.block([[np.column_stack([np.ones_like(w), -w**2, np.zeros_like(w)])],
                  [np.column_stack([np.zeros_like(w), np.zeros_like(w), w])]])
    b = np.concatenate([y.real, y.imag])
    W = np.concatenate([wt, wt])
    K, M, B = np.linalg.lstsq(A * W[:, None], b * W, rcond=None)[0]
    if M <= 0 or K <= 0 or B <= 0:
        raise InputError(f"no resonance could be fitted near {fp:.3g} Hz (M={M:.3g}, K={K:.3g}, B={B:.3g})")
    return ModeFit(float(M), float(K), float(B))


def plant_from_frf(freq, accelerance, rm: ReactionMass, *, axis: str = "tangential", f_min: float = 2.0,
                   f_max: float = 40.0) -> Plant:
    """METHODS.md §8 plant from a measured accelerance ``a/d`` and the reaction-mass hardware."""
    mode = fit_mode(freq, accelerance, f_min, f_max)
    p = two_mass_plant(mode.M, mode.K, mode.B, rm, axis=axis, source="measured")
    return Plant(p.axes, p.A, p.B, p.C, p.D, "measured", p.mode_hz, dict(p.info, zeta=mode.zeta))


def measure_accelerance(op, axis: str = "tangential", *, duration: float = 64.0, segment: float = 8.0,
                        force_rms: float = 10.0, f_max: float = 50.0, hardware: Hardware | None = None,
                        seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulated shaker test: random force on the axis's disturbance coil, H1 of ``a/d``.

    Returns
    -------
    freq : ndarray, Hz
    accelerance : ndarray, complex, m/s²/N (``d`` = force on the robot, minus the coil force)
    coherence : ndarray
    """
    hw = hardware if hardware is not None else Hardware()
    n = int(round(duration * hw.fs))
    rng = np.random.default_rng(seed)
    sos = signal.butter(4, f_max, fs=hw.fs, output="sos")
    f_coil = signal.sosfilt(sos, rng.normal(0.0, 1.0, n))
    f_coil *= force_rms / np.std(f_coil)
    rec = run_loop(op, None, duration, hardware=hw, shaker={axis: f_coil}, record_axes=(axis,), seed=seed)
    acc = rec.acc[:, 0] + rng.normal(0.0, hw.acc_noise, n)
    d = -f_coil
    n_seg = int(round(segment * hw.fs))
    win = np.hanning(n_seg)
    freq = np.fft.rfftfreq(n_seg, 1 / hw.fs)
    sums = SpectralSums(len(freq), 1)
    start = n_seg  # the first segment holds the start-up transient
    for s0 in range(start, n - n_seg + 1, n_seg // 2):
        sums.add(np.fft.rfft(win * d[s0:s0 + n_seg]), np.fft.rfft(win * acc[s0:s0 + n_seg])[:, None])
    H, coh = h1(sums)
    keep = (freq > 0) & (freq <= f_max)
    return freq[keep], H[keep, 0], coh[keep, 0]


def measured_plant(op, axis: str = "tangential", **kwargs) -> Plant:
    """The plant of one axis from a simulated FRF measurement of the robot's mode (seed's path)."""
    freq, H, _ = measure_accelerance(op, axis, **kwargs)
    return plant_from_frf(freq, H, reaction_mass(op.robot.model, axis), axis=axis)
