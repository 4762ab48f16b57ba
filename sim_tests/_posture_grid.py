"""The seed's posture grid and a smooth posture dependence, shared by the predictor tests."""

import numpy as np


def grid():
    """The seed's 4 x 4 x 7 posture grid (m, m, rad)."""
    xs, ys = np.array([1.3, 1.5, 1.7, 1.9]), np.array([-0.3, -0.1, 0.1, 0.3])
    th = np.radians(np.arange(-60, 61, 20))
    return np.array([(x, y, t) for x in xs for y in ys for t in th])


def smooth(X):
    """A frequency-like smooth function of the posture (Hz)."""
    return 10 + 2 * np.sin(2 * X[:, 0]) + 3 * X[:, 1] ** 2 + 0.5 * np.cos(X[:, 2])
