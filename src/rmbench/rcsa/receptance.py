"""The full receptance matrix of a tool point from translations only (METHODS.md §3, Appendix A).

A 4x4 receptance matrix measured at the tool tip 1 and at point 1a, a distance S up the tool, in X
and Y (coordinates ``1X, 1Y, 1aX, 1aY``) gives by first-order finite differences the full matrix of
Eq. 3 at the tip, coordinates ``1X, 1rX, 1Y, 1rY``: H (displacement/force, m/N), L
(displacement/moment, m/(N·m)), N (rotation/force, rad/N) and P (rotation/moment, rad/(N·m)).

Convention (the one of the tool beam model, :meth:`rmbench.robot.tool.ToolGeometry.overhang_matrices`,
and of the simulator's exact rotations ``1rX``, ``1rY``): the rotation in direction D is the slope
of the D-displacement along the tool axis, ``θ_D ≈ (u_D,1 − u_D,1a)/S``, and its moment the couple
of +F at 1 and −F at 1a, ``M_D = F·S``. With ``D`` mapping point displacements to
``(x, θx, y, θy)`` the full matrix is ``T = D H Dᵀ``, which is Eq. 3 entry by entry with no sign flips
and keeps non-reciprocal data (L is taken from the columns, N from the rows).

The difference is exact for a rigid tip segment and carries a truncation error where the tool
bends between 1 and 1a; it divides the measurement noise by S (by S² in P): the S trade-off.
"""

from __future__ import annotations

import numpy as np
import xarray as xr

from rmbench.errors import InputError

__all__ = ["FULL_COORDS", "POINT_COORDS", "difference_matrix", "full_receptance", "point_receptance",
           "campaign_receptance"]

#: Coordinates of the full matrix (Eq. 3 order): tip displacement and rotation in X, then in Y.
FULL_COORDS = ("1X", "1rX", "1Y", "1rY")
#: Coordinates of the measured matrix (DATA.md).
POINT_COORDS = ("1X", "1Y", "1aX", "1aY")


def difference_matrix(s: float) -> np.ndarray:
    """Map from point displacements (1X, 1Y, 1aX, 1aY) to (x, θx, y, θy), shape (4, 4).

    Parameters
    ----------
    s : float
        Distance S of point 1a up the tool from the tip, m.
    """
    if not (np.isfinite(s) and s > 0):
        raise InputError(f"sensor spacing S must be positive, got {s} m")
    return np.array([[1.0, 0, 0, 0],
                     [1 / s, 0, -1 / s, 0],
                     [0, 1.0, 0, 0],
                     [0, 1 / s, 0, -1 / s]])


def full_receptance(h: np.ndarray, s: float) -> np.ndarray:
    """Full receptance matrix of the tool tip from the measured 4x4 matrix.

    Parameters
    ----------
    h : ndarray, shape (..., 4, 4), complex
        Receptance, m/N, rows responses and columns forces in ``POINT_COORDS`` order.
    s : float
        Spacing S of point 1a, m.

    Returns
    -------
    ndarray, shape (..., 4, 4), complex
        Receptance in ``FULL_COORDS`` order: m/N, m/(N·m), rad/N, rad/(N·m).
    """
    h = np.asarray(h)
    if h.shape[-2:] != (4, 4):
        raise InputError(f"the measured matrix must be 4x4 (1X, 1Y, 1aX, 1aY), got shape {h.shape[-2:]}")
    d = difference_matrix(s)
    return d @ h @ d.T


def point_receptance(t: np.ndarray, s: float) -> np.ndarray:
    """The inverse of :func:`full_receptance`: translations at 1 and 1a, ``POINT_COORDS``, (..., 4, 4).

    Exact for a rigid tip segment between 1 and 1a (u_1a = u_1 − S θ); how a predicted target tool
    is handed to a 4x4 modal fit.
    """
    d = np.linalg.inv(difference_matrix(s))
    return d @ np.asarray(t) @ d.T


def campaign_receptance(data: xr.Dataset, index: int, band: str, *, variable: str = "H") -> xr.DataArray:
    """The full tip receptance of one posture and band of a campaign dataset.

    Parameters
    ----------
    data : xarray.Dataset
        An impact campaign (DATA.md): ``H`` (posture, freq, out, inp) and ``sensor_spacing_<band>``.
    index : int
        Posture index.
    band : str
        ``"low"`` or ``"high"``.
    variable : str
        ``"H"`` (measured), ``"H_exact"`` or ``"H_exact_bare"``.

    Returns
    -------
    xarray.DataArray, dims (freq, out, inp), coordinates ``FULL_COORDS``
    """
    if variable not in data:
        raise InputError(f"the dataset has no {variable!r}")
    if not 0 <= index < data.sizes["posture"]:
        raise InputError(f"posture index {index} outside 0..{data.sizes['posture'] - 1}")
    if "ok" in data and not bool(data["ok"].values[index]):
        raise InputError(f"posture {index} failed in the campaign: {data['reason'].values[index]}")
    lines = data["band"].values == band
    if not lines.any():
        raise InputError(f"the dataset has no {band!r} band")
    key = f"sensor_spacing_{band}"
    if key not in data.attrs:
        raise InputError(f"the dataset does not record the sensor spacing S of the {band} band ({key})")
    h = data[variable].isel(posture=index, freq=np.flatnonzero(lines)).transpose("freq", "out", "inp")
    h = h.sel(out=list(POINT_COORDS), inp=list(POINT_COORDS)).values
    if not np.all(np.isfinite(h)):
        raise InputError(f"posture {index}, {band} band: the 4x4 matrix is incomplete (all four points "
                         "must be hit in X and Y for the rotations)")
    t = full_receptance(h, float(data.attrs[key]))
    return xr.DataArray(t, dims=("freq", "out", "inp"),
                        coords={"freq": data["freq"].values[lines], "out": list(FULL_COORDS),
                                "inp": list(FULL_COORDS)},
                        attrs={"units": "m/N, m/(N m), rad/N, rad/(N m)", "band": band})
