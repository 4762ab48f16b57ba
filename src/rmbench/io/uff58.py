"""UFF58 interchange of receptance matrices: a campaign dataset to universal files and back.

A directory written by :func:`write_uff58`::

    postures.csv             index, stem, x_mm, y_mm, theta_deg, bands, ok, reason (one row a posture)
    attributes.json          the dataset's attributes
    posture_0000_low.uff     16 dataset-58 records: H[out, inp], out and inp in 1X 1Y 1aX 1aY
    posture_0000_high.uff
    ...                      (postures numbered from 0 in dataset order; failed postures: no files)

Numbering (METHODS.md §1, DATA.md): node 1 = tool tip (point 1), node 2 = point 1a; UFF direction
1 = +X, 2 = +Y of the robot base frame; the response node/direction is ``out``, the reference
(excitation) node/direction is ``inp``. Each record is a receptance: function type 4 (FRF), ordinate
data type 6 (complex double), even abscissa in Hz (specific data type 18), ordinate numerator
specific data type 8 (displacement, m) over denominator 13 (excitation force, N), SI units.

Precision: ASCII records carry 13 significant digits (``4E20.12``, as the format specifies; pyuff's
own writer keeps 12, also enough), so H comes back within 5e-13 relative; binary records (58b,
``binary=True``) carry the IEEE doubles and H comes back bit for bit. The frequency axis comes back
to round-off through a full-precision first/last line in ID line 5 (record 7 keeps 6 digits); see
:mod:`rmbench.io._uff58_records`.

:func:`read_uff58` also reads the UFF58 files of other modal software for one posture: any ``.uff``,
``.unv`` or ``.uf`` files in a directory, node numbers mapped to points by ``node_map``; mobility and
accelerance are converted to receptance, a units dataset 164 to SI, and each FRF's band follows from
its frequency range.
"""

from __future__ import annotations

import json
import math
import os
import re
import secrets
from collections.abc import Mapping
from dataclasses import replace
from datetime import datetime
from pathlib import Path
from types import MappingProxyType

import numpy as np
import xarray as xr

from rmbench.errors import InputError
from rmbench.io._posture_table import PostureRow, format_table, read_table
from rmbench.io._uff58_records import FrfRecord, format_record, read_frf_records

__all__ = ["write_uff58", "read_uff58", "DEFAULT_NODE_MAP", "LOW_BAND_LIMIT_HZ"]

DEFAULT_NODE_MAP: Mapping[int, str] = MappingProxyType({1: "1", 2: "1a"})
"""UFF node number → measurement point, as rmbench writes them."""
LOW_BAND_LIMIT_HZ = 200.0
"""Other software's FRFs whose highest line lies below this frequency (Hz) are the low band."""

_COORDS = ("1X", "1Y", "1aX", "1aY")  # out and inp labels, DATA.md order
_BANDS = ("low", "high")
_AXIS_OF_DIRECTION = {1: "X", 2: "Y"}
_NODE_DIRECTION = {"1X": (1, 1), "1Y": (1, 2), "1aX": (2, 1), "1aY": (2, 2)}
_POSTURE_TABLE = "postures.csv"
_ATTRIBUTES = "attributes.json"
_UFF_SUFFIXES = {".uff", ".unv", ".uf"}
_RMBENCH_FILE = re.compile(r"^(posture_(\d+))_(low|high)\.uff$")
_MONTHS = ("JAN", "FEB", "MAR", "APR", "MAY", "JUN", "JUL", "AUG", "SEP", "OCT", "NOV", "DEC")


