"""Modal parameters out of rmbench: UFF55 complex-mode files and a flat CSV table.

A modal dataset (DATA.md) holds ``modal`` (posture, mode, param), the 16 parameters per mode of
METHODS.md §2: f_n (Hz), ζ, φL at 1X 1aX 1Y (φL's 1aY element is 1 and not stored) and φR at
1X 1aX 1Y 1aY (s/kg), with an optional ``modal_std`` of the same shape. Where METHODS.md §2's
fallback fixed another φL element for a mode (coordinate ``phiL_ref`` on ``mode``), φL at 1aY
is in ``phiL_1aY`` (posture, mode), complex.

A directory written by :func:`write_uff55`::

    posture_0000_modes.uff   one dataset-55 record per mode: the right eigenvectors φR
    posture_0000_left.uff    the same records with the left eigenvectors φL (phiL_ref = 1)
    ...                      (postures numbered from 0 in dataset order; failed postures: no files)

Each record is "data at nodes" of a complex eigenvalue analysis (SDRC dataset 55):

* record 6: model type 1 (structural), analysis type 3 (complex eigenvalue, first order), data
  characteristic 2 (3-DOF global translation vector, so 3 values a node: X, Y and Z = 0),
  specific data type 8 (displacement), data type 5 (complex);
* record 7: load case 1 and the mode number, the mode's position along ``mode`` plus one (UFF
  modes count from 1, rmbench's from 0; ID line 1 names the rmbench mode and its band);
* record 8: the eigenvalue λ = −ζω_n + iω_n√(1−ζ²) in rad/s, modal A = 1 and modal B = −λ: the
  first-order normalisation ψL^T A ψR = 1 of METHODS.md §2, under which the receptance is
  H = Σ φR φL^T / (iω − λ) + c.c. with no further scale;
* records 9-10, nodes as in the campaign's UFF58 files: node 1 = tool tip (point 1), node 2 =
  point 1a; values in the robot base frame's X, Y (UFF directions 1, 2), Z written as 0.

φL goes into a second file rather than a second set of records in the same file: modal software
takes every dataset-55 record of a file as one more mode shape, so a file holding both would show
each mode twice. ``*_modes.uff`` alone is the usual mode-shape set (φR, which carries the units);
``*_left.uff`` completes it for a non-reciprocal structure (for a reciprocal one φL ∝ φR).

Precision: record 8 and the node values use the format's ``6E13.5`` (6 significant digits), so
each component of φR and φL, the real and imaginary part of λ and hence f_n come back within
5e-6 relative, ζ within 1e-5 relative. ID line 5 (``rmbench-mode N f_n F zeta Z``) also
carries f_n and ζ at full precision (shortest round-trip ``repr``). Modes whose parameters are
not all finite at a posture (not identified there) are left out of that posture's files; a
posture with no such mode gets no files. ``modal_std`` is not written to UFF55 (the format has no
place for it); :func:`write_modal_csv` writes it.
"""

from __future__ import annotations

import csv
import io
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from rmbench.errors import InputError
from rmbench.io.uff58 import _posture_values, _uff_date, _uff_directory, _write_atomic

__all__ = ["write_uff55", "write_modal_csv"]

_PHI_L = ("1X", "1aX", "1Y")  # stored φL elements; 1aY is 1
_PHI_R = ("1X", "1aX", "1Y", "1aY")
_PARAMS = ("f_n", "zeta",
           *(f"phiL_{c}_{part}" for c in _PHI_L for part in ("re", "im")),
           *(f"phiR_{c}_{part}" for c in _PHI_R for part in ("re", "im")))
# node (1 = tool tip, 2 = point 1a) → positions of its X and Y values in _PHI_R order
_NODES = ((1, (0, 2)), (2, (1, 3)))
_MODEL_STRUCTURAL = 1
_ANALYSIS_COMPLEX_EIGEN = 3
_DATA_CH_3DOF = 2
_SPEC_DISPLACEMENT = 8
_DATA_COMPLEX = 5
_LOAD_CASE = 1
_TINY = 1e-99  # E13.5 has room for two exponent digits: smaller magnitudes are written as 0


