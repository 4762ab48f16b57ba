"""Where the model departs from the measurement: the gap map.

Per measured mode (posture, band) the paired model mode's frequency, damping, residue-scale and
shape gaps, each also as a z-score against the measurement's uncertainty (standard error and the
floors of :mod:`rmbench.calibrate.residual`); per posture and band the FRF log-magnitude gap of each entry
class (direct, same direction, X↔Y cross) against the noise the coherence implies; and a summary
by tracked mode, band and entry class of what exceeds the noise (|z| > 3, or an FRF gap beyond
three times its noise).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rmbench.calibrate.residual import SLOT_NAMES, hammer_leak, mode_residuals
from rmbench.modeshape import mac

__all__ = ["GapMap", "gap_map", "entry_class", "ENTRY_CLASSES"]

ENTRY_CLASSES = ("direct", "same direction", "cross")
_DB = 20 / np.log(10)


def entry_class(out: str, inp: str) -> str:
    """``direct`` (same coordinate), ``same direction`` (X with X, Y with Y) or ``cross``."""
    if out == inp:
        return "direct"
    return "same direction" if out[-1] == inp[-1] else "cross"


@dataclass(frozen=True)
class GapMap:
    """The gap of a model to the measurement, mode by mode and FRF by FRF.

    Attributes
    ----------
    records : list of dict
        One per measured mode: ``posture``, ``x``, ``y``, ``theta`` (m, rad), ``band``, ``mode``
        (tracked number), ``f_meas``, ``zeta_meas``, ``f_model``, ``zeta_model`` (NaN when
        unpaired), ``df``, ``dzeta``, ``dscale`` (relative), ``mac`` (of the residues), ``z``
        (dict of the four z-scores), ``significant`` (any |z| > 3), ``paired``.
    frf : list of dict
        One per posture and band: ``posture``, ``band``, and per entry class the rms
        log-magnitude gap (dB) and the rms noise the coherence implies (dB).
    surplus : list of dict
        Model modes visible above 1 % of a band's peak that the measurement lacks.
    """

    records: list
    frf: list
    surplus: list

    def summary(self) -> dict:
        """What exceeds the noise: by band, tracked mode and FRF entry class (JSON-ready)."""
        out = {"bands": {}, "modes": [], "frf": {}, "unpaired_measured": 0,
               "surplus_model_modes": len(self.surplus)}
        for b in sorted({r["band"] for r in self.records}):
            rs = [r for r in self.records if r["band"] == b]
            out["bands"][b] = {"modes": len(rs), "significant": int(sum(r["significant"] for r in rs)),
                               "rms_z": float(np.sqrt(np.mean([np.sum(np.square(list(r["z"].values())))
                                                                for r in rs]))) if rs else 0.0}
        out["unpaired_measured"] = int(sum(not r["paired"] for r in self.records))
        for key in sorted({(r["band"], r["mode"]) for r in self.records}):
            rs = [r for r in self.records if (r["band"], r["mode"]) == key and r["paired"]]
            if not rs:
                continue
            out["modes"].append({
                "band": key[0], "mode": int(key[1]),
                "f_meas": float(np.median([r["f_meas"] for r in rs])),
                "df_median": float(np.median([r["df"] for r in rs])),
                "dzeta_median": float(np.median([r["dzeta"] for r in rs])),
                "mac_median": float(np.median([r["mac"] for r in rs])),
                "significant_at": int(sum(r["significant"] for r in rs)), "postures": len(rs)})
        for b in sorted({r["band"] for r in self.frf}):
            rs = [r for r in self.frf if r["band"] == b]
            out["frf"][b] = {c: {"gap_db": float(np.sqrt(np.mean([r[c][0] ** 2 for r in rs]))),
                                 "noise_db": float(np.sqrt(np.mean([r[c][1] ** 2 for r in rs])))}
                             for c in ENTRY_CLASSES}
        return out

    def describe(self, limit: int = 4) -> str:
        """One line: the largest significant gaps, by tracked mode."""
        s = self.summary()
        worst = sorted((m for m in s["modes"] if m["significant_at"]),
                       key=lambda m: -abs(m["df_median"]))[:limit]
        parts = [f"{m['band']} band mode at {m['f_meas']:.4g} Hz: f {100 * m['df_median']:+.2f} %, "
                 f"ζ {100 * m['dzeta_median']:+.1f} %, MAC {m['mac_median']:.3f} "
                 f"(significant at {m['significant_at']}/{m['postures']} postures)" for m in worst]
        if s["unpaired_measured"]:
            parts.append(f"{s['unpaired_measured']} measured modes with no model partner")
        if s["surplus_model_modes"]:
            parts.append(f"{s['surplus_model_modes']} model modes the data lack")
        return "; ".join(parts) if parts else "no mode departs beyond the noise"


def gap_map(bench, meas, ds, bands, change, postures_xyt, *, averages: int = 3,
            scatter: dict | None = None) -> GapMap:
    """The gap map of the model (``bench`` with ``change``) against the measurement.

    Parameters
    ----------
    bench : ModelBench
    meas : list of dict
        Per posture ``{band: MeasuredModes}``.
    ds : xarray.Dataset or None
        The measured data (H, coherence optional), for the FRF gaps (None: modes only).
    postures_xyt : ndarray, shape (n_postures, 3)
        x, y (m), θ (rad) of each posture.
    averages : int
        Hits averaged per FRF (the coherence's noise formula).
    scatter : dict, optional
        Per band, the hammer's direction scatter (rad): its leak into the cross entries is part
        of their noise (:func:`rmbench.calibrate.residual.hammer_leak`).
    """
    coords = ["1X", "1Y", "1aX", "1aY"] if ds is None else [str(c) for c in ds.out.values]
    classes = {c: [(i, j) for i, o in enumerate(coords) for j, k in enumerate(coords)
                   if entry_class(o, k) == c] for c in ENTRY_CLASSES}
    records, frf, surplus = [], [], []
    for p in range(bench.n_postures):
        x, y, t = postures_xyt[p]
        for b in bands:
            mm = meas[p][b]
            model = bench.modes(change, p, b)
            e, pairing = mode_residuals(mm, model)
            z = e[:-1].reshape(len(mm), 4)
            partner = dict(zip(pairing.meas, pairing.model))
            for i in range(len(mm)):
                j = partner.get(i)
                rec = {"posture": p, "x": float(x), "y": float(y), "theta": float(t), "band": b,
                       "mode": int(mm.mode_id[i]) if mm.mode_id is not None else i,
                       "f_meas": float(mm.f_n[i]), "zeta_meas": float(mm.zeta[i]),
                       "paired": j is not None, "z": dict(zip(SLOT_NAMES, map(float, z[i])))}
                if j is None:
                    rec.update(f_model=np.nan, zeta_model=np.nan, df=np.nan, dzeta=np.nan,
                               dscale=np.nan, mac=np.nan, significant=True)
                else:
                    rm, rd = model.residue[j].ravel(), mm.residue[i].ravel()
                    rec.update(f_model=float(model.f_n[j]), zeta_model=float(model.zeta[j]),
                               df=float(model.f_n[j] / mm.f_n[i] - 1),
                               dzeta=float(model.zeta[j] / mm.zeta[i] - 1),
                               dscale=float(np.linalg.norm(rm) / np.linalg.norm(rd) - 1), mac=float(mac(rd, rm)),
                               significant=bool(np.any(np.abs(z[i]) > 3)))
                records.append(rec)
            for j in pairing.unpaired_model:
                surplus.append({"posture": p, "band": b, "f_model": float(model.f_n[j]),
                                "zeta_model": float(model.zeta[j]), "peak": float(model.peak[j])})
            if ds is None:
                continue
            sel = ds.band.values == b
            freq = ds.freq.values[sel]
            h = ds.H.values[p][sel]
            h_model = bench.frf(change, p, b, freq)
            coh = ds.coherence.values[p][sel] if "coherence" in ds else None
            leak = (hammer_leak(h, ds.inp.values, scatter[b], averages)
                    if scatter and scatter.get(b) else np.zeros(h.shape))
            row = {"posture": p, "band": b}
            for c, idx in classes.items():
                ii, jj = zip(*idx)
                gap = _DB * np.log(np.abs(h_model[:, ii, jj]) / np.abs(h[:, ii, jj]))
                if coh is not None:
                    g2 = np.clip(coh[:, ii, jj], 1e-6, 1 - 1e-9)
                    noise = _DB * np.hypot(np.sqrt((1 - g2) / (2 * averages * g2)), leak[:, ii, jj])
                    noise_rms = float(np.sqrt(np.nanmean(noise ** 2)))
                else:
                    noise_rms = float("nan")
                row[c] = (float(np.sqrt(np.nanmean(gap ** 2))), noise_rms)
            frf.append(row)
    return GapMap(records=records, frf=frf, surplus=surplus)