def write_uff58(ds: xr.Dataset, directory: str | os.PathLike, *, binary: bool = False) -> list[Path]:
    """Write the receptance ``H`` of a campaign as UFF58 files, one per measured posture and band.

    Each file ``posture_NNNN_BAND.uff`` (NNNN: the posture's position in ``ds``, from 0) holds the
    16 FRFs of the 4x4 matrix, response ``out`` and excitation ``inp`` in 1X 1Y 1aX 1aY order;
    ``postures.csv`` lists every posture (failed ones without files) and ``attributes.json`` the
    dataset's attributes. Other variables (coherence, ground truth) are not written; NaN lines of a
    measured posture are written as NaN. Each file is written under a temporary name and renamed,
    so a failure leaves no half-written file; existing files of the same names are replaced (other
    files in ``directory`` are left alone; ``postures.csv`` says which files belong to the set).

    Parameters
    ----------
    ds : xarray.Dataset
        A campaign (DATA.md): ``H`` (posture, freq, out, inp), complex, m/N; coordinate ``freq``
        (n_freq,), Hz, with ``band`` ("low"/"high") on each line, each band evenly spaced;
        posture coordinates ``x``, ``y`` (m), ``theta`` (rad), ``ok``, ``reason`` (absent ones are
        written as NaN, true and empty).
    directory : str or path-like
        Where to write; created if missing.
    binary : bool, default False
        Write binary 58b records (bit-exact values) instead of ASCII 58 records.

    Returns
    -------
    list of Path
        The files written: the UFF files in posture and band order, then ``postures.csv`` and
        ``attributes.json``.

    Raises
    ------
    InputError
        ``ds`` does not follow DATA.md (no complex ``H``, other out/inp labels, a band not evenly
        spaced or split), an attribute cannot be written as JSON, or a file cannot be written.
    """
    h, freq, band_lines, rows = _campaign(ds)
    attributes = _attributes_json(ds.attrs)
    directory = _uff_directory(directory)
    date = _uff_date(ds.attrs.get("created"))
    written = []
    for p, row in enumerate(rows):
        for band in row.bands:
            lines = band_lines[band]
            records = [format_record(h[p, lines, i, j], freq[lines][0], freq[lines][-1],
                                     response=_NODE_DIRECTION[out], reference=_NODE_DIRECTION[inp],
                                     func_id=4 * i + j + 1, id_lines=_id_lines(row, band, out, inp, date),
                                     binary=binary)
                       for i, out in enumerate(_COORDS) for j, inp in enumerate(_COORDS)]
            path = directory / f"{row.stem}_{band}.uff"
            _write_atomic(path, b"".join(records))
            written.append(path)
    for name, text in ((_POSTURE_TABLE, format_table(rows)), (_ATTRIBUTES, attributes)):
        _write_atomic(directory / name, text.encode("utf-8"))
        written.append(directory / name)
    return written


def read_uff58(directory: str | os.PathLike, *, node_map: Mapping[int, str] | None = None,
               posture_table: str | os.PathLike | None = None) -> xr.Dataset:
    """Read a directory of UFF58 files into a receptance dataset (DATA.md).

    Two kinds of directory are understood:

    * written by :func:`write_uff58` (files ``posture_NNNN_BAND.uff``): the postures and their
      positions come from ``postures.csv`` (or, without it, from the file names, with NaN
      positions); each file's band from its name;
    * written by other modal software for **one** posture (any other ``.uff``/``.unv``/``.uf``
      files): all their FRF records form one posture, at NaN x, y, theta unless ``posture_table``
      (or a ``postures.csv`` there) gives its one row; each FRF's band is "low" if its highest line
      is below 200 Hz, else "high".

    Mobility and accelerance records are converted to receptance (divided by iω and −ω²), and
    ``original_kind`` records what the files held. Records of other functions (coherence,
    spectra), of other directions (Z, rotations) and, with a ``node_map``, of nodes it does not name
    are passed over.

    Parameters
    ----------
    directory : str or path-like
        The directory to read.
    node_map : mapping of int to {"1", "1a"}, optional
        UFF node number → measurement point, e.g. ``{101: "1", 102: "1a"}``. Default
        :data:`DEFAULT_NODE_MAP` (node 1 = tool tip, node 2 = point 1a), where any other node is
        an error.
    posture_table : str or path-like, optional
        A posture table in the ``postures.csv`` format (columns index, x_mm, y_mm, theta_deg
        required) to use instead of the directory's.

    Returns
    -------
    xarray.Dataset
        ``H`` (posture, freq, out, inp), complex128, m/N (NaN for postures not measured);
        coordinates ``freq`` (Hz, low band first) with ``band``, ``out``/``inp`` (1X 1Y 1aX 1aY),
        ``x``, ``y`` (m), ``theta`` (rad), ``ok``, ``reason`` on ``posture``; attributes from
        ``attributes.json`` if present, plus ``original_kind`` ("receptance", "mobility",
        "accelerance", comma-separated if mixed) and ``uff58_source`` (the directory).

    Raises
    ------
    InputError
        No UFF58 FRF records; a file unreadable, truncated or corrupt; not all 16 FRFs of the 4x4
        matrix in a posture and band, or one twice; frequency axes that differ within a band;
        node numbers other than 1 and 2 without a ``node_map``; a malformed posture table.
    """
    directory = Path(directory)
    if not directory.is_dir():
        raise InputError(f"UFF58 directory {directory} does not exist or is not a directory")
    nodes, strict = _node_map(node_map)
    files = sorted(p for p in directory.iterdir()
                   if p.is_file() and not p.name.startswith(".") and p.suffix.lower() in _UFF_SUFFIXES)
    ours = [p for p in files if _RMBENCH_FILE.match(p.name)]
    theirs = [p for p in files if not _RMBENCH_FILE.match(p.name)]
    if ours and theirs:
        raise InputError(f"{directory} mixes rmbench's posture_NNNN_BAND.uff files with other UFF "
                         f"files ({theirs[0].name}); keep one set per directory")
    table_path = Path(posture_table) if posture_table is not None else directory / _POSTURE_TABLE
    table = read_table(table_path) if posture_table is not None or table_path.is_file() else None
    if theirs or (table is None and not ours):
        postures = [_foreign_posture(directory, theirs, table, table_path)]
    else:
        postures = _rmbench_postures(directory, ours, table, table_path)
    matrices = [{band: _frf_matrix(records, band, nodes, strict) for band, records in by_band.items()}
                for _, by_band in postures]
    return _dataset([row for row, _ in postures], matrices, _read_attributes(directory), directory)