@dataclass(frozen=True)
class _ModalTable:
    """A checked modal dataset: parameters in DATA.md order, posture coordinates in SI."""

    modal: np.ndarray  # (n_posture, n_mode, 16)
    std: np.ndarray | None  # same, or None
    x: np.ndarray  # (n_posture,), m
    y: np.ndarray
    theta: np.ndarray  # rad
    ok: np.ndarray  # bool
    band: np.ndarray  # (n_mode,), str
    phi_l_1ay: np.ndarray  # (n_posture, n_mode) complex: φL at 1aY (1 unless renormalised)
    ref: np.ndarray  # (n_mode,), str: the φL element fixed to 1
    fit_ok: np.ndarray | None = None  # (n_posture, n_mode) bool: the verdict of the mode's band
    uncertain: np.ndarray | None = None  # (n_posture, n_mode) bool


def write_uff55(ds: xr.Dataset, directory: str | os.PathLike) -> list[Path]:
    """Write the modes of every measured posture as UFF55 complex-mode files.

    Per posture with ``ok`` true and at least one identified mode, ``posture_NNNN_modes.uff``
    holds one dataset-55 record per mode with its eigenvalue and right eigenvector φR (s/kg), and
    ``posture_NNNN_left.uff`` the same records with the left eigenvector φL (dimensionless, its
    ``phiL_ref`` element 1, 1aY by default); NNNN is the posture's position in ``ds``, from 0. Codes, nodes and precision are
    described in the module docstring. Each file is written under a temporary name and renamed,
    so a failure leaves no half-written file; files of the same names are replaced.

    Parameters
    ----------
    ds : xarray.Dataset
        A modal dataset (DATA.md): ``modal`` (posture, mode, param), real, with the 16 ``param``
        labels (f_n in Hz, zeta, φL and φR parts); optional posture coordinates ``x``, ``y`` (m),
        ``theta`` (rad), ``ok`` (absent ones are written as NaN and true) and ``mode_band`` on
        ``mode``.
    directory : str or path-like
        Where to write; created if missing.

    Returns
    -------
    list of Path
        The files written, in posture order, each posture's ``_modes`` file before its ``_left``.

    Raises
    ------
    InputError
        ``ds`` has no ``modal`` variable, other dimensions or ``param`` labels; a written mode has
        f_n ≤ 0 or |ζ| ≥ 1 (no complex pole pair); a file cannot be written.
    """
    table = _modal_table(ds, "write_uff55")
    directory = _uff_directory(directory)
    date = _uff_date(ds.attrs.get("created"))
    written = []
    for p in np.flatnonzero(table.ok):
        found = np.flatnonzero(np.all(np.isfinite(table.modal[p]), axis=1))
        if found.size == 0:
            continue
        stem = f"posture_{p:04d}"
        where = (f"rmbench {stem}", date, f"posture x={table.x[p] * 1000:g} mm "
                 f"y={table.y[p] * 1000:g} mm theta={math.degrees(table.theta[p]):g} deg")
        right, left = [], []
        for m in found:
            prm = table.modal[p, m]
            eig = _eigenvalue(prm[0], prm[1], f"posture {p}, mode {m}")
            band = f" ({table.band[m]} band)" if table.band[m] else ""
            id5 = f"rmbench-mode {m} f_n {float(prm[0])!r} zeta {float(prm[1])!r}"
            phi_l = np.append(prm[2:8:2] + 1j * prm[3:8:2], table.phi_l_1ay[p, m])  # 1X 1aX 1Y 1aY
            phi_r = prm[8:16:2] + 1j * prm[9:16:2]
            right.append(_record(eig, int(m) + 1, phi_r,
                                 (f"rmbench mode {m}{band} right eigenvector phiR, s/kg", *where, id5)))
            left.append(_record(eig, int(m) + 1, phi_l,
                                (f"rmbench mode {m}{band} left eigenvector phiL, {table.ref[m]} = 1",
                                 *where, id5)))
        for kind, records in (("modes", right), ("left", left)):
            path = directory / f"{stem}_{kind}.uff"
            _write_atomic(path, "".join(records).encode("ascii", errors="replace"))
            written.append(path)
    return written


