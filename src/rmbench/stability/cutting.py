"""The milling process: cutting-force coefficients, tool engagement and the directional matrix.

Two-degree-of-freedom milling with a straight-fluted cutter (METHODS.md §10; Insperger & Stépán
2002, Ding et al. 2010): x along the feed, y normal to it in the tool's plane. Tooth j sits at the
angle φ_j(t) = Ω t + 2π j/N (Ω in rad/s); it cuts while φ_j lies within the immersion
[φ_st, φ_ex] (down-milling: φ_st = arccos(2 a/D − 1), φ_ex = π; up-milling: φ_st = 0,
φ_ex = arccos(1 − 2 a/D)). The regenerative force on the tool is

    F(t) = −a_p H(t) [q(t) − q(t − T)],   T = 60 / (N n),

with a_p the axial depth, q = (x, y) the tool-tip displacement and, summed over cutting teeth,

    H = Σ_j [[sin φ (K_t cos φ + K_n sin φ),  cos φ (K_t cos φ + K_n sin φ)],
             [sin φ (−K_t sin φ + K_n cos φ), cos φ (−K_t sin φ + K_n cos φ)]]_j

(N/m² — K_t tangential, K_n radial force per chip area).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError

__all__ = ["Cutting", "BENCHMARK", "ALUMINIUM_6061", "STEEL_C45", "TI6AL4V"]


@dataclass(frozen=True)
class Cutting:
    """Cutting conditions of the stability model, SI units.

    Attributes
    ----------
    k_t, k_n : float
        Tangential and radial cutting-force coefficients, N/m².
    teeth : int
    immersion : float
        Radial immersion a/D in (0, 1] (1: slot).
    down : bool
        Down-milling (climb) if True, up-milling if False.
    """

    k_t: float
    k_n: float
    teeth: int
    immersion: float
    down: bool = True

    def __post_init__(self):
        if not (isinstance(self.teeth, (int, np.integer)) and self.teeth >= 1):
            raise InputError(f"the cutter needs at least one tooth, got {self.teeth}")
        if not 0 < self.immersion <= 1:
            raise InputError(f"radial immersion a/D must lie in (0, 1], got {self.immersion}")
        if not (np.isfinite(self.k_t) and self.k_t > 0 and np.isfinite(self.k_n) and self.k_n >= 0):
            raise InputError(f"cutting coefficients need K_t > 0 and K_n ≥ 0 (N/m²), got {self.k_t}, {self.k_n}")

    @property
    def angles(self) -> tuple[float, float]:
        """Entry and exit angles φ_st, φ_ex of a tooth, rad."""
        if self.down:
            return math.acos(2 * self.immersion - 1), math.pi
        return 0.0, math.acos(1 - 2 * self.immersion)

    def directional(self, phase: np.ndarray) -> np.ndarray:
        """H at cutter rotation angles ``phase`` (tooth 0's angle, rad), N/m², shape (n, 2, 2)."""
        phase = np.atleast_1d(np.asarray(phase, float))
        st, ex = self.angles
        out = np.zeros(phase.shape + (2, 2))
        for j in range(self.teeth):
            phi = np.mod(phase + 2 * np.pi * j / self.teeth, 2 * np.pi)
            g = (phi >= st) & (phi <= ex)
            s, c = np.sin(phi), np.cos(phi)
            ft = self.k_t * c + self.k_n * s
            fn = -self.k_t * s + self.k_n * c
            out[..., 0, 0] += g * s * ft
            out[..., 0, 1] += g * c * ft
            out[..., 1, 0] += g * s * fn
            out[..., 1, 1] += g * c * fn
        return out

    def average_directional(self) -> np.ndarray:
        """Time average of H over a revolution (Altintas-Budak's zero-order term), N/m², shape (2, 2)."""
        st, ex = self.angles
        kr = self.k_n

        def prim(p):  # antiderivatives of the four entries (per tooth), evaluated at p
            s2, c2 = math.sin(2 * p), math.cos(2 * p)
            xx = self.k_t * (-c2 / 4) + kr * (p / 2 - s2 / 4)
            xy = self.k_t * (p / 2 + s2 / 4) + kr * (-c2 / 4)
            yx = -self.k_t * (p / 2 - s2 / 4) + kr * (-c2 / 4)
            yy = -self.k_t * (-c2 / 4) + kr * (p / 2 + s2 / 4)
            return np.array([[xx, xy], [yx, yy]])

        return self.teeth / (2 * math.pi) * (prim(ex) - prim(st))


#: The published solver benchmark (METHODS.md §10): 2 teeth, a/D 0.05, down-milling.
BENCHMARK = Cutting(k_t=6e8, k_n=2e8, teeth=2, immersion=0.05, down=True)
#: Seed 000's robot milling case: aluminium 6061, K_t 880 N/mm², K_r 52 N/mm², slot (2 teeth).
ALUMINIUM_6061 = Cutting(k_t=880e6, k_n=52e6, teeth=2, immersion=1.0, down=True)
#: Low-speed robotic milling of steel, 300-3,000 rev/min: K_t 2,000 N/mm², K_n 700 N/mm², 6 teeth at
#: half immersion (shoulder milling), climb. The values are issue 82's "steel-like cut" (its quick
#: check of the posture's effect); tangential coefficients near 2 kN/mm² with a radial one about a
#: third of it are the order mechanistic models give for medium-carbon steels such as C45, the
#: seed 001 part's steel (no seed states its cutting coefficients).
STEEL_C45 = Cutting(k_t=2000e6, k_n=700e6, teeth=6, immersion=0.5, down=True)
#: Low-speed robotic milling of titanium Ti-6Al-4V: K_t 1,700 N/mm², K_n 600 N/mm², 4 teeth at half
#: immersion, climb. No seed gives titanium; the values are of the order of the mechanistic
#: coefficients for carbide end mills in Ti-6Al-4V predicted from orthogonal cutting data by Budak,
#: Altintas & Armarego (1996, J. Manuf. Sci. Eng. 118: 216-224), rounded, not a table entry checked
#: here: a stand-in for the process, to be replaced by a measured value where there is one.
TI6AL4V = Cutting(k_t=1700e6, k_n=600e6, teeth=4, immersion=0.5, down=True)