def _campaign(ds) -> tuple[np.ndarray, np.ndarray, dict[str, slice], list[PostureRow]]:
    """Check a campaign dataset; H (posture, freq, 4, 4) in _COORDS order, freq, band lines, rows."""
    if not isinstance(ds, xr.Dataset):
        raise InputError(f"write_uff58 needs an xarray Dataset, got {type(ds).__name__}")
    if "H" not in ds.data_vars:
        raise InputError("the dataset has no receptance variable 'H'")
    if set(ds["H"].dims) != {"posture", "freq", "out", "inp"}:
        raise InputError(f"H must have dimensions (posture, freq, out, inp), got {ds['H'].dims}")
    if not np.iscomplexobj(ds["H"]):
        raise InputError(f"H must be complex receptance (m/N), got dtype {ds['H'].dtype}")
    for dim in ("out", "inp"):
        labels = sorted(str(v) for v in ds[dim].values) if dim in ds.coords else None
        if labels != sorted(_COORDS):
            raise InputError(f"H's {dim} labels must be {' '.join(_COORDS)}, got {labels}")
    h = np.asarray(ds["H"].transpose("posture", "freq", "out", "inp")
                   .sel(out=list(_COORDS), inp=list(_COORDS)).values, dtype=np.complex128)
    freq = np.asarray(ds["freq"].values, dtype=float)
    if "band" not in ds.coords or ds["band"].dims != ("freq",):
        raise InputError("the freq dimension needs a coordinate 'band' ('low' or 'high' on each line)")
    band_lines = _band_lines(freq, np.asarray(ds["band"].values).astype(str))
    n = h.shape[0]
    x, y, theta = (np.asarray(_posture_values(ds, name, np.nan, n), dtype=float)
                   for name in ("x", "y", "theta"))
    ok = np.asarray(_posture_values(ds, "ok", True, n), dtype=bool)
    reason = _posture_values(ds, "reason", "", n)
    rows = [PostureRow(index=p, stem=f"posture_{p:04d}", x=float(x[p]), y=float(y[p]),
                       theta=float(theta[p]), bands=tuple(band_lines) if ok[p] else (), ok=bool(ok[p]),
                       reason=str(reason[p])) for p in range(n)]
    return h, freq, band_lines, rows


