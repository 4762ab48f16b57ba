"""Measured modes at measured postures: what a calibration fits a model to.

Four sources give the same :class:`ModalData`:

- a campaign dataset (netCDF) or a UFF58 directory of FRFs: fitted here, blind (rmbench.modal);
- a modal fit (``rmbench modal fit --out FIT.nc``);
- a modal table (CSV), such as a paper's tables: one row per mode, columns

  ``x_mm, y_mm, theta_deg, band, f_n_hz, zeta_pct`` (required), ``mode``, ``source`` (optional), and
  optionally the mode's shape, ``phiL_C_re, phiL_C_im, phiR_C_re, phiR_C_im`` for the coordinates
  C of ``1X, 1Y, 1aX, 1aY`` (φL dimensionless with φL[1aY] = 1, φR in s/kg). Lines starting with
  ``#`` are comments.

A table gives no standard errors: the residual floors (0.1 % in frequency, 3 % in damping) stand
for them.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from rmbench.calibrate.design import TestDesign
from rmbench.calibrate.measured import MeasuredModes, measured_data, modes_of_fit, postures_of
from rmbench.errors import InputError
from rmbench.robot import Posture

__all__ = ["ModalData", "load_modal_data", "fitted_modal_data", "source_name", "read_modal_table", "TABLE_COLUMNS"]

_COORDS = ("1X", "1Y", "1aX", "1aY")
TABLE_COLUMNS = ("x_mm", "y_mm", "theta_deg", "band", "f_n_hz", "zeta_pct")
_OPTIONAL = ("mode", "source") + tuple(f"phi{s}_{c}_{p}" for s in ("L", "R") for c in _COORDS
                                       for p in ("re", "im"))


@dataclass(frozen=True)
class ModalData:
    """Measured modes per posture and band, with the test design they were measured under.

    Attributes
    ----------
    postures : tuple of Posture
    modes : tuple of dict
        Per posture, ``{band: MeasuredModes}``.
    bands : tuple of str
    design : TestDesign
    source : str
        Where the data came from (a file name), for the calibrated model's header.
    frf : tuple of dict or None
        Per posture, ``{band: FrfTarget}`` (:func:`~rmbench.calibrate.residual.frf_target`): the
        measured FRFs reduced to what the FRF residual compares; None for data without FRFs (a
        modal fit or table).
    """

    postures: tuple
    modes: tuple
    bands: tuple
    design: TestDesign
    source: str = ""
    frf: tuple | None = None

    def __len__(self) -> int:
        return len(self.postures)

    @property
    def n_modes(self) -> int:
        """Measured modes over all postures and the data's bands."""
        return sum(len(per[b]) for per in self.modes for b in self.bands if b in per)

    def subset(self, idx) -> "ModalData":
        """The data at the postures ``idx`` (a sequence of posture indices, in that order; a
        repeated index repeats its posture), with the same bands, design and source."""
        idx = [int(i) for i in idx]
        return ModalData(tuple(self.postures[i] for i in idx), tuple(self.modes[i] for i in idx),
                         self.bands, self.design, self.source,
                         None if self.frf is None else tuple(self.frf[i] for i in idx))


def load_modal_data(data, *, test: str | None = None, workers: int | None = None,
                    bands=None) -> ModalData:
    """Measured modes from a campaign, UFF58 directory, modal fit or modal table.

    Parameters
    ----------
    data : str, Path or xarray.Dataset
    test : str, optional
        Campaign TOML text of the test design, where the data carry none (a modal table: the
        seed's design ``seed_full`` by default).
    workers : int, optional
        Worker processes of the modal fit of FRF data.
    bands : sequence of str, optional
        Bands to use (default: those the data hold).

    Raises
    ------
    InputError
        An unreadable file, a table with unknown columns or units, data without postures.
    """
    if not isinstance(data, xr.Dataset) and str(data).lower().endswith(".csv"):
        postures, modes = read_modal_table(data)
        design = TestDesign.from_text(test) if test is not None else _seed_design()
        found = tuple(b for b in ("low", "high") if any(b in per and len(per[b]) for per in modes))
        return ModalData(tuple(postures), tuple(modes), _pick(found, bands), design, source_name(data))
    ds = _open(data)
    if "modal" in ds:
        if not all(c in ds.coords for c in ("x", "y", "theta")):
            raise InputError("the modal fit has no posture positions (x, y, theta)")
        design = TestDesign.of_dataset(ds, test)
        found = tuple(b for b in ("low", "high") if b in set(ds.mode_band.values))
        use = _pick(found, bands)
        postures = [Posture(float(x), float(y), float(t))
                    for x, y, t in zip(ds.x.values, ds.y.values, ds.theta.values)]
        return ModalData(tuple(postures), tuple(modes_of_fit(ds, use)), use, design, source_name(data))
    ds = measured_data(ds)
    design = TestDesign.of_dataset(ds, test)
    found = tuple(b for b in ("low", "high") if np.any(ds.band.values == b))
    return fitted_modal_data(ds, design, _pick(found, bands), source_name(data), workers=workers)


def fitted_modal_data(ds: xr.Dataset, design: TestDesign, bands, source: str = "", *,
                      workers: int | None = None) -> ModalData:
    """The modes and FRF targets of measured FRFs, fitted blind (:mod:`rmbench.modal`).

    Parameters
    ----------
    ds : xarray.Dataset
        Measured FRFs as :func:`~rmbench.calibrate.measured.measured_data` gives them.
    design : TestDesign
        The test design they were measured under.
    bands : sequence of str
    source : str
        Where the data came from (:attr:`ModalData.source`).
    workers : int, optional
        Worker processes of the modal fit.
    """
    from rmbench.calibrate.measured import fit_measured, frf_targets

    modes, fit = fit_measured(ds, bands, workers=workers)
    frf = frf_targets(ds, fit, bands, design.averages(), design.direction_scatter())
    return ModalData(tuple(postures_of(ds)), tuple(modes), tuple(bands), design, source, tuple(frf))


