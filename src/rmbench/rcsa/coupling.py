"""Receptance coupling for a tool change (METHODS.md §4, seed 000 Eq. 4), cross terms kept.

Assembly C is the robot (with spindle, holder and the shank in the holder) joined at the holder
face (point 3) to the tool's overhang A (1 = tip, 2 = holder end) by the contact K:

    T^C_11 = T^A_11 − T^A_12 (T^A_22 + K⁻¹ + R_33)⁻¹ T^A_21.

Decoupling the measured reference tool gives the robot's side, ``R_33 + K_1⁻¹ =
T^A_21,1 (T^A_11,1 − T^C_11,1)⁻¹ T^A_12,1 − T^A_22,1``; recoupling the target tool with ``ΔK⁻¹ =
K_2⁻¹ − K_1⁻¹`` is Eq. 4. Beyond the seed, the shank change is kept: the two shanks differ in mass,
and the robot's side is updated by the difference of their rigid mass matrices at the holder face,
``R_33,2 = (R_33,1⁻¹ − ω² ΔM)⁻¹``. That needs the reference contact K_1 itself, not only ΔK; without
the shank correction K_1 cancels and the result is exactly Eq. 4.

Every 4x4 inversion is checked per line: its condition number after symmetric diagonal scaling
(which removes the units' spread between translations and rotations) above ``max_condition``
marks the line ill-conditioned; such lines are returned as NaN and named in an
:class:`IllConditionedWarning`, never returned as numbers.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.rcsa.contact import Contact
from rmbench.rcsa.receptance import FULL_COORDS, POINT_COORDS
from rmbench.rcsa.substructure import PLANE_POINTS, ToolReceptance, shank_mass_matrix, tool_receptance
from rmbench.robot.tool import ToolGeometry

__all__ = ["ToolChange", "IllConditionedWarning", "change_tool", "couple_tool", "holder_receptance", "with_shank_change",
           "scaled_condition", "line_ranges", "MAX_CONDITION"]

#: Default bound on the scaled condition number of an inverted 4x4 receptance sum. Measured
#: receptances carry ~1e-3 relative noise; above 1e6 that noise alone could reach the result.
MAX_CONDITION = 1e6


class IllConditionedWarning(UserWarning):
    """Some frequency lines needed a near-singular inversion; they are returned as NaN."""


@dataclass(frozen=True)
class ToolChange:
    """A predicted tool-tip receptance matrix for the target tool.

    Attributes
    ----------
    freq : ndarray, shape (n_freq,), Hz
    t : ndarray, shape (n_freq, 4, 4), complex
        Target tool's full tip receptance, ``FULL_COORDS`` order; NaN on ill-conditioned lines.
    condition : ndarray, shape (n_freq,)
        Worst scaled condition number among the line's inversions.
    ill_conditioned : ndarray, shape (n_freq,), bool
    reference, target : ToolGeometry
    reference_contact, target_contact : Contact
    shank : bool
        Whether the shank change was accounted for.
    """

    freq: np.ndarray
    t: np.ndarray
    condition: np.ndarray
    ill_conditioned: np.ndarray
    reference: ToolGeometry
    target: ToolGeometry
    reference_contact: Contact
    target_contact: Contact
    shank: bool

    @property
    def tip(self) -> np.ndarray:
        """The tip's displacement/force receptances [[H_xx, H_xy], [H_yx, H_yy]], m/N, shape (n_freq, 2, 2)."""
        return self.t[:, 0::2, 0::2]

    def to_dataarray(self):
        """The target tool's tip receptance matrix ``t`` as an ``xarray.DataArray`` of dims
        (freq, out, inp), shape (n_freq, 4, 4), complex: ``freq`` in Hz, ``out`` and ``inp`` in
        ``FULL_COORDS`` order (tip displacement and rotation in X, then in Y), so its
        entries are m/N, m/(N·m), rad/N or rad/(N·m); attrs name the reference and target tools,
        whether the shank change was corrected and how many lines are ill-conditioned (NaN)."""
        import xarray as xr

        return xr.DataArray(self.t, dims=("freq", "out", "inp"),
                            coords={"freq": self.freq, "out": list(FULL_COORDS), "inp": list(FULL_COORDS)},
                            attrs={"units": "m/N, m/(N m), rad/N, rad/(N m)", "reference_tool": self.reference.name,
                                   "target_tool": self.target.name, "shank_corrected": int(self.shank),
                                   "ill_conditioned_lines": int(self.ill_conditioned.sum())})