def _band_lines(freq: np.ndarray, band: np.ndarray) -> dict[str, slice]:
    """The lines of each band, checked contiguous, increasing and evenly spaced."""
    lines = {}
    for name in dict.fromkeys(band):  # in order of appearance
        if name not in _BANDS:
            raise InputError(f"unknown band {name!r} on the freq coordinate; bands are 'low' and 'high'")
        where = np.flatnonzero(band == name)
        if where[-1] - where[0] + 1 != where.size:
            raise InputError(f"the {name} band's frequency lines are not contiguous on the freq axis")
        if where.size < 2:
            raise InputError(f"the {name} band has {where.size} frequency line; UFF58 even spacing "
                             "needs at least 2")
        step = np.diff(freq[where])
        if not (np.all(np.isfinite(step)) and np.all(step > 0)
                and np.max(np.abs(step - step.mean())) <= 1e-6 * step.mean()):
            raise InputError(f"the {name} band's frequency lines ({freq[where[0]]:g}-"
                             f"{freq[where[-1]]:g} Hz) are not increasing and evenly spaced, "
                             "as UFF58 records written here need")
        lines[name] = slice(where[0], where[-1] + 1)
    return lines


def _posture_values(ds: xr.Dataset, name: str, default, n: int) -> np.ndarray:
    if name not in ds.variables:
        return np.full(n, default, dtype=object)
    if ds[name].dims != ("posture",):
        raise InputError(f"posture coordinate {name!r} must lie on the posture dimension alone, got "
                         f"dimensions {ds[name].dims}")
    return ds[name].values


def _id_lines(row: PostureRow, band: str, out: str, inp: str, date: str) -> tuple[str, str, str, str]:
    """ID lines 1-4: function, run (file), date, load case (posture in mm and degrees)."""
    return (f"H({out},{inp}) receptance, response {out}, excitation {inp}",
            f"rmbench {row.stem} band {band}",
            date,
            f"posture x={row.x * 1000:g} mm y={row.y * 1000:g} mm theta={math.degrees(row.theta):g} deg")


def _uff_date(created) -> str:
    """ID line 3 as DD-MMM-YY HH:MM:SS from the ISO ``created`` attribute, else NONE."""
    try:
        t = datetime.fromisoformat(str(created))
    except ValueError:
        return "NONE"
    return f"{t.day:02d}-{_MONTHS[t.month - 1]}-{t.year % 100:02d} {t:%H:%M:%S}"


def _attributes_json(attrs: Mapping) -> str:
    clean = {}
    for key, value in attrs.items():
        if isinstance(value, np.generic | np.ndarray):
            value = value.tolist()
        elif isinstance(value, tuple):
            value = list(value)
        try:
            json.dumps(value)
        except (TypeError, ValueError):
            raise InputError(f"dataset attribute {key!r} of type {type(value).__name__} cannot be "
                             "written; attributes are str, numbers or lists of them") from None
        clean[str(key)] = value
    return json.dumps(clean, indent=1, sort_keys=True) + "\n"


def _read_attributes(directory: Path) -> dict:
    path = directory / _ATTRIBUTES
    if not path.is_file():
        return {}
    try:
        attrs = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"attribute file {path} cannot be read: {exc}") from None
    if not isinstance(attrs, dict):
        raise InputError(f"attribute file {path} must hold a JSON object, got {type(attrs).__name__}")
    return attrs


def _uff_directory(directory) -> Path:
    """The output directory as a Path, created if missing (one-line error if it cannot be)."""
    directory = Path(directory)
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the UFF directory {directory}: {exc.strerror or exc}") from None
    return directory


def _write_atomic(path: Path, payload: bytes) -> None:
    """Write under a temporary name in the same directory, then rename over ``path``."""
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp")
    try:
        with open(tmp, "xb") as fh:
            fh.write(payload)
        os.replace(tmp, path)
    except BaseException as exc:
        tmp.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise InputError(f"cannot write {path}: {exc.strerror or exc}") from None
        raise


def _node_map(node_map) -> tuple[dict[int, str], bool]:
    """The node map and whether nodes outside it are errors (default map) or passed over."""
    if node_map is None:
        return dict(DEFAULT_NODE_MAP), True
    if not isinstance(node_map, Mapping) or not node_map:
        raise InputError(f"node_map must be a non-empty mapping of UFF node numbers to '1' or '1a', "
                         f"got {node_map!r}")
    nodes = {}
    for node, point in node_map.items():
        if isinstance(node, bool) or not isinstance(node, int | np.integer):
            raise InputError(f"node_map keys must be UFF node numbers (int), got {node!r}")
        if point not in ("1", "1a"):
            raise InputError(f"node_map[{node}] must be '1' (tool tip) or '1a', got {point!r}")
        nodes[int(node)] = point
    return nodes, False