def write_modal_csv(ds: xr.Dataset, path: str | os.PathLike) -> Path:
    """Write the modal parameters as one CSV table, a row per measured posture and mode.

    Columns (one header line): ``posture`` (position in ``ds``, from 0), ``x_mm``, ``y_mm``,
    ``theta_deg`` (the posture in mm and degrees, as the CLI shows it), ``mode`` (position along
    ``mode``, from 0), ``band``, the 16 parameters under their DATA.md names in SI (f_n in Hz,
    zeta, φL dimensionless, φR in s/kg) and, when ``ds`` has ``modal_std``, their standard
    deviations as ``<param>_std``; then ``phiL_ref`` (the φL element fixed to 1 for the mode,
    1aY unless METHODS.md §2's fallback moved it) and ``phiL_1aY_re``/``_im`` (φL at 1aY, 1 + 0i
    unless renormalised); where the dataset has them, ``fit_ok`` (``true``/``false``: the
    verdict on the fit of the mode's band at that posture) and ``uncertain`` (the mode's
    standard errors do not support the accuracy asked of it). Rows cover the postures whose ``ok`` is true, every mode of
    each; a mode not identified at a posture has ``nan`` values. Numbers are written with
    Python's shortest round-trip representation, so they read back exactly. The file is written
    under a temporary name and renamed.

    Parameters
    ----------
    ds : xarray.Dataset
        A modal dataset, as for :func:`write_uff55`; ``modal_std`` (posture, mode, param) optional.
    path : str or path-like
        The CSV file to write (its directory must exist).

    Returns
    -------
    Path
        ``path``.

    Raises
    ------
    InputError
        ``ds`` has no ``modal`` variable, other dimensions or ``param`` labels, a ``modal_std``
        of other dimensions; the file cannot be written.
    """
    table = _modal_table(ds, "write_modal_csv")
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    std_columns = [f"{name}_std" for name in _PARAMS] if table.std is not None else []
    verdict = [c for c, v in (("fit_ok", table.fit_ok), ("uncertain", table.uncertain))
               if v is not None]
    writer.writerow(["posture", "x_mm", "y_mm", "theta_deg", "mode", "band", *_PARAMS, *std_columns,
                     "phiL_ref", "phiL_1aY_re", "phiL_1aY_im", *verdict])
    for p in np.flatnonzero(table.ok):
        posture = [int(p), repr(float(table.x[p]) * 1000.0), repr(float(table.y[p]) * 1000.0),
                   repr(math.degrees(table.theta[p]))]
        for m in range(table.modal.shape[1]):
            values = table.modal[p, m] if table.std is None else np.concatenate(
                [table.modal[p, m], table.std[p, m]])
            a = table.phi_l_1ay[p, m]
            flags = [str(bool(v[p, m])).lower() for v in (table.fit_ok, table.uncertain)
                     if v is not None]
            writer.writerow([*posture, m, table.band[m], *(repr(float(v)) for v in values),
                             table.ref[m], repr(float(a.real)), repr(float(a.imag)), *flags])
    path = Path(path)
    _write_atomic(path, out.getvalue().encode("utf-8"))
    return path


def _modal_table(ds, who: str) -> _ModalTable:
    """Check a modal dataset and bring its parameters into DATA.md order."""
    if not isinstance(ds, xr.Dataset):
        raise InputError(f"{who} needs an xarray Dataset, got {type(ds).__name__}")
    if "modal" not in ds.data_vars:
        raise InputError(f"{who}: the dataset has no variable 'modal' (posture, mode, param) of "
                         f"modal parameters; its variables are {sorted(map(str, ds.data_vars))}")
    _check_labels(ds)
    modal = _parameters(ds, "modal")
    std = _parameters(ds, "modal_std") if "modal_std" in ds.data_vars else None
    n = modal.shape[0]
    x, y, theta = (np.asarray(_posture_values(ds, name, np.nan, n), dtype=float)
                   for name in ("x", "y", "theta"))
    ok = np.asarray(_posture_values(ds, "ok", True, n), dtype=bool)
    # METHODS.md §2 fallback: a mode may fix another φL element; 1aY is then stored apart
    phi_l_1ay = (np.asarray(ds["phiL_1aY"].transpose("posture", "mode").values, complex)
                 if "phiL_1aY" in ds.data_vars else np.ones(modal.shape[:2], complex))
    ref = (np.asarray(ds["phiL_ref"].values, dtype=str) if "phiL_ref" in ds.coords
           else np.array(["1aY"] * modal.shape[1]))
    band = _mode_bands(ds)
    fit_ok = uncertain = None
    if "fit_ok" in ds.data_vars and set(ds["fit_ok"].dims) == {"posture", "fit_band"}:
        verdict = ds["fit_ok"].transpose("posture", "fit_band")
        labels = [str(b) for b in ds["fit_band"].values]
        fit_ok = np.ones(modal.shape[:2], bool)
        for m, b in enumerate(band):
            if b in labels:
                fit_ok[:, m] = np.asarray(verdict.values[:, labels.index(b)], dtype=bool)
    if "mode_uncertain" in ds.data_vars and set(ds["mode_uncertain"].dims) == {"posture", "mode"}:
        uncertain = np.asarray(ds["mode_uncertain"].transpose("posture", "mode").values, dtype=bool)
    return _ModalTable(modal=modal, std=std, x=x, y=y, theta=theta, ok=ok, band=band,
                       phi_l_1ay=phi_l_1ay, ref=ref, fit_ok=fit_ok, uncertain=uncertain)