def scaled_condition(a: np.ndarray) -> np.ndarray:
    """2-norm condition number of each matrix after symmetric diagonal scaling, shape (...,).

    Scaling by 1/sqrt|a_ii| puts translations and rotations on one footing, so the number reflects
    near-singularity, not units. A zero or non-finite diagonal gives inf.
    """
    d = np.abs(np.diagonal(a, axis1=-2, axis2=-1))
    with np.errstate(divide="ignore", invalid="ignore"):
        s = 1 / np.sqrt(d)
        scaled = a * s[..., :, None] * s[..., None, :]
        ok = np.all(np.isfinite(scaled), axis=(-2, -1))
        out = np.full(a.shape[:-2], np.inf)
        if ok.any():
            out[ok] = np.linalg.cond(scaled[ok])
    return out


def line_ranges(freq: np.ndarray, mask: np.ndarray) -> list[tuple[float, float]]:
    """Contiguous runs of flagged lines as (first, last) frequencies, Hz."""
    out, start = [], None
    for i, flag in enumerate(mask):
        if flag and start is None:
            start = i
        if start is not None and (not flag or i == len(mask) - 1):
            end = i if flag else i - 1
            out.append((float(freq[start]), float(freq[end])))
            start = None
    return out


def _solve(a: np.ndarray, b: np.ndarray, max_condition: float) -> tuple[np.ndarray, np.ndarray]:
    """a⁻¹ b per line, and the lines' scaled condition numbers (NaN rows where a is singular)."""
    cond = scaled_condition(a)
    out = np.full(np.broadcast_shapes(a.shape[:-2], b.shape[:-2]) + a.shape[-1:] + b.shape[-1:], np.nan + 0j)
    good = np.isfinite(cond) & (cond <= max_condition)
    if good.any():
        out[good] = np.linalg.solve(a[good], np.broadcast_to(b, out.shape)[good])
    return out, cond


def holder_receptance(t_ref: np.ndarray, a_ref: ToolReceptance, contact_ref: Contact, *,
                      max_condition: float = MAX_CONDITION) -> tuple[np.ndarray, np.ndarray]:
    """The robot's receptance at the holder face, R_33, decoupled from the reference tool.

    Parameters
    ----------
    t_ref : ndarray, shape (n_freq, 4, 4), complex
        The reference tool's full tip receptance (``FULL_COORDS``), or, when ``a_ref`` carries
        point receptances (built with ``s_1a``), its measured translations at 1 and 1a in
        ``POINT_COORDS`` order: these couple through the beam model with no finite difference.

    Returns
    -------
    r33 : ndarray, shape (n_freq, 4, 4), complex
    condition : ndarray, shape (n_freq,)
    """
    if a_ref.points is None:
        a_mm, a_m2, a_2m = a_ref.t11, a_ref.t12, a_ref.t21
    else:
        a_mm, a_m2, a_2m = a_ref.points
        order = [POINT_COORDS.index(c) for c in PLANE_POINTS]
        t_ref = t_ref[:, order][:, :, order]
    x, cond = _solve(a_mm - t_ref, a_m2, max_condition)
    return a_2m @ x - a_ref.t22 - contact_ref.compliance(a_ref.freq), cond


def couple_tool(r33: np.ndarray, a: ToolReceptance, contact: Contact, *,
                max_condition: float = MAX_CONDITION) -> tuple[np.ndarray, np.ndarray]:
    """Tip receptance of a tool on a robot side R_33 (METHODS.md §4), shape (n_freq, 4, 4), and conditions."""
    x, cond = _solve(a.t22 + contact.compliance(a.freq) + r33, a.t21, max_condition)
    return a.t11 - a.t12 @ x, cond