def _foreign_posture(directory: Path, files: list[Path], table: list[PostureRow] | None,
                     table_path: Path) -> tuple[PostureRow, dict[str, list[FrfRecord]]]:
    """Other software's files: all FRFs of the directory are one posture; bands by frequency."""
    records = [record for path in files for record in read_frf_records(path)]
    if not records:
        found = f"{len(files)} UFF file(s) read" if files else "no .uff, .unv or .uf files"
        raise InputError(f"no UFF58 FRF records in {directory} ({found})")
    by_band: dict[str, list[FrfRecord]] = {}
    for record in records:
        band = "low" if record.freq[-1] < LOW_BAND_LIMIT_HZ else "high"
        by_band.setdefault(band, []).append(record)
    bands = tuple(b for b in _BANDS if b in by_band)
    if table is None:
        row = PostureRow(index=0, stem="", x=math.nan, y=math.nan, theta=math.nan, bands=bands,
                         ok=True, reason="")
    elif len(table) != 1:
        raise InputError(f"posture table {table_path} has {len(table)} rows; a directory of other "
                         "software's UFF files is one posture")
    else:
        row = replace(table[0], bands=bands, ok=True, reason="")
    return row, by_band


def _rmbench_postures(directory: Path, files: list[Path], table: list[PostureRow] | None,
                      table_path: Path) -> list[tuple[PostureRow, dict[str, list[FrfRecord]]]]:
    """Files written by write_uff58: postures from the table (or the file names), bands by name."""
    found: dict[str, dict[str, Path]] = {}
    for path in files:
        stem, _, band = _RMBENCH_FILE.match(path.name).groups()
        found.setdefault(stem, {})[band] = path
    if table is None:
        table = [PostureRow(index=int(stem.split("_")[1]), stem=stem, x=math.nan, y=math.nan,
                            theta=math.nan, bands=tuple(b for b in _BANDS if b in bands), ok=True,
                            reason="")
                 for stem, bands in sorted(found.items(), key=lambda item: int(item[0].split("_")[1]))]
    postures = []
    for row in table:
        by_band = {}
        bands = row.bands if row.bands is not None else tuple(found.get(row.stem, {}))
        for band in bands if row.ok else ():
            path = directory / f"{row.stem}_{band}.uff"
            if not path.is_file():
                raise InputError(f"posture table {table_path} lists band {band} of posture "
                                 f"{row.index}, but {path.name} is missing")
            records = read_frf_records(path)
            if not records:
                raise InputError(f"UFF file {path} holds no UFF58 FRF records")
            by_band[band] = records
        postures.append((replace(row, bands=tuple(by_band)), by_band))
    return postures


def _frf_matrix(records: list[FrfRecord], band: str, nodes: dict[int, str],
                strict: bool) -> tuple[np.ndarray, np.ndarray, set[str]]:
    """The 4x4 receptance of one posture and band: freq (n_freq,), H (n_freq, 4, 4), kinds read."""
    files = ", ".join(dict.fromkeys(r.path.name for r in records))
    used: dict[tuple[str, str], FrfRecord] = {}
    for record in records:
        unknown = sorted({record.rsp_node, record.ref_node} - nodes.keys())
        if unknown and strict:
            raise InputError(f"UFF file {record.path}, dataset {record.number}: unknown node number(s) "
                             f"{unknown}; rmbench numbers node 1 = tool tip (point 1), node 2 = point "
                             f"1a; pass node_map, e.g. {{{unknown[0]}: '1', ...}}")
        out = _coordinate(nodes, record.rsp_node, record.rsp_dir)
        inp = _coordinate(nodes, record.ref_node, record.ref_dir)
        if out is None or inp is None:
            continue
        if (out, inp) in used:
            raise InputError(f"H({out},{inp}) of the {band} band is given twice: "
                             f"{used[out, inp].where} and {record.where}")
        first = next(iter(used.values()), record)
        if not _same_axis(record.freq, first.freq):
            raise InputError(f"inconsistent frequency axes in the {band} band: {record.where} has "
                             f"{_describe(record.freq)}, {first.where} has {_describe(first.freq)}")
        used[out, inp] = record
    missing = [f"H({o},{i})" for o in _COORDS for i in _COORDS if (o, i) not in used]
    if missing:
        seen = sorted({n for r in records for n in (r.rsp_node, r.ref_node)})
        raise InputError(f"{files}: missing FRFs in the {band} band: {len(missing)} of the 16 of the "
                         f"4x4 matrix (response, excitation in {' '.join(_COORDS)}) are absent: "
                         f"{', '.join(missing)} (node numbers found: {seen})")
    freq = used[_COORDS[0], _COORDS[0]].freq
    h = np.empty((freq.size, 4, 4), dtype=np.complex128)
    for (out, inp), record in used.items():
        sign = np.sign(record.rsp_dir) * np.sign(record.ref_dir)
        h[:, _COORDS.index(out), _COORDS.index(inp)] = sign * record.receptance()
    return freq, h, {record.kind for record in used.values()}


