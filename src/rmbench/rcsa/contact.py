"""The tool-holder contact: translational and rotational stiffness and damping (METHODS.md §4)."""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.robot.tool import ToolGeometry

__all__ = ["Contact"]


@dataclass(frozen=True)
class Contact:
    """Complex contact stiffness per lateral direction, K = diag(k_t + iω c_t, k_r + iω c_r).

    Attributes
    ----------
    k_t : float
        Translational stiffness, N/m.
    k_r : float
        Rotational stiffness, N·m/rad.
    c_t : float
        Translational damping, N·s/m.
    c_r : float
        Rotational damping, N·m·s/rad.
    """

    k_t: float
    k_r: float
    c_t: float = 0.0
    c_r: float = 0.0

    def __post_init__(self):
        for name in ("k_t", "k_r"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise InputError(f"contact {name} must be positive, got {getattr(self, name)}")
        for name in ("c_t", "c_r"):
            if not (np.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise InputError(f"contact {name} must be zero or positive, got {getattr(self, name)}")

    @classmethod
    def of(cls, tool: ToolGeometry) -> "Contact":
        """The contact built into a bundled tool (what the simulator holds it with)."""
        return cls(tool.k_t, tool.k_r, tool.c_t, tool.c_r)

    @classmethod
    def parse(cls, text: str) -> "Contact":
        """``"k_t,k_r[,c_t,c_r]"`` in SI units (N/m, N·m/rad, N·s/m, N·m·s/rad)."""
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            raise InputError(f"contact must be numbers 'k_t,k_r[,c_t,c_r]', got {text!r}") from None
        if len(values) not in (2, 4):
            raise InputError(f"contact must be 'k_t,k_r[,c_t,c_r]' (2 or 4 numbers), got {text!r}")
        return cls(*values)

    def compliance(self, freq: np.ndarray) -> np.ndarray:
        """K⁻¹ per line in (x, θx, y, θy) order, shape (n_freq, 4, 4): m/N and rad/(N·m)."""
        omega = 2 * np.pi * np.atleast_1d(np.asarray(freq, float))
        out = np.zeros((len(omega), 4, 4), complex)
        out[:, 0, 0] = out[:, 2, 2] = 1 / (self.k_t + 1j * omega * self.c_t)
        out[:, 1, 1] = out[:, 3, 3] = 1 / (self.k_r + 1j * omega * self.c_r)
        return out

    def to_dict(self) -> dict:
        """The four coefficients by name, SI: ``{"k_t": N/m, "k_r": N·m/rad, "c_t": N·s/m,
        "c_r": N·m·s/rad}``."""
        return asdict(self)
