"""Weights of the mixed-sensitivity H∞ design (METHODS.md §8, seed 004 Paper II Fig. 4).

Per axis, with ``ω0 = 2π f0`` the robot mode the axis targets:

- acceleration ``W_a(s) = k_a · 2ζ_w ω0 s / (s² + 2ζ_w ω0 s + ω0²)``: a band-pass around the mode,
  shaped like the roll-off of G_d on both sides, so the minimisation spends its effort at the mode
  (``ζ_w`` sets how wide: wider is more robust to the mode moving with posture);
- reaction-mass position ``W_p(s) = k_p (s + ω_pz) / (s + ω_pl)``: high at low frequency, to keep
  the mass centred (pole just off the imaginary axis, ``ω_pl``, as hinfsyn needs);
- control force ``W_u(s) = k_u (s + ω_uz) / (s + ω_ul)``: high at low frequency (stroke), ``k_u``
  above (D12 full column rank);
- sensor noise: constant weights ``n_a`` (m/s²) and ``n_p`` (m) on the measurement channels (D21
  full row rank). ``noise_pos`` is set far above the encoder's real noise (0.2 mm): the encoder
  only keeps the mass centred, and trusting it more gives unstable central controllers (an open-
  loop unstable controller saturating its voice coil is what a real test must avoid).

The defaults were chosen on the MH180 stand-in's reference posture (tangential mode 5.9 Hz) for
≥ 80 % reduction, ≤ 3 dB amplification above twice the mode, ≤ 10 mm stroke at a 20 N
disturbance and a stable controller (``bench/control_loop.py`` measures them in closed loop).

Units: gains make each weighted output dimensionless per newton of disturbance.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields, replace

import control as ct
import numpy as np

from rmbench.errors import InputError

__all__ = ["Weights"]


@dataclass(frozen=True)
class Weights:
    """Mixed-sensitivity weights of one axis (the same shape on every axis, centred on its mode).

    Attributes
    ----------
    k_a : float
        Acceleration weight at the mode, 1/(m/s²) per N of disturbance: the closed-loop peak
        acceleration sensitivity is pushed below ``γ / k_a`` (m/s²/N).
    zeta_w : float
        Relative width of the acceleration band-pass.
    k_p, f_pz, f_pl : float
        Position weight: high-frequency gain (1/m) and zero and pole, Hz.
    k_u, f_uz, f_ul : float
        Force weight: high-frequency gain (1/N) and zero and pole, Hz.
    noise_acc, noise_pos : float
        Measurement-noise weights, m/s² and m.
    """

    k_a: float = 40.0
    zeta_w: float = 0.25
    k_p: float = 400.0
    f_pz: float = 6.0
    f_pl: float = 1e-4
    k_u: float = 0.5
    f_uz: float = 1.0
    f_ul: float = 0.05
    noise_acc: float = 2e-3
    noise_pos: float = 2e-4

    def __post_init__(self):
        for f in fields(self):
            v = getattr(self, f.name)
            if not np.isfinite(v) or v <= 0:
                raise InputError(f"weight {f.name} must be a positive number, got {v!r}")
        if self.f_pl >= self.f_pz:
            raise InputError(f"position weight pole f_pl ({self.f_pl:g} Hz) must lie below its zero f_pz "
                             f"({self.f_pz:g} Hz): the weight is high at low frequency")
        if self.f_ul >= self.f_uz:
            raise InputError(f"force weight pole f_ul ({self.f_ul:g} Hz) must lie below its zero f_uz "
                             f"({self.f_uz:g} Hz): the weight is high at low frequency")

    def with_(self, **changes) -> "Weights":
        """A copy with some weights changed (unknown names are an error)."""
        names = {f.name for f in fields(self)}
        bad = sorted(set(changes) - names)
        if bad:
            raise InputError(f"unknown weight {bad[0]!r}; known: {', '.join(sorted(names))}")
        return replace(self, **changes)

    def as_dict(self) -> dict:
        """The weights by field name (units as in the attributes: frequencies in Hz)."""
        return asdict(self)

    # transfer functions ----------------------------------------------------------------------
    def acceleration(self, f0: float) -> ct.TransferFunction:
        """The acceleration weight ``W_a(s)``, a band-pass of gain ``k_a`` (1/(m/s²)) at the mode
        ``f0`` (Hz) and relative width ``zeta_w``; ``s`` in rad/s."""
        w0 = 2 * np.pi * f0
        return ct.tf([self.k_a * 2 * self.zeta_w * w0, 0], [1, 2 * self.zeta_w * w0, w0**2])

    def position(self) -> ct.TransferFunction:
        """The reaction-mass position weight ``W_p(s) = k_p (s + ω_pz) / (s + ω_pl)``, 1/m
        (``k_p`` at high frequency, ``k_p f_pz / f_pl`` at DC); ``s`` in rad/s."""
        return self.k_p * ct.tf([1, 2 * np.pi * self.f_pz], [1, 2 * np.pi * self.f_pl])

    def force(self) -> ct.TransferFunction:
        """The control-force weight ``W_u(s) = k_u (s + ω_uz) / (s + ω_ul)``, 1/N (``k_u`` at high
        frequency, ``k_u f_uz / f_ul`` at DC); ``s`` in rad/s."""
        return self.k_u * ct.tf([1, 2 * np.pi * self.f_uz], [1, 2 * np.pi * self.f_ul])