def with_shank_change(r33: np.ndarray, freq: np.ndarray, reference: ToolGeometry, target: ToolGeometry, *,
                      max_condition: float = MAX_CONDITION) -> tuple[np.ndarray, np.ndarray]:
    """The robot's side with the reference shank swapped for the target's: (R_33⁻¹ − ω² ΔM)⁻¹."""
    dm = shank_mass_matrix(target) - shank_mass_matrix(reference)
    z = (2 * np.pi * np.asarray(freq, float))[:, None, None] ** 2 * dm
    inv_r33, c1 = _solve(r33, np.eye(4), max_condition)
    out, c2 = _solve(inv_r33 - z, np.eye(4), max_condition)
    return out, np.fmax(c1, c2)


def change_tool(t_ref: np.ndarray, freq: np.ndarray, reference: ToolGeometry, target: ToolGeometry, *,
                reference_contact: Contact | None = None, target_contact: Contact | None = None,
                s_1a: float | None = None, shank: bool = True, n_el: int = 20, tool_model: str = "beam",
                reference_masses: tuple[tuple[float, float], ...] = (),
                max_condition: float = MAX_CONDITION) -> ToolChange:
    """Predict the target tool's full tip receptance from the reference tool's (Eq. 4).

    Parameters
    ----------
    t_ref : ndarray, shape (n_freq, 4, 4), complex
        Without ``s_1a``: the reference tool's full tip receptance, ``FULL_COORDS`` order (from
        :func:`full_receptance` of a measurement — the seed's way —, from exact receptances, or
        from predicted parameters at any posture). With ``s_1a``: the measured 4x4 translations
        at 1 and 1a, ``POINT_COORDS`` order, coupled through the reference tool's beam model
        (no finite-difference truncation).
    freq : ndarray, shape (n_freq,), Hz
    reference, target : ToolGeometry
    reference_contact, target_contact : Contact, optional
        Contacts of the two tools; by default the tools' own (catalogue) values.
    s_1a : float, optional
        Spacing of point 1a, m, when ``t_ref`` holds point translations.
    shank : bool
        Account for the shank change at the holder face (needs the reference contact itself).
    n_el : int
        Beam elements per overhang.
    tool_model : str
        Substructure model of both overhangs, ``"beam"`` or ``"lumped"`` (:func:`tool_receptance`).
    reference_masses : sequence of (s_up, mass)
        Sensors on the reference tool when it was measured (m up from the tip, kg): its
        substructure carries them, so that decoupling removes their mass loading; the target is
        predicted bare.
    max_condition : float
        Lines whose inversions exceed this scaled condition number come back NaN, with a warning.
    """
    freq = np.asarray(freq, float)
    t_ref = np.asarray(t_ref)
    if t_ref.shape != (len(freq), 4, 4):
        raise InputError(f"reference receptance must have shape (n_freq, 4, 4) = ({len(freq)}, 4, 4), "
                         f"got {t_ref.shape}")
    k1 = reference_contact or Contact.of(reference)
    k2 = target_contact or Contact.of(target)
    a1 = tool_receptance(reference, freq, n_el=n_el, s_1a=s_1a, model=tool_model, masses=reference_masses)
    a2 = tool_receptance(target, freq, n_el=n_el, model=tool_model)
    r33, cond = holder_receptance(t_ref, a1, k1, max_condition=max_condition)
    if shank:
        r33, c = with_shank_change(r33, freq, reference, target, max_condition=max_condition)
        cond = np.fmax(cond, c)
    t, c = couple_tool(r33, a2, k2, max_condition=max_condition)
    cond = np.fmax(cond, c)
    bad = ~(np.isfinite(cond) & (cond <= max_condition)) | ~np.all(np.isfinite(t), axis=(1, 2))
    t = np.where(bad[:, None, None], np.nan + 0j, t)
    if bad.any():
        spans = ", ".join(f"{a:g}-{b:g} Hz" if a != b else f"{a:g} Hz" for a, b in line_ranges(freq, bad))
        warnings.warn(f"{int(bad.sum())} of {len(freq)} lines need a near-singular inversion (scaled "
                      f"condition > {max_condition:.0e}) and are left out: {spans}",
                      IllConditionedWarning, stacklevel=2)
    return ToolChange(freq, t, cond, bad, reference, target, k1, k2, shank)
