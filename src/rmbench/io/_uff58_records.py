"""Dataset-58 records: write receptance records, read FRF records through pyuff and check them.

Writing is done here rather than with pyuff's writer, which keeps 12 significant digits (enough) but
writes the abscissa minimum and increment with 6 (``%13.5e``), turns NaN into 0 silently, announces
half the byte count of complex data in the 58b identifier line and packs binary values one by one.
The records written here follow the SDRC layout (80-column ASCII header records 1-11):

* ASCII data: ``4E20.12`` (13 significant digits, relative error below 5e-13 per component, read by
  pyuff's fixed 20-column parser and by any reader splitting on white space);
* binary (58b): little-endian IEEE 754 doubles, real and imaginary parts interleaved, byte count in
  the identifier line: the values come back bit for bit;
* the abscissa: even spacing (minimum and increment, 6 digits in record 7 as the format allows), and
  the first and last line at full precision in ID line 5 (``rmbench-abscissa FIRST LAST N``), which
  the reader here prefers when it agrees with record 7.

Reading parses with pyuff (never unpickles or evaluates) and turns every failure into an
:class:`~rmbench.errors.InputError` naming the file and dataset.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

import numpy as np
import pyuff

from rmbench.errors import InputError

__all__ = ["FrfRecord", "Kind", "format_record", "read_frf_records", "FUNC_FRF", "ORD_COMPLEX_DOUBLE",
           "TYPE_FREQUENCY", "TYPE_DISPLACEMENT", "TYPE_EXCITATION_FORCE"]

Kind = Literal["receptance", "mobility", "accelerance"]

FUNC_FRF = 4  # record 6 field 1: frequency response function
ORD_COMPLEX_DOUBLE = 6  # record 7 field 1: complex, double precision
TYPE_FREQUENCY = 18  # records 8-11 field 1 (specific data type)
TYPE_DISPLACEMENT = 8
TYPE_VELOCITY = 11
TYPE_ACCELERATION = 12
TYPE_REACTION_FORCE = 9
TYPE_EXCITATION_FORCE = 13

_KIND_OF_NUMERATOR: dict[int, Kind] = {TYPE_DISPLACEMENT: "receptance", TYPE_VELOCITY: "mobility",
                                       TYPE_ACCELERATION: "accelerance"}
_FORCE_TYPES = (TYPE_EXCITATION_FORCE, TYPE_REACTION_FORCE)
_ABSCISSA_TAG = "rmbench-abscissa"
# a delimiter line as pyuff finds it: "    -1" ending the line (or padded to 80 columns)
_DELIMITER = re.compile(rb"    -1(?=\r|\n| {74}|\Z)")


@dataclass(frozen=True)
class FrfRecord:
    """One frequency response function read from a dataset-58 record, in SI units.

    Attributes
    ----------
    path : Path
        The file it was read from.
    number : int
        Position of the dataset in its file, from 1.
    rsp_node, rsp_dir, ref_node, ref_dir : int
        Response and reference (excitation) node and UFF direction code (1 = +X, -1 = -X, ...).
    kind : {"receptance", "mobility", "accelerance"}
        What the file holds: displacement, velocity or acceleration over force.
    freq : ndarray, shape (n_freq,)
        Frequency lines, Hz, increasing.
    data : ndarray, shape (n_freq,), complex128
        The FRF in m/N, (m/s)/N or (m/s²)/N according to ``kind`` (file units converted through a
        units dataset 164 when the file has one).
    """

    path: Path
    number: int
    rsp_node: int
    rsp_dir: int
    ref_node: int
    ref_dir: int
    kind: Kind
    freq: np.ndarray
    data: np.ndarray

    @property
    def where(self) -> str:
        """``file name, dataset N`` for messages."""
        return f"{self.path.name}, dataset {self.number}"

    def receptance(self) -> np.ndarray:
        """The FRF as receptance, m/N, shape (n_freq,): mobility / (iω), accelerance / (−ω²).

        Lines at 0 Hz of a mobility or accelerance have no receptance and come back NaN.
        """
        if self.kind == "receptance":
            return self.data
        omega = 2.0 * np.pi * self.freq
        with np.errstate(divide="ignore", invalid="ignore"):
            h = self.data / (1j * omega) if self.kind == "mobility" else self.data / -(omega**2)
        return np.where(omega == 0.0, np.nan + 0j, h)


def format_record(data: np.ndarray, f_first: float, f_last: float, *, response: tuple[int, int],
                  reference: tuple[int, int], func_id: int, id_lines: tuple[str, str, str, str],
                  binary: bool) -> bytes:
    """One receptance record (dataset 58, or 58b when ``binary``) as the bytes of a file.

    Parameters
    ----------
    data : ndarray, shape (n_freq,), complex
        Receptance, m/N, on evenly spaced lines from ``f_first`` to ``f_last``.
    f_first, f_last : float
        First and last frequency line, Hz.
    response, reference : tuple of int
        (node, UFF direction) of the response and of the excitation.
    func_id : int
        Function identification number (record 6 field 2).
    id_lines : tuple of 4 str
        ID lines 1-4 (ASCII, at most 80 characters each); ID line 5 carries the abscissa.
    binary : bool
        Write the values as 58b little-endian doubles instead of ``4E20.12`` text.

    Returns
    -------
    bytes
        The record from its opening to its closing ``    -1`` line.
    """
    data = np.ascontiguousarray(data, dtype=np.complex128)
    n = data.size
    df = (f_last - f_first) / (n - 1) if n > 1 else 0.0
    ids = (*id_lines, f"{_ABSCISSA_TAG} {float(f_first)!r} {float(f_last)!r} {n}")
    if binary:
        values = data.astype("<c16").tobytes()
        # Format(I6,1A1,I6,I6,I12,I12,I6,I6,I12,I12): little endian (1), IEEE 754 (2), 11 lines
        ident = f"{58:6d}b{1:6d}{2:6d}{11:12d}{len(values):12d}{0:6d}{0:6d}{0:12d}{0:12d}"
    else:
        values = _ascii_values(data)
        ident = f"{58:6d}"
    header = [ident, *(f"{line[:80]:<80}" for line in ids),
              f"{FUNC_FRF:5d}{func_id:10d}{0:5d}{0:10d} {'NONE':<10}{response[0]:10d}{response[1]:4d}"
              f" {'NONE':<10}{reference[0]:10d}{reference[1]:4d}",
              f"{ORD_COMPLEX_DOUBLE:10d}{n:10d}{1:10d}{f_first:13.5E}{df:13.5E}{0.0:13.5E}",
              _axis(TYPE_FREQUENCY, "Frequency", "Hz"),
              _axis(TYPE_DISPLACEMENT, "Displacement", "m"),
              _axis(TYPE_EXCITATION_FORCE, "Force", "N"),
              _axis(0, "NONE", "NONE")]
    head = ("    -1\n" + "\n".join(header) + "\n").encode("ascii")
    return head + values + b"    -1\n"


def read_frf_records(path: Path) -> list[FrfRecord]:
    """Read the FRF records (dataset 58/58b, function type 4) of one universal file.

    Datasets of other types, and dataset-58 functions other than FRFs (coherence, spectra...),
    are passed over.

    Parameters
    ----------
    path : Path
        A universal file.

    Returns
    -------
    list of FrfRecord
        In file order; empty when the file holds no FRF.

    Raises
    ------
    InputError
        The file cannot be read, is truncated (unbalanced ``-1`` delimiters), a dataset cannot be
        parsed, holds fewer or more values than its header announces, has real ordinates, no
        increasing frequency axis, or an ordinate kind other than displacement, velocity or
        acceleration over force.
    """
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise InputError(f"UFF file {path} cannot be read: {exc.strerror or exc}") from None
    n_delimiters = len(_DELIMITER.findall(raw))
    if n_delimiters == 0:
        return []
    if n_delimiters % 2 or not raw.rstrip().endswith(b"    -1"):
        raise InputError(f"UFF file {path} is truncated or corrupt: its last dataset has no closing "
                         "'    -1' line")
    try:
        uff = pyuff.UFF(str(path))
        types = [int(t) for t in uff.get_set_types()]
    except Exception as exc:  # pyuff raises bare Exception for everything
        raise InputError(f"UFF file {path} cannot be parsed: {exc}") from None
    for number, set_type in enumerate(types, start=1):
        if set_type == 0:
            raise InputError(f"UFF file {path} is corrupt: dataset {number} has no dataset number line")
    scale = _unit_scale(uff, types, path)
    records = []
    for number, set_type in enumerate(types, start=1):
        if set_type != 58:
            continue
        try:
            dset = uff.read_sets(number - 1)
        except Exception:
            raise InputError(f"UFF file {path} is truncated or corrupt: dataset {number} (type 58) "
                             "cannot be parsed") from None
        if dset.get("func_type") == FUNC_FRF:
            records.append(_frf_record(dset, path, number, scale))
    return records


def _ascii_values(data: np.ndarray) -> bytes:
    """Interleaved real and imaginary parts, four ``E20.12`` fields a line."""
    values = data.view(np.float64)  # re, im, re, im, ...
    full, rest = divmod(values.size, 4)
    text = ("%20.12E%20.12E%20.12E%20.12E\n" * full) % tuple(values[:4 * full].tolist())
    if rest:
        text += ("%20.12E" * rest + "\n") % tuple(values[4 * full:].tolist())
    return text.encode("ascii")


def _axis(data_type: int, label: str, units: str) -> str:
    """Records 8-11: Format(I10,3I5,2(1X,20A1)); unit exponents are implied by the data type."""
    return f"{data_type:10d}{0:5d}{0:5d}{0:5d} {label:<20} {units:<20}"


def _unit_scale(uff, types: list[int], path: Path) -> float:
    """Factor taking the file's FRFs (length over force) to SI, from its units dataset 164, if any.

    Dataset 164 gives factors that divide file units into SI: length_SI = length / f_length.
    """
    factors = set()
    for number, set_type in enumerate(types, start=1):
        if set_type == 164:
            try:
                units = uff.read_sets(number - 1)
            except Exception:
                raise InputError(f"UFF file {path} is corrupt: units dataset {number} (type 164) "
                                 "cannot be parsed") from None
            factors.add((units["length"], units["force"]))
    if not factors:
        return 1.0
    if len(factors) > 1:
        raise InputError(f"UFF file {path} declares {len(factors)} different unit systems "
                         "(dataset 164); one is supported")
    length, force = factors.pop()
    if not (math.isfinite(length) and math.isfinite(force) and length > 0 and force > 0):
        raise InputError(f"UFF file {path}: units dataset 164 has length factor {length} and force "
                         f"factor {force}; both must be positive")
    return force / length


def _frf_record(dset: dict, path: Path, number: int, scale: float) -> FrfRecord:
    where = f"UFF file {path}, dataset {number}"
    if dset.get("ord_data_type") not in (5, 6):
        raise InputError(f"{where}: FRF ordinates are real (ordinate data type "
                         f"{dset.get('ord_data_type')}); complex ordinates (5 or 6) are needed")
    data = np.asarray(dset["data"], dtype=np.complex128)
    if data.size != dset["num_pts"] or data.size == 0:
        raise InputError(f"{where} is truncated or corrupt: the header announces {dset['num_pts']} "
                         f"values, the record holds {data.size}")
    numerator = dset.get("ordinate_spec_data_type")
    denominator = dset.get("orddenom_spec_data_type")
    if numerator not in _KIND_OF_NUMERATOR or denominator not in _FORCE_TYPES:
        raise InputError(f"{where}: cannot tell the FRF kind from its ordinate data types (numerator "
                         f"{numerator}, denominator {denominator}); displacement (8), velocity (11) "
                         "or acceleration (12) over force (13 or 9) is understood")
    freq = _abscissa(dset, data.size)
    if not (np.all(np.isfinite(freq)) and np.all(np.diff(freq) > 0)):
        raise InputError(f"{where}: the frequency axis is not finite and increasing")
    return FrfRecord(path=path, number=number, rsp_node=int(dset["rsp_node"]),
                     rsp_dir=int(dset["rsp_dir"]), ref_node=int(dset["ref_node"]),
                     ref_dir=int(dset["ref_dir"]), kind=_KIND_OF_NUMERATOR[numerator],
                     freq=freq, data=data * scale)


def _abscissa(dset: dict, n: int) -> np.ndarray:
    """Frequency lines, Hz: rmbench's full-precision ID line 5 where it agrees with the header."""
    freq = np.asarray(dset["x"], dtype=float)
    fields = str(dset.get("id5", "")).split()
    if len(fields) != 4 or fields[0] != _ABSCISSA_TAG or int(dset.get("abscissa_spacing", 0)) != 1:
        return freq
    try:
        first, last, count = float(fields[1]), float(fields[2]), int(fields[3])
    except ValueError:
        return freq
    if count != n or not (math.isfinite(first) and math.isfinite(last)):
        return freq
    exact = np.linspace(first, last, n)
    # record 7 keeps 6 digits of the minimum and the increment: agreement to 1e-5 of the range
    if np.max(np.abs(exact - freq)) > 1e-5 * max(np.max(np.abs(exact)), np.finfo(float).tiny):
        return freq
    return exact
