"""A tool change on a campaign: predict the target tool at a measured posture, score it on the bench.

Computation only: :func:`predict_campaign_tool` takes an impact campaign of the reference tool
(DATA.md) and returns, per band, the target tool's predicted tip receptances; where the campaign
came from the bench it also simulates the robot carrying the target tool at the same joint
commands (the ground truth) and scores every peak.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import xarray as xr

from rmbench.errors import InputError, ModelError
from rmbench.rcsa.contact import Contact
from rmbench.rcsa.coupling import change_tool
from rmbench.rcsa.identify import ContactFit, identify_contact
from rmbench.rcsa.receptance import FULL_COORDS, POINT_COORDS, campaign_receptance
from rmbench.rcsa.substructure import TOOL_MODELS
from rmbench.rcsa.validate import peak_errors
from rmbench.robot.tool import TOOLS, ToolGeometry

__all__ = ["CampaignToolChange", "predict_campaign_tool", "tool_geometry", "posture_index", "sensor_masses",
           "reading_matrix", "without_cross_axis", "hit_matrix", "without_hit_offset", "TIP_ENTRIES"]

#: The four tip entries scored: (row, column) in ``FULL_COORDS`` and their labels.
TIP_ENTRIES = (((0, 0), "1X/1X"), ((0, 2), "1X/1Y"), ((2, 0), "1Y/1X"), ((2, 2), "1Y/1Y"))


@dataclass(frozen=True)
class CampaignToolChange:
    """Target-tool predictions at one posture of a campaign.

    Attributes
    ----------
    index : int
        Posture index in the reference campaign.
    posture_mm_deg : tuple of float
    method : str
        ``"difference"`` (the seed's finite differences and Eq. 4) or ``"beam"``.
    bands : dict of str to ToolChange
    truth : dict of str to ndarray
        Per band, the simulated target tool's full tip receptance (bench data only), (n_freq, 4, 4).
    peaks : list of PeakError
        Every true peak of the four tip entries in every band (bench data only).
    contact_fit : ContactFit or None
    contact_source : str
    tool_model : str
        Substructure model of the overhangs, ``"beam"`` or ``"lumped"``.
    """

    index: int
    posture_mm_deg: tuple[float, float, float]
    method: str
    bands: dict
    truth: dict = field(default_factory=dict)
    peaks: list = field(default_factory=list)
    contact_fit: ContactFit | None = None
    contact_source: str = "catalogue"
    tool_model: str = "beam"

    def to_dict(self) -> dict:
        out = {"posture_index": self.index, "posture_mm_deg": list(self.posture_mm_deg),
               "method": self.method, "tool_model": self.tool_model, "contact_source": self.contact_source,
               "reference_tool": next(iter(self.bands.values())).reference.name,
               "target_tool": next(iter(self.bands.values())).target.name,
               "target_contact": next(iter(self.bands.values())).target_contact.to_dict(),
               "ill_conditioned_hz": {b: [float(f) for f in tc.freq[tc.ill_conditioned]]
                                      for b, tc in self.bands.items()}}
        if self.contact_fit is not None:
            f = self.contact_fit
            out["contact_fit"] = {"rms": f.rms, "rms_start": f.rms_start, "lines": f.n_lines,
                                  "at_bound": list(f.at_bound), "rel_std": f.rel_std}
        if self.peaks:
            out["peaks"] = [{"entry": p.entry, "f_true_hz": p.f_true, "f_pred_hz": p.f_pred,
                             "amp_err": p.amp_err, "freq_err": p.freq_err} for p in self.peaks]
            out["peak_amp_err_max"], out["peak_freq_err_max"] = self.largest_peak_errors()
        return out

    def largest_peak_errors(self) -> tuple[float, float]:
        """The largest relative amplitude and frequency errors over the scored peaks, NaNs ignored
        (NaN without peaks)."""
        if not self.peaks:
            return float("nan"), float("nan")
        return (float(np.nanmax([abs(p.amp_err) for p in self.peaks])),
                float(np.nanmax([abs(p.freq_err) for p in self.peaks])))

    def to_dataset(self, reference: str = "") -> xr.Dataset:
        """The predicted target-tool receptances as one dataset: ``T_<band>`` per band on its own
        frequency axis ``freq_<band>`` (Hz); attributes name the reference campaign (``reference``),
        posture index, method and tool model."""
        return xr.Dataset({f"T_{b}": tc.to_dataarray().rename(freq=f"freq_{b}") for b, tc in self.bands.items()},
                          attrs={"kind": "rcsa_tool_change", "reference": str(reference),
                                 "posture_index": self.index, "method": self.method,
                                 "tool_model": self.tool_model})


def tool_geometry(name: str) -> ToolGeometry:
    """A bundled tool by name."""
    if name not in TOOLS:
        raise InputError(f"unknown tool {name!r}; bundled tools: {', '.join(sorted(TOOLS))}")
    return TOOLS[name]


def _design(data: xr.Dataset):
    """A campaign's test design (the ``config`` attribute) as a CampaignConfig; None without one."""
    text = data.attrs.get("config")
    if not text:
        return None
    from rmbench.impact.config import CampaignConfig, parse_config

    text = str(text).strip()
    if text.startswith("{"):        # the validated JSON a campaign stores, or the TOML it was run from
        try:
            return CampaignConfig.model_validate_json(text)
        except ValueError as exc:
            raise InputError(f"the campaign's test design (attribute 'config') does not parse: "
                             f"{str(exc).splitlines()[0]}") from None
    return parse_config(text, source="the campaign's test design (attribute 'config')")


def _sensors(data: xr.Dataset, band: str):
    """The band's SensorSet from a campaign's test design, calibrated; None for a campaign without
    one or without that band."""
    from rmbench.impact.sensors import sensor_set

    cfg = _design(data)
    if cfg is None or band not in cfg.bands:
        return None
    return sensor_set(cfg.bands[band], cfg, None)


def sensor_masses(data: xr.Dataset, band: str) -> list[tuple[float, float]]:
    """(s_up m, mass kg) of each sensor on the tool in a campaign's band, from its test design
    (the ``config`` attribute); empty for lasers or a campaign without one."""
    sens = _sensors(data, band)
    return [] if sens is None else sens.tool_masses()


def reading_matrix(data: xr.Dataset, band: str) -> np.ndarray:
    """What the band's four sensors read of the translations 1X, 1Y, 1aX, 1aY, shape (4, 4), from
    the campaign's test design: each sensor's axis (misalignment included) plus its transverse
    sensitivity times the in-plane perpendicular (``reading = D @ translations``). The identity
    for lasers or a campaign without a design."""
    sens = _sensors(data, band)
    D = np.eye(4)
    if sens is None:
        return D
    d = sens.directions()[:, :2]
    for i in range(4):
        j = 0 if i < 2 else 2           # 1X, 1Y read point 1; 1aX, 1aY read point 1a
        D[i] = 0.0
        D[i, j:j + 2] = d[i]
    return D


def without_cross_axis(data: xr.Dataset) -> xr.Dataset:
    """The campaign with each band's readings taken back to the translations they stand for
    (``H ← D⁻¹ H`` on the output side, :func:`reading_matrix`): the accelerometers' 2 % transverse
    sensitivity mixes the X and Y motion of a point, which at the tool-on-holder mode moved the
    fitted rotational contact stiffness by ~30 % (bench/rcsa.py). A copy; ``H_exact`` is left as
    tested."""
    return _per_band(data, lambda vals, band: np.einsum("ij,...jk->...ik",
                                                         np.linalg.inv(reading_matrix(data, band)), vals), "out")


def hit_matrix(data: xr.Dataset, band: str) -> np.ndarray:
    """Where the band's hits land on average, as forces at 1X, 1Y, 1aX, 1aY, shape (4, 4).

    Column j is the nominal force of hit j spread over the two points of its direction so that
    force and moment about the tip match the mean hit point (:func:`mean_hit_point`; exact for
    the rigid tip segment): ``measured = H @ W``. Hits at the tip cannot land beyond the tool's
    end, so their mean point lies σ/√(2π) up the tool (0.08 mm for the default 0.2 mm scatter,
    0.4 % of S = 20 mm). The identity for a campaign without a design or a location scatter."""
    from rmbench.impact.hammer import mean_hit_point
    from rmbench.impact.sensors import nominal_point

    cfg = _design(data)
    W = np.eye(4)
    if cfg is None or band not in cfg.bands:
        return W
    b = cfg.bands[band]
    s_1a, sigma = 1e-3 * b.s_1a_mm, 1e-3 * b.hammer.location_scatter_mm
    for j, c in enumerate(POINT_COORDS):
        s_nom, _ = nominal_point(c, s_1a)
        a = mean_hit_point(s_nom, sigma) / s_1a     # share carried by point 1a
        tip, up = j % 2, 2 + j % 2                  # same direction at 1 and at 1a
        W[:, j] = 0.0
        W[tip, j], W[up, j] = 1 - a, a
    return W


def without_hit_offset(data: xr.Dataset) -> xr.Dataset:
    """The campaign with each band's hits taken back to their nominal points (``H ← H W⁻¹`` on
    the input side, :func:`hit_matrix`). The tip hits' mean 0.08 mm above the tip adds 0.4 % of
    the 1a column to the tip's: at the tool-on-holder mode that moved the fitted rotational
    contact stiffness by +6 % on average (bench/rcsa.py). A copy; ``H_exact`` is left as tested."""
    return _per_band(data, lambda vals, band: vals @ np.linalg.inv(hit_matrix(data, band)), "inp")


def _per_band(data: xr.Dataset, apply, dim: str) -> xr.Dataset:
    """``H`` with ``apply(values (..., out, inp), band)`` done on each band's lines; ``dim`` (the
    side it acts on) must hold ``POINT_COORDS`` in order."""
    H = data["H"].transpose(..., "out", "inp")
    if list(H[dim].values) != list(POINT_COORDS):
        raise InputError(f"the campaign's {'outputs' if dim == 'out' else 'inputs'} are not 1X, 1Y, 1aX, 1aY")
    vals = H.values.copy()
    bands = data["band"].values
    freq_axis = H.dims.index("freq")
    for band in dict.fromkeys(str(b) for b in bands):
        sel = [slice(None)] * vals.ndim
        sel[freq_axis] = bands == band
        vals[tuple(sel)] = apply(vals[tuple(sel)], band)
    return data.assign(H=H.copy(data=vals).transpose(*data["H"].dims))


def posture_index(data: xr.Dataset, posture) -> int:
    """Index of a measured posture (within 0.1 mm and 0.01°), or an error naming the nearest."""
    d = np.hypot(data["x"].values - posture.x, data["y"].values - posture.y)
    dt = np.abs(data["theta"].values - posture.theta)
    hit = np.flatnonzero((d < 1e-4) & (dt < np.radians(0.01)))
    if not len(hit):
        k = int(np.argmin(d + dt))
        raise InputError(f"posture ({1e3 * posture.x:g}, {1e3 * posture.y:g}, {np.degrees(posture.theta):g}) "
                         f"was not measured; nearest is index {k} ({1e3 * data['x'].values[k]:g}, "
                         f"{1e3 * data['y'].values[k]:g}, {np.degrees(data['theta'].values[k]):g})")
    return int(hit[0])


def _point_matrix(data: xr.Dataset, index: int, band: str) -> tuple[np.ndarray, np.ndarray]:
    lines = np.flatnonzero(data["band"].values == band)
    h = data["H"].isel(posture=index, freq=lines).transpose("freq", "out", "inp")
    return data["freq"].values[lines], h.sel(out=list(POINT_COORDS), inp=list(POINT_COORDS)).values


def _truth(data: xr.Dataset, index: int, target: ToolGeometry, freqs: dict) -> dict:
    """The simulated robot carrying the target tool at the campaign's joint commands."""
    from rmbench.robot import Robot

    try:
        robot = Robot.load(str(data.attrs["robot"]), tool=target.name)
    except (ModelError, KeyError):
        return {}
    op = robot.at(np.asarray(data["q_cmd"].values[index], float))
    return {band: op.frf(f, FULL_COORDS) for band, f in freqs.items()}


def _calibrated_contact(data, calibration, calibration_reference, reference, target, *, method, shank,
                        tool_model, free, mass_loading):
    """The target contact fitted on a calibration campaign (:func:`predict_campaign_tool`), and a
    line saying where: (ContactFit, str)."""
    from rmbench.robot import Posture

    cal, j = calibration
    ref_name = reference.name
    if str(cal.attrs.get("tool", "")) != target.name:
        raise InputError(f"the calibration campaign carries tool {cal.attrs.get('tool')!r}, "
                         f"not the target {target.name!r}")
    p = Posture(float(cal["x"].values[j]), float(cal["y"].values[j]), float(cal["theta"].values[j]))
    if calibration_reference is None:
        i_ref = posture_index(data, p)
        fit = _fit_contact(data, i_ref, cal, j, reference, target, method, shank, tool_model, free,
                           mass_loading)
        return fit, f"identified at posture {i_ref}"
    if str(calibration_reference.attrs.get("tool", "")) != ref_name:
        raise InputError(f"the reference calibration campaign carries tool "
                         f"{calibration_reference.attrs.get('tool')!r}, not the reference {ref_name!r}")
    i_ref = posture_index(calibration_reference, p)
    fit = _fit_contact(calibration_reference, i_ref, cal, j, reference, target, method, shank,
                       tool_model, free, mass_loading)
    f_cal = calibration_reference["freq"].values[calibration_reference["band"].values == "high"]
    return fit, (f"identified at ({p.x * 1e3:g}, {p.y * 1e3:g}, {np.degrees(p.theta):g}) from the "
                 f"calibration campaigns, {f_cal.min():g}-{f_cal.max():g} Hz")


def predict_campaign_tool(data: xr.Dataset, index: int, target: ToolGeometry, *,
                          contact: Contact | None = None, calibration: tuple[xr.Dataset, int] | None = None,
                          calibration_reference: xr.Dataset | None = None,
                          method: str = "difference", shank: bool = True,
                          bands: tuple[str, ...] | None = None, tool_model: str = "beam",
                          free: tuple[str, ...] = ("k_t", "c_t"), mass_loading: bool = True,
                          cross_axis: bool = True, hit_offset: bool = True) -> CampaignToolChange:
    """Predict the target tool's tip receptances at posture ``index`` of a reference campaign.

    Parameters
    ----------
    data : xarray.Dataset
        Impact campaign of the reference tool (``tool`` attribute names a bundled tool).
    index : int
    target : ToolGeometry
    contact : Contact, optional
        The target tool's contact. Default: identified from ``calibration`` if given, else the
        target tool's catalogue value.
    calibration : (Dataset, int), optional
        A campaign of the target tool and a posture index in it that the reference campaign also
        measured: the target contact is fitted there (high band).
    calibration_reference : Dataset, optional
        A campaign of the reference tool at the calibration posture, measured like
        ``calibration`` (same high-band lines): the contact is then fitted on these two instead
        of the reference campaign's own high band. Why: the contact acts on the tool-on-holder
        mode (2.7 kHz for the end mill on the IRB6660 stand-in), above the seed's 600-1400 Hz band,
        where its damping c_t barely shows — fitted there it is off by a factor of two from
        measured FRFs (bench/rcsa.py); a hard-tip calibration to 3.5 kHz
        (``rmbench campaign run --config tool_calibration``) holds it within a few per cent.
    method : str
        ``"difference"``: rotations by finite differences, Eq. 4 (the seed's way). ``"beam"``:
        the translations at 1 and 1a couple through the reference tool's beam model.
    shank : bool
        Account for the shank change.
    bands : tuple of str, optional
        Bands to predict (default all in the dataset).
    tool_model : str
        Substructure model of the overhangs: ``"beam"`` (Timoshenko elements, as a lab would) or
        ``"lumped"`` (the simulator's own tool chain: the bench's check of the coupling and the
        identification free of model-form error).
    free : tuple of str
        Contact parameters fitted on the calibration (:func:`identify_contact`).
    mass_loading : bool
        The measured tools carry the campaigns' accelerometers (masses and positions from each
        campaign's test design): the reference substructure and, in the contact fit, both tools
        carry them, and the target is predicted bare.
    cross_axis : bool
        Take the accelerometers' transverse sensitivity (from each campaign's test design) off the
        measured readings first (:func:`without_cross_axis`).
    hit_offset : bool
        Take the hits back to their nominal points first (:func:`without_hit_offset`): the tip
        hits' mean lies above the tip by the hammer's location scatter over √(2π).
    """
    reference = _reference_tool(data, method, tool_model)
    bands = bands or tuple(dict.fromkeys(str(b) for b in data["band"].values))
    data, calibration, calibration_reference = _corrected(data, calibration, calibration_reference,
                                                          cross_axis=cross_axis, hit_offset=hit_offset)
    source, fit = "catalogue", None
    if contact is not None:
        source = "given"
    elif calibration is not None:
        fit, source = _calibrated_contact(data, calibration, calibration_reference, reference, target,
                                          method=method, shank=shank, tool_model=tool_model, free=free,
                                          mass_loading=mass_loading)
        contact = fit.contact
    out, freqs = _predict_bands(data, index, bands, reference, target, contact, method=method, shank=shank,
                                tool_model=tool_model, mass_loading=mass_loading)
    truth, peaks = _truth_peaks(data, index, target, out, freqs)
    posture = (1e3 * float(data["x"].values[index]), 1e3 * float(data["y"].values[index]),
               float(np.degrees(data["theta"].values[index])))
    return CampaignToolChange(index, posture, method, out, truth, peaks, fit, source, tool_model)


def _reference_tool(data: xr.Dataset, method: str, tool_model: str) -> ToolGeometry:
    """Check the method and tool model; the reference campaign's bundled tool."""
    if method not in ("difference", "beam"):
        raise InputError(f"method must be 'difference' or 'beam', got {method!r}")
    if tool_model not in TOOL_MODELS:
        raise InputError(f"tool model must be one of {', '.join(TOOL_MODELS)}, got {tool_model!r}")
    ref_name = str(data.attrs.get("tool", ""))
    reference = tool_geometry(ref_name) if ref_name in TOOLS else None
    if reference is None:
        raise InputError(f"the reference campaign's tool {ref_name!r} is not a bundled tool; "
                         f"RCSA needs its geometry ({', '.join(sorted(TOOLS))})")
    return reference


def _corrected(data, calibration, calibration_reference, *, cross_axis: bool, hit_offset: bool):
    """The campaigns with the selected measurement corrections applied, in order: cross-axis
    sensitivity, then the hits' offset."""
    corrections = [fix for on, fix in ((cross_axis, without_cross_axis), (hit_offset, without_hit_offset)) if on]
    for fix in corrections:
        data = fix(data)
        if calibration is not None:
            calibration = (fix(calibration[0]), calibration[1])
        if calibration_reference is not None:
            calibration_reference = fix(calibration_reference)
    return data, calibration, calibration_reference


def _predict_bands(data, index: int, bands, reference, target, contact, *, method, shank, tool_model,
                   mass_loading) -> tuple[dict, dict]:
    """The target tool's predicted receptances per band (:func:`change_tool` results) and the
    bands' lines (Hz)."""
    out, freqs = {}, {}
    for band in bands:
        if method == "difference":
            t_ref = campaign_receptance(data, index, band)
            f, t_in, s = t_ref["freq"].values, t_ref.values, None
        else:
            campaign_receptance(data, index, band)  # same checks of the posture and the matrix
            f, t_in = _point_matrix(data, index, band)
            s = float(data.attrs[f"sensor_spacing_{band}"])
        masses = sensor_masses(data, band) if mass_loading else ()
        out[band] = change_tool(t_in, f, reference, target, target_contact=contact, s_1a=s, shank=shank,
                                tool_model=tool_model, reference_masses=masses)
        freqs[band] = f
    return out, freqs


def _truth_peaks(data, index: int, target, out: dict, freqs: dict) -> tuple[dict, list]:
    """Where the campaign holds ground truth: the target tool's exact tip receptances per band and
    the predicted peaks' errors against them (tip entries); else nothing."""
    truth, peaks = {}, []
    if "H_exact" in data:
        truth = _truth(data, index, target, freqs)
        for band, t in truth.items():
            rows = [e[0] for e in TIP_ENTRIES]
            peaks += peak_errors(freqs[band], np.stack([out[band].t[:, i, j] for i, j in rows], 1),
                                 np.stack([t[:, i, j] for i, j in rows], 1), [e[1] for e in TIP_ENTRIES])
    return truth, peaks


def _fit_contact(data, i_ref, cal, j, reference, target, method, shank, tool_model, free,
                 mass_loading) -> ContactFit:
    band = "high"
    if not np.any(cal["band"].values == band) or not np.any(data["band"].values == band):
        raise InputError("the contact is fitted on a high band, which a calibration campaign lacks")
    if method == "difference":
        t_ref = campaign_receptance(data, i_ref, band)
        f, t_in, s = t_ref["freq"].values, t_ref.values, None
    else:
        f, t_in = _point_matrix(data, i_ref, band)
        s = float(data.attrs["sensor_spacing_high"])
    f2, h2 = _point_matrix(cal, j, band)
    if len(f2) != len(f) or not np.allclose(f2, f):
        raise InputError("the calibration campaign's high-band lines differ from the reference's "
                         f"({f2.min():g}-{f2.max():g} Hz against {f.min():g}-{f.max():g} Hz)")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return identify_contact(t_in, h2[:, :2, :2], f, reference, target, s_1a=s, shank=shank,
                                tool_model=tool_model, free=free,
                                sensor_masses=sensor_masses(data, band) if mass_loading else ())
