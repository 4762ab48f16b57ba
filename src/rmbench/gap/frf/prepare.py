"""The diagnosis's data, prepared: the measurement loaded (:func:`load_data`), its bands checked
against the test design and the model, its modes fitted, the postures split into training and
held-out ones (:func:`prepare`), and the record the search runs on (:class:`SearchData`).

The measured side is the calibration's container, :class:`~rmbench.calibrate.data.ModalData`
(modes, FRF targets, bands, design, postures): a calibrated diagnosis hands it to the calibration
as it is, and the search adds only what is its own (the model bench, the dataset, the split).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

from rmbench.calibrate.data import ModalData, fitted_modal_data, source_name
from rmbench.calibrate.design import TestDesign
from rmbench.calibrate.measured import measured_data, postures_of
from rmbench.calibrate.residual import mode_residuals
from rmbench.calibrate.split import spread_held_out
from rmbench.errors import InputError, UnreachablePosture
from rmbench.gap.frf.effects import Change
from rmbench.gap.frf.model import ModelBench

__all__ = ["SearchData", "check_match", "load_data", "prepare"]


@dataclass(frozen=True)
class SearchData:
    """What the search runs on: the measured modes, a model under the test design and the split.

    Attributes
    ----------
    robot : Robot
        The model searched from: the nominal one (:func:`prepare`), or the calibrated one.
    modal : ModalData
        The measured modes per posture and band, their FRF targets (None for modes alone: a modal
        table), the bands, the test design and the postures.
    bench : ModelBench
        ``robot`` under the design at the measured postures (their joint commands ``bench.q_cmd``).
    ds : xarray.Dataset or None
        The measured FRFs (:func:`rmbench.calibrate.measured.measured_data`; None for a modal table).
    train, held : tuple of int
        Posture indices the candidates are fitted on and scored on.
    """

    robot: object
    modal: ModalData
    bench: ModelBench
    ds: object
    train: tuple
    held: tuple

    @property
    def xyt(self) -> np.ndarray:
        """Posture coordinates of the gap map, shape (n_postures, 3): x, y in m, θ in rad."""
        return np.array([[p.x, p.y, p.theta] for p in self.modal.postures], float).reshape(-1, 3)

    @classmethod
    def from_modes(cls, robot, postures, meas, *, design: TestDesign, train, held, bands=("low", "high"),
                   bench: ModelBench | None = None) -> "SearchData":
        """Measured modes alone (a modal table, no FRFs), on a split the caller chose.

        Parameters
        ----------
        robot : Robot
        postures : sequence of Posture
        meas : sequence of dict
            Per posture, ``{band: MeasuredModes}``.
        design : TestDesign
            The test design the modes were measured under.
        train, held : sequence of int
            Posture indices to fit the candidates on and to score them on.
        bands : sequence of str
        bench : ModelBench, optional
            ``robot`` under ``design`` at ``postures``, to share its caches between calls (folds).
        """
        bench = bench if bench is not None else ModelBench.commanded(robot, design, list(postures))
        modal = ModalData(tuple(postures), tuple(meas), tuple(bands), design)
        return cls(robot, modal, bench, None, tuple(train), tuple(held))


def load_data(data) -> xr.Dataset:
    """A campaign dataset (netCDF path or Dataset) or a UFF58 directory, as a Dataset."""
    if isinstance(data, xr.Dataset):
        return data
    p = Path(data)
    if p.is_dir():
        from rmbench.io import read_uff58

        return read_uff58(p)
    from rmbench.impact import open_campaign

    return open_campaign(p)


def prepare(nominal, data, test, tool, workers, settings, say, t) -> SearchData:
    """What every FRF diagnosis starts from, on the nominal robot: the measured dataset, its modes
    and FRF targets under its test design in the bands it shares with the model, the model bench,
    and the training and held-out postures. ``test``, ``tool``, ``workers``:
    :func:`~rmbench.gap.frf.diagnosis.diagnose`'s; ``settings``: the
    :class:`~rmbench.gap.frf.settings.DiagnosisSettings` (the split); ``say``: the progress
    callback; ``t``: the step times, to which the modal fit's is added."""
    from rmbench.robot import Robot

    robot = nominal if isinstance(nominal, Robot) else Robot.load(nominal, tool=tool)
    ds = measured_data(load_data(data))
    design = TestDesign.of_dataset(ds, test)
    bands = _bands(ds, design, robot)
    postures = postures_of(ds)
    try:
        bench = ModelBench.commanded(robot, design, postures)
    except UnreachablePosture as err:
        raise InputError(f"the data's postures are not this model's: {err}") from None
    say(f"nominal model at {len(postures)} postures")
    modal = fitted_modal_data(ds, design, bands, source_name(data), workers=workers)
    t["fit"] = time.perf_counter()
    say("measured FRFs fitted")
    check_match(bench, modal.modes, bands)
    train, held = _split(ds, settings.heldout)
    train, held = _spread(train, settings.max_train), _spread(held, settings.max_held)
    return SearchData(robot, modal, bench, ds, tuple(train), tuple(held))


