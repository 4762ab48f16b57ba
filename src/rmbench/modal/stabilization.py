"""Stabilisation diagram and automatic pole selection.

A pole of order ``p`` is *stable* when a pole of order ``p - 1`` lies within the frequency, damping
and participation-vector (MAC) tolerances. Stable, physical poles of all orders are clustered
(average-linkage hierarchical clustering on the distance ``|λ_i − λ_j| / min|λ| + (1 − MAC_ij)``);
a cluster holding stable poles from enough orders is a mode, represented by the median of its poles.
"""

from dataclasses import dataclass

import numpy as np
from scipy.cluster.hierarchy import fcluster, linkage

from rmbench.modal.plscf import PolyMaxOrder
from rmbench.modeshape import mac
from rmbench.plotting import axes_or_new

__all__ = ["Stabilization", "StabilityCriteria", "stabilize"]


@dataclass(frozen=True)
class StabilityCriteria:
    """Tolerances of the stabilisation diagram.

    Attributes
    ----------
    freq_tol : float
        Largest relative change of the natural frequency between consecutive orders.
    damping_tol : float
        Largest relative change of the damping ratio between consecutive orders.
    mac_min : float
        Smallest MAC of the participation vectors between consecutive orders.
    zeta_max : float
        Poles with ``ζ <= 0`` or ``ζ >= zeta_max`` are not physical.
    cluster_distance : float
        Cut-off of the average-linkage clustering (relative pole distance plus ``1 − MAC``).
    min_fraction : float
        A cluster is a mode when it holds stable poles of at least this fraction of the orders
        (and of at least 3 orders).
    """

    freq_tol: float = 0.01
    damping_tol: float = 0.05
    mac_min: float = 0.98
    zeta_max: float = 0.3
    cluster_distance: float = 0.01
    min_fraction: float = 0.2

    def __post_init__(self):
        for name in ("freq_tol", "damping_tol", "zeta_max", "cluster_distance"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)!r}")
        if not 0 < self.mac_min <= 1 or not 0 < self.min_fraction <= 1:
            raise ValueError("mac_min and min_fraction must lie in (0, 1]")


@dataclass(frozen=True)
class Stabilization:
    """What a stabilisation diagram shows, one entry per physical pole of every order.

    Attributes
    ----------
    order : ndarray, shape (n_poles,), int
        Model order of each pole.
    pole : ndarray, shape (n_poles,), complex, rad/s
        The pole (``Im > 0``, ``0 < ζ < zeta_max``, natural frequency inside the band).
    stable : ndarray, shape (n_poles,), bool
        Stable in frequency, damping and participation against the previous order.
    cluster : ndarray, shape (n_poles,), int
        Index into ``selected`` of the mode the pole was counted for, ``-1`` if none.
    selected : ndarray, shape (n_modes,), complex, rad/s
        The selected poles (cluster medians), sorted by frequency.
    participation : ndarray, shape (n_modes, n_in), complex
        Participation vector of each selected pole (of the cluster member nearest the median).
    n_orders : ndarray, shape (n_modes,), int
        Number of model orders with a stable pole in each selected cluster.
    weak : ndarray, shape (n_weak,), complex, rad/s
        Medians of the clusters stable at 3 or more orders but too few to be selected, strongest
        first: candidates the fit may still need.
    """

    order: np.ndarray
    pole: np.ndarray
    stable: np.ndarray
    cluster: np.ndarray
    selected: np.ndarray
    participation: np.ndarray
    n_orders: np.ndarray = None
    weak: np.ndarray = None

    def __post_init__(self):
        n = len(self.order)
        for name in ("pole", "stable", "cluster"):
            if len(getattr(self, name)) != n:
                raise ValueError(f"{name} must have one entry per pole ({n})")
        if len(self.participation) != len(self.selected):
            raise ValueError("participation must have one row per selected pole")
        if self.n_orders is None:
            object.__setattr__(self, "n_orders", np.zeros(len(self.selected), int))
        if self.weak is None:
            object.__setattr__(self, "weak", np.zeros(0, complex))
        if len(self.n_orders) != len(self.selected):
            raise ValueError("n_orders must have one entry per selected pole")

    @property
    def freq(self) -> np.ndarray:
        """Natural frequency of each pole, Hz, shape (n_poles,)."""
        return np.abs(self.pole) / (2 * np.pi)

    @property
    def zeta(self) -> np.ndarray:
        """Damping ratio of each pole, shape (n_poles,)."""
        return -self.pole.real / np.abs(self.pole)

    def plot(self, ax=None, *, freq=None, H=None):
        """Draw the diagram (orders against frequency), optionally over ``sum |H|``.

        Parameters
        ----------
        ax : matplotlib Axes, optional
        freq : ndarray, shape (n_freq,), Hz, optional
        H : ndarray, shape (n_freq, n_out, n_in), m/N, optional
            Drawn as the sum of the FRF magnitudes on a second, logarithmic axis.

        Returns
        -------
        matplotlib Axes
        """
        ax = axes_or_new(ax)
        f = self.freq
        ax.plot(f[~self.stable], self.order[~self.stable], "o", ms=3, mfc="none", color="0.6",
                label="pole")
        ax.plot(f[self.stable], self.order[self.stable], "+", color="C0", label="stable")
        ax.plot(f[self.cluster >= 0], self.order[self.cluster >= 0], "x", color="C3",
                label="selected cluster")
        for lam in self.selected:
            ax.axvline(abs(lam) / (2 * np.pi), color="C3", lw=0.5)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("model order")
        if freq is not None and H is not None:
            ax2 = ax.twinx()
            ax2.semilogy(freq, np.abs(H).sum(axis=(1, 2)), color="k", lw=0.8)
            ax2.set_ylabel("Σ|H| (m/N)")
        ax.legend(loc="upper left", fontsize="small")
        return ax


