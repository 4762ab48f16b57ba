"""Frequency responses of state-space systems, all lines at once."""

from __future__ import annotations

import numpy as np

__all__ = ["frequency_response"]

_MAX_COND = 1e8  # eigenvector conditioning up to which the modal formula keeps ~8 digits


def frequency_response(A, B, C, D, freq) -> np.ndarray:
    """``C (jω I − A)⁻¹ B + D`` at ``freq`` Hz, shape (n_freq, n_out, n_in).

    In the system's modal coordinates when ``A`` is well diagonalisable (one eigendecomposition for
    every line), else by one linear solve per line.
    """
    s = 2j * np.pi * np.asarray(freq, float)
    A, B, C, D = (np.asarray(x, float) for x in (A, B, C, D))
    if A.shape[0] == 0:
        return np.broadcast_to(D.astype(complex), (len(s),) + D.shape).copy()
    lam, V = np.linalg.eig(A)
    if np.linalg.cond(V) < _MAX_COND:
        CV, ViB = C @ V, np.linalg.solve(V, B)
        return np.einsum("on,fn,ni->foi", CV, 1.0 / (s[:, None] - lam[None]), ViB) + D
    eye = np.eye(A.shape[0])
    return np.array([C @ np.linalg.solve(si * eye - A, B) + D for si in s])