def _check_labels(ds: xr.Dataset) -> None:
    """The ``param`` coordinate holds the 16 DATA.md labels, each once."""
    labels = [str(v) for v in ds["param"].values] if "param" in ds.coords else None
    if labels is None or sorted(labels) != sorted(_PARAMS):
        missing = [p for p in _PARAMS if p not in (labels or ())]
        unexpected = [p for p in labels or () if p not in _PARAMS]
        raise InputError(f"the param labels must be the 16 of DATA.md ({', '.join(_PARAMS)}); "
                         + ("the dataset has no param coordinate" if labels is None else
                            f"missing {missing}, unexpected {unexpected}"
                            + (", duplicated labels" if not missing and not unexpected else "")))


def _parameters(ds: xr.Dataset, name: str) -> np.ndarray:
    """``ds[name]`` as float (posture, mode, 16) in DATA.md parameter order."""
    var = ds[name]
    if set(var.dims) != {"posture", "mode", "param"}:
        raise InputError(f"{name} must have dimensions (posture, mode, param), got {var.dims}")
    if not (np.issubdtype(var.dtype, np.floating) or np.issubdtype(var.dtype, np.integer)):
        raise InputError(f"{name} must hold real numbers, got dtype {var.dtype}")
    return np.asarray(var.transpose("posture", "mode", "param").sel(param=list(_PARAMS)).values,
                      dtype=float)


def _mode_bands(ds: xr.Dataset) -> np.ndarray:
    """Each mode's band from ``mode_band`` (or DATA.md's ``band``) on ``mode``, else empty."""
    for name in ("mode_band", "band"):
        if name in ds.coords and ds[name].dims == ("mode",):
            return np.asarray(ds[name].values).astype(str)
    return np.full(ds.sizes["mode"], "", dtype=str)


def _eigenvalue(f_n: float, zeta: float, where: str) -> complex:
    """λ = −ζω_n + iω_n√(1−ζ²), rad/s, of an underdamped mode."""
    if not (f_n > 0.0 and abs(zeta) < 1.0):
        raise InputError(f"{where}: f_n = {f_n!r} Hz and zeta = {zeta!r} give no complex pole pair "
                         "(UFF55 complex modes need f_n > 0 and |zeta| < 1)")
    omega = 2.0 * math.pi * f_n
    return complex(-zeta * omega, omega * math.sqrt(1.0 - zeta * zeta))


def _record(eig: complex, mode_n: int, phi: np.ndarray, id_lines: tuple[str, ...]) -> str:
    """One dataset-55 record (complex eigenvalue, 3-DOF complex vectors at nodes 1 and 2).

    ``phi`` holds the 1X 1aX 1Y 1aY components; ``id_lines`` the five ID lines (ASCII).
    """
    lines = ["    -1", f"{55:6d}", *(f"{line[:80]:<80}" for line in id_lines),
             f"{_MODEL_STRUCTURAL:10d}{_ANALYSIS_COMPLEX_EIGEN:10d}{_DATA_CH_3DOF:10d}"
             f"{_SPEC_DISPLACEMENT:10d}{_DATA_COMPLEX:10d}{3:10d}",
             f"{2:10d}{6:10d}{_LOAD_CASE:10d}{mode_n:10d}",
             _e13(eig.real, eig.imag, 1.0, 0.0, -eig.real, -eig.imag)]
    for node, (ix, iy) in _NODES:
        lines += [f"{node:10d}", _e13(phi[ix].real, phi[ix].imag, phi[iy].real, phi[iy].imag, 0.0, 0.0)]
    lines.append("    -1")
    return "\n".join(lines) + "\n"


def _e13(*values: float) -> str:
    """Values in ``E13.5`` fields; magnitudes below 1e-99 as 0 (no room for a 3-digit exponent)."""
    return "".join(f"{v if abs(v) >= _TINY else 0.0:13.5E}" for v in values)
