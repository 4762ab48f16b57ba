"""Seed 000's whole chain on the bench: predicted reference dynamics → new tool by RCSA → lobes.

At a posture never hammered, the posture predictor gives the reference tool's modal parameters;
per band they rebuild the 4x4 receptance at 1 and 1a (Eq. 15, that band's modes), finite differences
give the full tip matrix, RCSA puts the target tool on (Eq. 4 with the shank change), the target's
translations at 1 and 1a go through the modal stage's blind MDOF fit, and the fitted modes feed the
stability solver; the bands' lobes are combined into their lowest envelope, as the seed did.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from rmbench.errors import InputError
from rmbench.modal.fit import ModalFit
from rmbench.predict.predictor import predicted_frf
from rmbench.rcsa import change_tool, full_receptance
from rmbench.rcsa.contact import Contact
from rmbench.rcsa.receptance import point_receptance
from rmbench.robot.tool import ToolGeometry
from rmbench.stability.cutting import Cutting
from rmbench.stability.lobes import Lobes, lobes, lowest_envelope
from rmbench.stability.structure import Structure

__all__ = ["ChainResult", "tool_structures", "predicted_tool_structures", "predicted_lobes"]


@dataclass(frozen=True)
class ChainResult:
    """Per band: the target tool's predicted tip FRFs, its fitted modes as a Structure, and lobes.

    Attributes
    ----------
    freq : dict of str to ndarray, shape (n_freq,)
        Per band, its frequency lines, Hz.
    tip : dict of str to ndarray, shape (n_freq, 2, 2), complex
        Per band, the RCSA prediction of the target tool's tip receptances [[H_xx, H_xy],
        [H_yx, H_yy]], m/N.
    structures : dict of str to Structure
        Per band, the modes fitted to the target's predicted receptances.
    lobes : dict of str to Lobes
        Per band, the stability lobes of that band's structure (critical depth in m per speed
        in rev/min).
    envelope : Lobes
        The bands' lowest critical depth at each speed.
    """

    freq: dict
    tip: dict            # band -> (n_freq, 2, 2) m/N, the RCSA prediction
    structures: dict     # band -> Structure
    lobes: dict          # band -> Lobes
    envelope: Lobes


def tool_structures(h_ref: dict, bands: dict, reference: ToolGeometry, target: ToolGeometry, *,
                    n_modes: dict | None = None, target_contact: Contact | None = None) -> tuple[dict, dict]:
    """Target-tool tip structures per band from the reference tool's 4x4 receptances.

    Parameters
    ----------
    h_ref : dict of str to ndarray (n_freq, 4, 4)
        Per band, the reference tool's receptance at 1X, 1Y, 1aX, 1aY (measured, exact or rebuilt).
    bands : dict of str to (freq ndarray (Hz), s_1a float (m))
    n_modes : dict of str to int, optional
        Modes the target's fit should find per band (default: the fit decides).

    Returns
    -------
    tips : dict of band to ndarray (n_freq, 2, 2)
        The RCSA prediction of the target's tip receptances, m/N.
    structures : dict of band to Structure
    """
    tips, structures = {}, {}
    for band, (freq, s) in bands.items():
        t = change_tool(full_receptance(h_ref[band], s), freq, reference, target, target_contact=target_contact)
        if t.ill_conditioned.any():
            raise InputError(f"{band} band: the tool change is ill-conditioned at {int(t.ill_conditioned.sum())} lines")
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")   # the fit's own verdict is kept on the object
            fit = ModalFit(n_modes=(n_modes or {}).get(band)).fit(freq, point_receptance(t.t, s))
        tips[band] = t.tip
        structures[band] = Structure.from_modes(fit.poles_, fit.phi_r_[:, :2], fit.phi_l_[:, :2])
    return tips, structures


def predicted_tool_structures(prediction, bands: dict, reference: ToolGeometry, target: ToolGeometry, *,
                              target_contact: Contact | None = None) -> tuple[dict, dict, dict]:
    """Target-tool tip structures per band from one posture's predicted reference parameters.

    Each band's 4x4 receptance is rebuilt from that band's predicted modes (Eq. 15) and, where
    the predictor learnt them, the band's predicted residual terms: without them the modes above
    the high band are missing, which on the stand-in moves the target's holder modes by ~0.2 % and
    the lobes' flanks above 15 krpm by up to 9 % (bench/lobes.py).

    Parameters
    ----------
    prediction : xarray.Dataset
        :meth:`PosturePredictor.predict` at one posture (``modal``, ``mode_band``, ``phiL_1aY``).
    bands : dict of str to (freq ndarray (Hz), s_1a float (m))
        Each band's lines and sensor spacing.
    """
    h_ref, counts = {}, {}
    for band, (freq, _) in bands.items():
        finite = np.isfinite(prediction["modal"].values[0, :, :2]).all(axis=1)
        sel = np.flatnonzero((prediction["mode_band"].values == band) & finite)
        if not len(sel):
            raise InputError(f"the prediction has no mode in the {band} band")
        h_ref[band] = predicted_frf(prediction, freq, posture=0, band=band)
        counts[band] = len(sel)
    tips, structures = tool_structures(h_ref, bands, reference, target, n_modes=counts,
                                       target_contact=target_contact)
    return {b: f for b, (f, _) in bands.items()}, tips, structures


def predicted_lobes(prediction, bands: dict, reference: ToolGeometry, target: ToolGeometry, cutting: Cutting,
                    speeds_rpm, depths, *, every: int = 5, target_contact: Contact | None = None) -> ChainResult:
    """Lobes of the target tool from a predicted reference posture (both bands, lowest envelope).

    Parameters
    ----------
    prediction : xarray.Dataset
        :meth:`PosturePredictor.predict` at one posture, as for :func:`predicted_tool_structures`.
    bands : dict of str to (freq ndarray (Hz), s_1a float (m))
        Each band's lines and sensor spacing.
    reference, target : ToolGeometry
        The tool the predictor learnt and the tool put on by RCSA.
    cutting : Cutting
    speeds_rpm : ndarray, shape (n_speed,), rev/min
        Spindle speeds of every band's diagram.
    depths : ndarray, shape (n_depth,), m
        Axial depth scan grid, increasing (:func:`rmbench.stability.lobes`).
    every : int
        Scan every ``every``-th grid depth first (:func:`rmbench.stability.lobes`).
    target_contact : Contact, optional
        The target's tool-holder contact (default: the one built into ``target``).

    Returns
    -------
    ChainResult
    """
    freqs, tips, structures = predicted_tool_structures(prediction, bands, reference, target,
                                                        target_contact=target_contact)
    per = {b: lobes(s, cutting, speeds_rpm, depths, every=every) for b, s in structures.items()}
    return ChainResult(freqs, tips, structures, per, lowest_envelope(*per.values()))
