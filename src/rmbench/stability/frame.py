"""The cut's frame: the tool tip's dynamics turned from the robot's base axes to feed and normal.

The milling model (:mod:`rmbench.stability.cutting`) works in the cut's frame: x along the feed, y
normal to it in the tool's plane, y the feed turned by +90° about the tool axis (as base Y is base
X turned). The tool tip's receptance and its modes' residues come in the robot's base axes (1X,
1Y). A feed heading ψ (rad, in the base XY plane, from base X toward base Y) turns them into the
cut's frame by the rotation whose rows are the feed and normal unit vectors in base coordinates,

    R(ψ) = [[cos ψ, sin ψ], [−sin ψ, cos ψ]],   G_cut = R G_base Rᵀ,

a displacement's cut components being R times its base components and a cutting force's base
components Rᵀ times its cut components. ψ = 0 is the feed along base X, the frame every lobe and
path computation used before headings (entry for entry the same numbers: R(0) is the identity).

Climb or conventional milling is not part of the frame: which side of the feed the material lies
on stays :attr:`Cutting.down <rmbench.stability.cutting.Cutting.down>`, passed to the stability
solver as it is; a path that changes it from location to location passes one value per location
(:meth:`rmbench.path.TipModes.depths`).
"""

from __future__ import annotations

import numpy as np

from rmbench.errors import InputError

__all__ = ["feed_rotation", "to_cut_frame"]


def feed_rotation(heading) -> np.ndarray:
    """The rotation from base (X, Y) to the cut's (feed, normal) axes.

    Parameters
    ----------
    heading : float or ndarray, shape (...), rad
        Feed direction in the base XY plane, from base X toward base Y.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        Rows: the feed and the normal unit vectors in base coordinates.
    """
    psi = np.asarray(heading, float)
    if not np.all(np.isfinite(psi)):
        raise InputError("a feed heading must be finite (rad)")
    c, s = np.cos(psi), np.sin(psi)
    return np.stack([np.stack([c, s], axis=-1), np.stack([-s, c], axis=-1)], axis=-2)


def to_cut_frame(tip, heading) -> np.ndarray:
    """A tool tip's 2x2 receptances or modal residues turned into the cut's (feed, normal) frame.

    Parameters
    ----------
    tip : ndarray, shape (..., 2, 2), complex
        In base (X, Y): a receptance in m/N (per frequency line) or modal residues
        ``R = φR φLᵀ`` in m/N·rad/s (per pose and mode, as :func:`rmbench.stability.zoa_limit`
        takes them), the last two axes (response, force).
    heading : float or ndarray, shape (k...), rad
        Feed direction in the base XY plane; its shape is the leading part of ``tip``'s
        (one heading per pose: shape (n_poses,) for residues of shape (n_poses, n_modes, 2, 2)),
        a float turns every matrix alike.

    Returns
    -------
    ndarray, shape (..., 2, 2)
        ``R(ψ) tip R(ψ)ᵀ``, same units (:func:`feed_rotation`).
    """
    tip = np.asarray(tip)
    psi = np.asarray(heading, float)
    if tip.ndim < 2 or tip.shape[-2:] != (2, 2):
        raise InputError(f"the tool tip's matrices must be 2x2 in (x, y), got shape {tip.shape}")
    lead = tip.shape[:-2]
    if psi.shape != lead[:psi.ndim]:
        raise InputError(f"one feed heading per leading index of the tip's matrices: headings of shape "
                         f"{psi.shape} for matrices of shape {tip.shape}")
    rot = feed_rotation(psi).reshape(psi.shape + (1,) * (len(lead) - psi.ndim) + (2, 2))
    return rot @ tip @ np.swapaxes(rot, -1, -2)