def _bands(ds, design, robot) -> list[str]:
    """Bands present in the data, in the design and overlapping the model's bands."""
    data_bands = [b for b in ("low", "high") if np.any(ds.band.values == b)]
    if not data_bands:
        raise InputError("the data hold no low- or high-band lines")
    out = []
    for b in data_bands:
        if b not in design.band_names:
            raise InputError(f"the test design has no {b} band, which the data have")
        f = ds.freq.values[ds.band.values == b]
        m = robot.bands.get(b)
        if m is None or f[-1] <= m.f_min or f[0] >= m.f_max:
            raise InputError(f"the data's {b} band ({f[0]:g}-{f[-1]:g} Hz) does not overlap the "
                             f"model's ({m.f_min:g}-{m.f_max:g} Hz)" if m else
                             f"the model has no {b} band")
        out.append(b)
    return out


def check_match(bench, meas, bands, *, least: float = 0.3) -> None:
    """Refuse data of another robot, tool or sensor layout: most measured modes have no model partner.

    Parameters
    ----------
    bench : ModelBench
        The model under the test design at the measured postures (its modes per posture and band).
    meas : sequence of dict
        Per posture of ``bench``, ``{band: MeasuredModes}``.
    bands : sequence of str
        The bands compared.
    least : float
        The share of measured modes (pooled over postures and bands) that must pair with a model
        mode (within 15 % in frequency and alike in shape).

    Raises
    ------
    InputError
        No measured modes at all, or fewer than ``least`` of them paired.
    """
    total = paired = 0
    for p in range(bench.n_postures):
        for b in bands:
            _, pairing = mode_residuals(meas[p][b], bench.modes(Change(), p, b))
            total += len(meas[p][b])
            paired += len(pairing.meas)
    if total == 0:
        raise InputError("no modes could be fitted in the measured data")
    if paired < least * total:
        raise InputError(f"the data do not look like this model under this test design: only "
                         f"{paired} of {total} measured modes have a model mode within 15 % in "
                         "frequency and alike in shape (another robot, tool or sensor layout?)")


def _split(ds, heldout: float) -> tuple[list[int], list[int]]:
    """Training and held-out postures: every other posture in (θ, x, y) order (a share
    ``heldout`` held out), so both cover the workspace."""
    n = ds.sizes["posture"]
    if n < 2:
        raise InputError("a diagnosis needs at least 2 measured postures (fit on some, score on "
                         "the others)")
    k = max(1, min(n - 1, int(round(heldout * n))))
    held = spread_held_out(ds.x.values, ds.y.values, ds.theta.values, k)
    train = [p for p in range(n) if p not in held]
    return train, held


def _spread(train, most: int) -> list[int]:
    """At most ``most`` of the postures ``train``, spread evenly over them."""
    if len(train) <= most:
        return list(train)
    idx = np.linspace(0, len(train) - 1, most).round().astype(int)
    return [train[i] for i in idx]
