"""A real case: the bundled IRB6660 stand-in against seed 000's measurements of a real IRB6660.

Seed 000 gives natural frequencies and damping ratios of nine modes at its three validation
postures (Tables 2-3) and all 16 parameters of the nine modes at one representative posture
(Table B1), typed into ``data/seed000_irb6660.csv``. They enter the diagnosis as measured modal
data: frequency and damping residuals where the tables give only those, and residue scale and
shape too where Table B1 gives the eigenvectors; the FRF matrix Table B1 implies is also
written as UFF58 (:func:`write_table_b1_uff`), for the FRF-level tools.

The check is a cross-validation over the validation postures: fit on two of them (and Table B1's
posture), score on the third, all three ways round.
"""

from __future__ import annotations

import csv
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from rmbench.errors import InputError
from rmbench.calibrate.design import TestDesign
from rmbench.gap.frf.diagnosis import DiagnosisSettings, SearchData, diagnose_modes
from rmbench.gap.frf.effects import Change
from rmbench.calibrate.measured import MeasuredModes
from rmbench.gap.frf.model import ModelBench
from rmbench.robot import Posture

__all__ = ["SEED000_CSV", "RealCase", "seed000_modes", "diagnose_seed000", "write_table_b1_uff"]

SEED000_CSV = "seed000_irb6660.csv"
VALIDATION = ((1800.0, -200.0, 0.0), (1800.0, 200.0, 0.0), (1800.0, 200.0, 60.0))
TABLE_B1_POSTURE = (1300.0, 100.0, 0.0)
_COORDS = ("1X", "1Y", "1aX", "1aY")


@dataclass(frozen=True)
class RealCase:
    """The seed-000 case: one diagnosis per held-out validation posture.

    Attributes
    ----------
    postures : tuple of (float, float, float)
        The measured postures (mm, mm, degrees), validation postures first.
    folds : tuple of Diagnosis
        Fold ``k`` holds validation posture ``k`` out.
    mirror : dict
        The first mode at the mirror postures (1800, ±200, 0): measured and model frequencies.
    seconds : float
    """

    postures: tuple
    folds: tuple
    mirror: dict
    seconds: float


def _read_csv(path) -> list[dict]:
    text = Path(path).read_text() if path is not None else \
        resources.files("rmbench.gap").joinpath("data", SEED000_CSV).read_text()
    lines = [ln for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    return list(csv.DictReader(lines))


def seed000_modes(path=None) -> tuple[list[tuple], list[dict]]:
    """The measured postures (mm, mm, deg) and, per posture, ``{band: MeasuredModes}``.

    Standard errors are not given by the seed: they are zero, and the residual floors
    (0.1 % in frequency, 3 % in damping) stand for the measurement's uncertainty.
    """
    rows = _read_csv(path)
    keys = []
    for r in rows:
        k = (float(r["x_mm"]), float(r["y_mm"]), float(r["theta_deg"]))
        if k not in keys:
            keys.append(k)
    keys.sort(key=lambda k: (k not in VALIDATION, VALIDATION.index(k) if k in VALIDATION else 0))
    out = []
    for k in keys:
        per = {}
        for band in ("low", "high"):
            sel = [r for r in rows if (float(r["x_mm"]), float(r["y_mm"]), float(r["theta_deg"])) == k
                   and r["band"] == band]
            f = np.array([float(r["f_n_hz"]) for r in sel])
            z = np.array([float(r["zeta_pct"]) for r in sel]) / 100
            res = np.full((len(sel), 4, 4), np.nan + 0j)
            for i, r in enumerate(sel):
                if r["phiR_1X_re"]:
                    pl = np.array([float(r[f"phiL_{c}_re"]) + 1j * float(r[f"phiL_{c}_im"]) for c in _COORDS])
                    pr = np.array([float(r[f"phiR_{c}_re"]) + 1j * float(r[f"phiR_{c}_im"]) for c in _COORDS])
                    res[i] = np.outer(pr, pl)
            per[band] = MeasuredModes(f_n=f, zeta=z, f_std=np.zeros(len(f)), zeta_std=np.zeros(len(f)),
                                      residue=res, residue_std=np.zeros(len(f)),
                                      mode_id=np.array([int(r["mode"]) for r in sel]))
        out.append(per)
    return keys, out


def diagnose_seed000(robot="irb6660", tool="dummy", *, path=None, test: str | None = None,
                     workers: int | None = None, settings: DiagnosisSettings = DiagnosisSettings(),
                     progress=None) -> RealCase:
    """Diagnose the stand-in against the seed's real robot, each validation posture held out once.

    Parameters
    ----------
    test : str, optional
        Campaign TOML of the test design (default: the seed's, ``seed_full``).
    """
    from rmbench.impact import load_config
    from rmbench.robot import Robot

    t0 = time.perf_counter()
    say = progress or (lambda msg: None)
    rob = robot if isinstance(robot, Robot) else Robot.load(robot, tool=tool)
    design = TestDesign.from_text(test) if test is not None else TestDesign.from_config(load_config("seed_full"))
    keys, meas = seed000_modes(path)
    if not all(v in keys for v in VALIDATION):
        raise InputError("the seed-000 table lacks a validation posture")
    postures = [Posture.from_mm_deg(*k) for k in keys]
    bench = ModelBench.commanded(rob, design, postures)
    folds = []
    for k in range(len(VALIDATION)):
        held = [k]
        train = [i for i in range(len(keys)) if i != k]
        say(f"fold {k + 1}: posture {keys[k]} held out")
        data = SearchData.from_modes(rob, postures, meas, design=design, train=train, held=held, bench=bench)
        folds.append(diagnose_modes(data, settings=settings, workers=workers, progress=say,
                                    notes=(f"held out: posture {keys[k]}",)))
    first = {}
    for k in (0, 1):
        mm = meas[k]["low"]
        i = int(np.argmin(mm.mode_id))
        model = bench.modes(Change(), k, "low")
        first[str(keys[k])] = {"measured_hz": float(mm.f_n[i]),
                               "model_lowest_hz": float(model.f_n.min()) if len(model) else float("nan")}
    return RealCase(postures=tuple(keys), folds=tuple(folds), mirror=first,
                    seconds=time.perf_counter() - t0)


def write_table_b1_uff(directory, *, design: TestDesign | None = None) -> list[Path]:
    """Write the 4x4 FRF matrix Table B1 implies (all nine modes) as UFF58, both bands, on the
    seed's lines, at Table B1's posture; returns the files written."""
    import xarray as xr

    from rmbench.impact import load_config
    from rmbench.io import write_uff58
    from rmbench.modal.synthetic import table_b1

    design = design or TestDesign.from_config(load_config("seed_full"))
    system = table_b1("low")
    freq = np.concatenate([design.lines(b) for b in ("low", "high")])
    band = np.concatenate([[b] * len(design.lines(b)) for b in ("low", "high")])
    from rmbench.modal import synthesize

    H = synthesize(freq, system.poles, system.phi_r, system.phi_l)[None]
    p = Posture.from_mm_deg(*TABLE_B1_POSTURE)
    ds = xr.Dataset({"H": (("posture", "freq", "out", "inp"), H)},
                    coords={"freq": freq, "band": ("freq", band), "out": list(_COORDS),
                            "inp": list(_COORDS), "x": ("posture", [p.x]), "y": ("posture", [p.y]),
                            "theta": ("posture", [p.theta]), "ok": ("posture", [True]),
                            "reason": ("posture", [""])},
                    attrs={"config": design.config.model_dump_json(),
                           "source": "seed 000 Table B1 (all nine modes), synthesised"})
    return write_uff58(ds, directory)