def stabilize(results: list[PolyMaxOrder], f_band: tuple[float, float], *,
              criteria: StabilityCriteria = StabilityCriteria(), n_modes: int | None = None
              ) -> Stabilization:
    """Build the stabilisation diagram of ``results`` and select the modes.

    Parameters
    ----------
    results : list of PolyMaxOrder
        pLSCF poles at increasing, consecutive orders.
    f_band : (float, float), Hz
        Band; poles outside it are not physical.
    criteria : StabilityCriteria
    n_modes : int, optional
        Take the ``n_modes`` largest clusters instead of all clusters large enough.

    Returns
    -------
    Stabilization
        ``selected`` is empty when no stable pole was found.
    """
    orders, poles, parts, stable = [], [], [], []
    prev = None
    for res in results:
        lam, L = res.poles, res.participation
        f, z = np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)
        ok = (z > 0) & (z < criteria.zeta_max) & (f >= f_band[0]) & (f <= f_band[1])
        lam, L, f, z = lam[ok], L[ok], f[ok], z[ok]
        st = np.zeros(len(lam), bool)
        if prev is not None and len(prev[0]) and len(lam):
            pf, pz, pL = prev
            df = np.abs(f[:, None] - pf[None, :]) / f[:, None]
            near = np.argmin(df, axis=1)
            rows = np.arange(len(lam))
            st = ((df[rows, near] < criteria.freq_tol)
                  & (np.abs(z - pz[near]) / z < criteria.damping_tol)
                  & (np.diagonal(mac(L, pL[near])) > criteria.mac_min))
        orders.append(np.full(len(lam), res.order))
        poles.append(lam)
        parts.append(L)
        stable.append(st)
        prev = (f, z, L)
    order = np.concatenate(orders) if orders else np.zeros(0, int)
    pole = np.concatenate(poles) if poles else np.zeros(0, complex)
    n_in = results[0].participation.shape[1] if results else 0
    part = np.concatenate(parts) if parts else np.zeros((0, n_in), complex)
    stable = np.concatenate(stable) if stable else np.zeros(0, bool)
    cluster = np.full(len(pole), -1)
    selected, sel_part, n_ord, weak = _select(order, pole, part, stable, cluster, len(results),
                                              criteria, n_modes)
    return Stabilization(order=order, pole=pole, stable=stable, cluster=cluster,
                         selected=selected, participation=sel_part, n_orders=n_ord, weak=weak)


def _select(order, pole, part, stable, cluster, n_orders, criteria, n_modes):
    """Cluster the stable poles and fill ``cluster`` in place; return the selected poles."""
    idx = np.flatnonzero(stable)
    n_in = part.shape[1]
    empty = np.zeros(0, complex), np.zeros((0, n_in), complex), np.zeros(0, int), np.zeros(0, complex)
    if len(idx) == 0:
        return empty
    if len(idx) == 1:
        labels = np.array([1])
    else:
        lam, L = pole[idx], part[idx]
        mag = np.abs(lam)
        d = np.abs(lam[:, None] - lam[None, :]) / np.minimum(mag[:, None], mag[None, :])
        d += 1 - np.abs(L.conj() @ L.T) ** 2  # participation vectors have unit norm
        iu = np.triu_indices(len(idx), 1)
        labels = fcluster(linkage(d[iu], method="average"), criteria.cluster_distance,
                          criterion="distance")
    ids, counts = np.unique(labels, return_counts=True)
    # count distinct orders, not poles: a cluster that swallows two poles per order is one mode
    n_ord = np.array([len(np.unique(order[idx[labels == c]])) for c in ids])
    rank = np.argsort(-n_ord, kind="stable")
    if n_modes is None:
        need = max(3, int(np.ceil(criteria.min_fraction * n_orders)))
        chosen = [ids[i] for i in rank if n_ord[i] >= need]
    else:
        chosen = [ids[i] for i in rank[:n_modes]]
    weak = [_median(pole[idx[labels == ids[i]]]) for i in rank
            if n_ord[i] >= 3 and ids[i] not in chosen]
    reps, rep_part, counts = [], [], []
    for c in chosen:
        members = idx[labels == c]
        med = _median(pole[members])
        reps.append(med)
        rep_part.append(part[members[np.argmin(np.abs(pole[members] - med))]])
        counts.append(n_ord[list(ids).index(c)])
    if not reps:
        return empty[:3] + (np.array(weak, complex),)
    reps, rep_part = np.array(reps), np.array(rep_part)
    by_freq = np.argsort(np.abs(reps))
    for new, k in enumerate(by_freq):
        cluster[idx[labels == chosen[k]]] = new
    return reps[by_freq], rep_part[by_freq], np.array(counts)[by_freq], np.array(weak, complex)


def _median(poles):
    return np.median(poles.real) + 1j * np.median(poles.imag)