def source_name(data) -> str:
    """What names data given as ``data`` (:attr:`ModalData.source`): a file's or directory's
    name, ``dataset`` for an in-memory Dataset."""
    return "dataset" if isinstance(data, xr.Dataset) else Path(data).name


def _pick(found, bands) -> tuple:
    if not found:
        raise InputError("the data hold no modes in the low or high band")
    if bands is None:
        return tuple(found)
    missing = [b for b in bands if b not in found]
    if missing:
        raise InputError(f"the data have no {missing[0]} band")
    return tuple(bands)


def _open(data) -> xr.Dataset:
    if isinstance(data, xr.Dataset):
        return data
    p = Path(data)
    if not p.exists():
        raise InputError(f"no such file or directory: {p}")
    if p.is_dir():
        from rmbench.io import read_uff58

        return read_uff58(p)
    try:
        return xr.load_dataset(p)
    except (OSError, ValueError) as err:
        raise InputError(f"cannot read {p} as a campaign, modal fit or netCDF file: {str(err).splitlines()[0]}") \
            from None


def _seed_design() -> TestDesign:
    from rmbench.impact import load_config

    return TestDesign.from_config(load_config("seed_full"))


def read_modal_table(path) -> tuple[list[Posture], list[dict]]:
    """Postures and per-posture ``{band: MeasuredModes}`` of a modal table CSV (module docstring).

    Raises
    ------
    InputError
        A missing required column, an unknown column (naming it and the accepted ones: units are
        part of a column's name), a value that is not a number, a band other than low or high, a
        non-positive frequency or a damping outside (0, 100) %.
    """
    p = Path(path)
    if not p.is_file():
        raise InputError(f"no such modal table: {p}")
    lines = [ln for ln in p.read_text().splitlines() if ln.strip() and not ln.lstrip().startswith("#")]
    if not lines:
        raise InputError(f"{p.name}: the modal table is empty")
    reader = csv.DictReader(lines)
    cols = [c.strip() for c in (reader.fieldnames or [])]
    missing = [c for c in TABLE_COLUMNS if c not in cols]
    if missing:
        raise InputError(f"{p.name}: the modal table lacks column {missing[0]!r} (needs "
                         f"{', '.join(TABLE_COLUMNS)}; units are part of the names)")
    unknown = [c for c in cols if c not in TABLE_COLUMNS + _OPTIONAL]
    if unknown:
        raise InputError(f"{p.name}: unknown column {unknown[0]!r} in the modal table (columns: "
                         f"{', '.join(TABLE_COLUMNS)}, optional mode, source and phiL_1X_re ... phiR_1aY_im)")
    rows = []
    for n, r in enumerate(reader, start=2):
        r = {k.strip(): (v or "").strip() for k, v in r.items() if k is not None}
        try:
            vals = {c: float(r[c]) for c in ("x_mm", "y_mm", "theta_deg", "f_n_hz", "zeta_pct")}
        except ValueError:
            raise InputError(f"{p.name}, data row {n - 1}: a posture, frequency or damping is not a number") from None
        if r["band"] not in ("low", "high"):
            raise InputError(f"{p.name}, data row {n - 1}: band must be low or high, got {r['band']!r}")
        if not vals["f_n_hz"] > 0 or not 0 < vals["zeta_pct"] < 100:
            raise InputError(f"{p.name}, data row {n - 1}: f_n_hz must be positive and zeta_pct in (0, 100)")
        rows.append((r, vals))
    keys = list(dict.fromkeys((v["x_mm"], v["y_mm"], v["theta_deg"]) for _, v in rows))
    postures, modes = [], []
    for k in keys:
        postures.append(Posture.from_mm_deg(*k))
        per = {}
        for band in ("low", "high"):
            sel = [(r, v) for r, v in rows if (v["x_mm"], v["y_mm"], v["theta_deg"]) == k and r["band"] == band]
            if not sel:
                continue
            f = np.array([v["f_n_hz"] for _, v in sel])
            z = np.array([v["zeta_pct"] for _, v in sel]) / 100
            res = np.full((len(sel), 4, 4), np.nan + 0j)
            for i, (r, _) in enumerate(sel):
                if r.get("phiR_1X_re"):
                    try:
                        pl = np.array([float(r[f"phiL_{c}_re"]) + 1j * float(r[f"phiL_{c}_im"]) for c in _COORDS])
                        pr = np.array([float(r[f"phiR_{c}_re"]) + 1j * float(r[f"phiR_{c}_im"]) for c in _COORDS])
                    except (KeyError, ValueError):
                        raise InputError(f"{p.name}: a mode at {k} gives part of its shape; give all 16 phi "
                                         "columns or none") from None
                    res[i] = np.outer(pr, pl)
            ids = [int(r["mode"]) if r.get("mode") else i for i, (r, _) in enumerate(sel)]
            per[band] = MeasuredModes(f_n=f, zeta=z, f_std=np.zeros(len(f)), zeta_std=np.zeros(len(f)),
                                      residue=res, residue_std=np.zeros(len(f)), mode_id=np.array(ids, int))
        modes.append(per)
    return postures, modes