def _coordinate(nodes: dict[int, str], node: int, direction: int) -> str | None:
    """``1X``-style label of a node and UFF direction, None for unmapped nodes and other directions."""
    if node not in nodes or abs(direction) not in _AXIS_OF_DIRECTION:
        return None
    return nodes[node] + _AXIS_OF_DIRECTION[abs(direction)]


def _same_axis(a: np.ndarray, b: np.ndarray) -> bool:
    """Same lines to 1e-6 of the highest: files keep the abscissa to 6 digits at worst."""
    return a.shape == b.shape and bool(np.max(np.abs(a - b)) <= 1e-6 * max(abs(a[-1]), abs(b[-1])))


def _describe(freq: np.ndarray) -> str:
    return f"{freq.size} lines from {freq[0]:g} to {freq[-1]:g} Hz"


def _dataset(rows: list[PostureRow], matrices: list[dict], attrs: dict, directory: Path) -> xr.Dataset:
    """Assemble the postures' matrices on one frequency axis per band (low band first)."""
    axes: dict[str, tuple[np.ndarray, str]] = {}
    for row, by_band in zip(rows, matrices):
        for band, (freq, _, _) in by_band.items():
            where = f"{row.stem}_{band}.uff" if row.stem else f"the {band} band"
            if band not in axes:
                axes[band] = (freq, where)
            elif not _same_axis(freq, axes[band][0]):
                raise InputError(f"inconsistent frequency axes in the {band} band: {where} has "
                                 f"{_describe(freq)}, {axes[band][1]} has {_describe(axes[band][0])}")
    bands = [b for b in _BANDS if b in axes]
    freq = np.concatenate([axes[b][0] for b in bands]) if bands else np.empty(0)
    band_of_line = np.concatenate([np.full(axes[b][0].size, b) for b in bands]) if bands else np.empty(0, str)
    h = np.full((len(rows), freq.size, 4, 4), np.nan + 0j, dtype=np.complex128)
    kinds: set[str] = set()
    start = dict(zip(bands, np.cumsum([0] + [axes[b][0].size for b in bands])))
    for p, by_band in enumerate(matrices):
        for band, (band_freq, matrix, band_kinds) in by_band.items():
            h[p, start[band]:start[band] + band_freq.size] = matrix
            kinds |= band_kinds
    attrs = {**attrs, "original_kind": ", ".join(sorted(kinds)) or "receptance",
             "uff58_source": str(directory)}
    return xr.Dataset(
        {"H": (("posture", "freq", "out", "inp"), h)},
        coords={"freq": freq, "band": ("freq", band_of_line), "out": list(_COORDS), "inp": list(_COORDS),
                "x": ("posture", np.array([r.x for r in rows], dtype=float)),
                "y": ("posture", np.array([r.y for r in rows], dtype=float)),
                "theta": ("posture", np.array([r.theta for r in rows], dtype=float)),
                "ok": ("posture", np.array([r.ok for r in rows], dtype=bool)),
                "reason": ("posture", np.array([r.reason for r in rows], dtype=str))},
        attrs=attrs)
