"""Where a tracker's pose error lies: the nominal model's registered error per axis, its share
above the noise, its rms over bins of each joint's angle and of the workspace, and how much of it
each joint's angle, gravity torque and the harmonics of its angle explain
(:class:`PoseErrorMap`, :func:`pose_error_map`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.gap.tracker.data import TrackerData

__all__ = ["PoseErrorMap", "pose_error_map"]


@dataclass(frozen=True)
class PoseErrorMap:
    """Where the nominal model's pose error lies (all configurations, registered).

    Attributes
    ----------
    rms : ndarray, shape (3,), m
        Per axis (tracker frame).
    rms_total, max_total : float, m
        Of the error vector's length.
    noise_rms : float, m
        Of the readings' noise (length of the σ vector).
    above_noise : float
        Share of the mean squared error above the noise, 0-1.
    explains : dict
        ``{"q_j2": R², "tau_j2": R², "sin1_j2": R², ...}``: the share of the error's variance
        that a linear fit on each regressor explains (joint angle, gravity torque, harmonics).
    bins : dict
        ``{joint: (edges rad (n_bins + 1,), rms m (n_bins,))}`` over each joint's angle, and
        ``{"tcp_x" | "tcp_y" | "tcp_z": (edges m, rms m)}`` over the workspace (the nominal TCP
        in the base frame). A bin without a reading has rms NaN (``null`` in :meth:`to_dict`,
        whose ``empty`` lists those bins).
    """

    rms: np.ndarray
    rms_total: float
    max_total: float
    noise_rms: float
    above_noise: float
    explains: dict
    bins: dict

    def top(self, n: int = 5) -> list:
        """The ``n`` regressors that explain most, as (name, R²)."""
        return sorted(self.explains.items(), key=lambda kv: -kv[1])[:n]

    def describe(self) -> str:
        """One line: the rms error overall and per axis and the largest error (mm), the share
        above the noise (%) and the three regressors that explain most (% of the variance)."""
        tops = ", ".join(f"{k} {100 * v:.0f} %" for k, v in self.top(3))
        return (f"rms {1e3 * self.rms_total:.3f} mm (x {1e3 * self.rms[0]:.3f}, y {1e3 * self.rms[1]:.3f}, "
                f"z {1e3 * self.rms[2]:.3f}), max {1e3 * self.max_total:.3f} mm, "
                f"{100 * self.above_noise:.0f} % above the noise; explained best by {tops}")

    def to_dict(self) -> dict:
        """The map as JSON types, SI: ``rms`` (3 floats, m), ``rms_total``, ``max_total``,
        ``noise_rms`` (m), ``above_noise`` (0-1), ``explains`` (R² per regressor) and per bin set
        its ``edges`` (rad or m), ``rms`` (m) and the indices of its ``empty`` bins."""
        return {"rms": self.rms.tolist(), "rms_total": self.rms_total, "max_total": self.max_total,
                "noise_rms": self.noise_rms, "above_noise": self.above_noise,
                "explains": self.explains,
                "bins": {k: {"edges": e.tolist(), "rms": r.tolist(), "empty": np.flatnonzero(~np.isfinite(r)).tolist()}
                         for k, (e, r) in self.bins.items()}}


def pose_error_map(chain, compliance, data: TrackerData, error: np.ndarray, *,
                   n_bins: int = 6, harmonics: int = 2) -> PoseErrorMap:
    """Where the pose error lies (see :class:`PoseErrorMap`); ``error`` (n, 3), m."""
    e = np.asarray(error, float)
    norm = np.linalg.norm(e, axis=1)
    noise2 = np.mean(np.sum(data.sigma ** 2, axis=1))
    msq = float(np.mean(norm ** 2))
    tau = chain.gravity_torque(data.q)
    regressors = {}
    for j, name in enumerate(chain.names):
        q = data.q[:, j]
        regressors[f"q_{name}"] = q
        if compliance[j] > 0:
            regressors[f"tau_{name}"] = tau[:, j]
        for h in range(1, harmonics + 1):
            regressors[f"sin{h}_{name}"] = np.sin(h * q)
            regressors[f"cos{h}_{name}"] = np.cos(h * q)
    centred = e - e.mean(axis=0)
    ss = float(np.sum(centred ** 2))
    explains = {}
    for key, r in regressors.items():
        x = r - r.mean()
        xx = float(x @ x)
        if xx <= 0 or ss <= 0:
            explains[key] = 0.0
            continue
        beta = x @ centred / xx                        # (3,)
        explains[key] = float(np.sum(np.outer(x, beta) ** 2) / ss)
    def binned(x):
        edges = np.linspace(x.min(), x.max(), n_bins + 1)
        which = np.clip(np.digitize(x, edges[1:-1]), 0, n_bins - 1)
        rms = np.array([np.sqrt(np.mean(norm[which == b] ** 2)) if np.any(which == b) else np.nan
                        for b in range(n_bins)])
        return edges, rms

    bins = {name: binned(data.q[:, j]) for j, name in enumerate(chain.names)}
    # the workspace: the nominal TCP's place in the base frame, per axis
    tcp = chain.position(data.q)
    bins.update({f"tcp_{a}": binned(tcp[:, k]) for k, a in enumerate("xyz")})
    return PoseErrorMap(rms=np.sqrt(np.mean(e ** 2, axis=0)), rms_total=float(np.sqrt(msq)),
                        max_total=float(norm.max()) if len(norm) else 0.0,
                        noise_rms=float(np.sqrt(noise2)),
                        above_noise=float(max(0.0, 1 - noise2 / msq)) if msq > 0 else 0.0,
                        explains=explains, bins=bins)
