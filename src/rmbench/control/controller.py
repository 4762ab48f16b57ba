"""A designed controller: state-space matrices, its signals, and a plain file format.

Sign convention: ``u = K y`` (the voice-coil forces are the controller's outputs as they are, no
minus sign), with ``y = [a_1 … a_n, p_1 … p_n]`` the accelerations (m/s²) and reaction-mass
positions (m) and ``u`` in N — the convention of ``hinfsyn``.

File format (``.npz``, read with ``allow_pickle=False``): arrays ``A, B, C, D`` (continuous time)
and ``meta``, a JSON string with ``axes``, ``gamma``, ``weights``, ``plant`` (source, mode_hz,
posture), ``modified`` and ``rmbench_controller_version``.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import control as ct
import numpy as np

from rmbench.control.response import frequency_response
from rmbench.errors import InputError

__all__ = ["Controller", "CONTROLLER_VERSION", "write_npz"]

#: Version of the controller file format, written into a file's ``meta`` as
#: ``rmbench_controller_version``; :meth:`Controller.load` reads only this version.
CONTROLLER_VERSION = 1


def write_npz(path: str | os.PathLike, arrays: dict, meta: dict) -> Path:
    """Write ``arrays`` and ``meta`` (as a JSON string) to an ``.npz`` atomically: a temporary name,
    then a rename, so an interrupted write never leaves half a file under the real name."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.tmp.npz")
    np.savez(tmp, meta=np.array(json.dumps(meta)), **arrays)
    os.replace(tmp, path)
    return path


@dataclass(frozen=True)
class Controller:
    """Continuous-time controller ``u = K(s) y`` of a proof-mass suppressor.

    Attributes
    ----------
    axes : tuple of str
    A, B, C, D : ndarray
        Shapes (n_k, n_k), (n_k, 2n), (n, n_k), (n, 2n).
    meta : dict
        Design record (weights, gamma, plant, ...), JSON-serialisable.
    """

    axes: tuple[str, ...]
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    meta: dict = field(default_factory=dict, compare=False)

    def __post_init__(self):
        n, k = len(self.axes), self.A.shape[0]
        shapes = {"A": (k, k), "B": (k, 2 * n), "C": (n, k), "D": (n, 2 * n)}
        for name, shape in shapes.items():
            arr = getattr(self, name)
            if arr.shape != shape:
                raise InputError(f"controller matrix {name} must have shape {shape} for {n} axes, "
                                 f"got {arr.shape}")
            if not np.all(np.isfinite(arr)):
                raise InputError(f"controller matrix {name} has NaN or infinite entries")

    @property
    def order(self) -> int:
        """The controller's states ``n_k``."""
        return self.A.shape[0]

    def ss(self) -> ct.StateSpace:
        """The controller as a python-control ``StateSpace`` named ``K``: inputs ``acc_<axis>``
        (m/s²) then ``pos_<axis>`` (m), outputs ``u_<axis>`` (N); continuous time, s in rad/s."""
        return ct.ss(self.A, self.B, self.C, self.D,
                     inputs=[f"acc_{a}" for a in self.axes] + [f"pos_{a}" for a in self.axes],
                     outputs=[f"u_{a}" for a in self.axes], name="K")

    def frf(self, freq) -> np.ndarray:
        """Frequency response, shape (n_freq, n, 2n)."""
        return frequency_response(self.A, self.B, self.C, self.D, freq)

    def discretize(self, fs: float) -> tuple[np.ndarray, ...]:
        """Tustin discretisation at ``fs`` Hz: ``(Ad, Bd, Cd, Dd)``."""
        if not np.isfinite(fs) or fs <= 0:
            raise InputError(f"controller sample rate must be positive, got {fs!r} Hz")
        d = ct.sample_system(ct.ss(self.A, self.B, self.C, self.D), 1.0 / fs, method="tustin")
        return tuple(np.asarray(x, float) for x in (d.A, d.B, d.C, d.D))

    def select(self, axes) -> "Controller":
        """The part of a controller that reads and drives some axes (for a SISO pair from MIMO parts)."""
        idx = [self.axes.index(a) for a in axes]
        n = len(self.axes)
        cols = idx + [n + i for i in idx]
        return Controller(tuple(axes), self.A, self.B[:, cols], self.C[idx], self.D[np.ix_(idx, cols)],
                          dict(self.meta))

    @staticmethod
    def block_diagonal(parts) -> "Controller":
        """Independent loops side by side (e.g. two separately designed SISO controllers)."""
        parts = list(parts)
        axes = tuple(a for p in parts for a in p.axes)
        n, k = len(axes), sum(p.order for p in parts)
        A, B = np.zeros((k, k)), np.zeros((k, 2 * n))
        C, D = np.zeros((n, k)), np.zeros((n, 2 * n))
        r = i = 0
        for p in parts:
            ni, ki = len(p.axes), p.order
            A[r:r + ki, r:r + ki] = p.A
            for j in range(ni):
                B[r:r + ki, i + j] = p.B[:, j]
                B[r:r + ki, n + i + j] = p.B[:, ni + j]
                D[i:i + ni, i + j] = p.D[:, j]
                D[i:i + ni, n + i + j] = p.D[:, ni + j]
            C[i:i + ni, r:r + ki] = p.C
            r, i = r + ki, i + ni
        return Controller(axes, A, B, C, D, {"parts": [p.meta for p in parts], "structure": "separate loops"})

    # file format -------------------------------------------------------------------------------
    def save(self, path: str | os.PathLike) -> Path:
        """Write the ``.npz`` file atomically (temporary name, then rename)."""
        meta = dict(self.meta, axes=list(self.axes), rmbench_controller_version=CONTROLLER_VERSION)
        return write_npz(path, {"A": self.A, "B": self.B, "C": self.C, "D": self.D}, meta)

    @classmethod
    def load(cls, path: str | os.PathLike) -> "Controller":
        """Read a controller file (never unpickles)."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as z:
                arrays = {k: np.asarray(z[k], float) for k in "ABCD"}
                meta = json.loads(str(z["meta"]))
        except FileNotFoundError:
            raise InputError(f"no controller file {path}") from None
        except (OSError, ValueError, KeyError) as exc:
            raise InputError(f"{path} is not an rmbench controller file ({exc})") from None
        version = meta.get("rmbench_controller_version")
        if version != CONTROLLER_VERSION:
            raise InputError(f"{path} is controller format version {version}; this rmbench reads "
                             f"version {CONTROLLER_VERSION}")
        axes = meta.get("axes")
        if not isinstance(axes, list) or not all(isinstance(a, str) for a in axes):
            raise InputError(f"{path}: 'axes' missing from the controller's metadata")
        return cls(tuple(axes), **arrays, meta=meta)
