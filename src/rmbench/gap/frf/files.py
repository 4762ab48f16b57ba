"""A diagnosis's folder: ``diagnosis.json``, the effect and gap-mode tables, the figures and the
updated variant MJCF (:meth:`rmbench.gap.frf.result.Diagnosis.save`)."""

from __future__ import annotations

import csv
from pathlib import Path

from rmbench.gap.jsonable import write_whole
from rmbench.io.strict_json import strict_dumps

__all__ = ["write_diagnosis", "mode_rows"]

_EFFECT_COLUMNS = ["rank", "name", "chosen", "description", "confidence", "shrink", "gap_before", "gap_after",
                   "f_err_before", "f_err_after", "frf_db_before", "frf_db_after"]
_MODE_COLUMNS = ["posture", "x", "y", "theta", "band", "mode", "f_meas", "f_model", "zeta_meas", "zeta_model",
                 "df", "dzeta", "dscale", "mac", "significant"]


def write_diagnosis(dg, directory: str | Path) -> dict:
    """Write a :class:`~rmbench.gap.frf.result.Diagnosis` ``dg`` into ``directory``:
    ``diagnosis.json``, ``effects.csv``, ``gap_modes.csv`` (and ``gap_modes_after.csv``, the
    updated model's gap, when there is one), the figures, the updated variant (``variant.xml``)
    and the calibrated model (``calibrated.xml``) where there are.

    Returns
    -------
    dict
        ``{"json", "effects", "modes", "modes_after", "variant", "calibrated", "figures"}`` paths.
    """
    from rmbench.gap.plot import plot_diagnosis

    d = Path(directory)
    d.mkdir(parents=True, exist_ok=True)
    out = {}
    if dg.variant_xml is not None:
        write_whole(d / "variant.xml", dg.variant_xml)
        out["variant"] = str(d / "variant.xml")
    if dg.calibrated_xml is not None:
        write_whole(d / "calibrated.xml", dg.calibrated_xml)
        out["calibrated"] = str(d / "calibrated.xml")
    _write_effects(d / "effects.csv", dg.effects)
    for name, gm in (("gap_modes.csv", dg.where), ("gap_modes_after.csv", dg.where_after)):
        if gm is None:
            (d / name).unlink(missing_ok=True)      # an earlier diagnosis's, in the same folder
        else:
            _write_modes(d / name, gm)
    out["effects"] = str(d / "effects.csv")
    out["modes"] = str(d / "gap_modes.csv")
    if dg.where_after is not None:
        out["modes_after"] = str(d / "gap_modes_after.csv")
    out["figures"] = [str(p) for p in plot_diagnosis(dg, d)]
    write_whole(d / "diagnosis.json", strict_dumps(dg.to_dict(out.get("variant")), indent=2))
    out["json"] = str(d / "diagnosis.json")
    return out


def mode_rows(gm) -> list:
    """A gap map's records (:class:`~rmbench.gap.frf.where.GapMap`) as the rows of
    ``gap_modes.csv``, one dict per measured mode: the columns of :data:`_MODE_COLUMNS` and the
    four z-scores ``z_f``, ``z_zeta``, ``z_scale``, ``z_shape`` (what the report reads, from the
    object or from the file)."""
    zs = ("z_f", "z_zeta", "z_scale", "z_shape")
    return [{**{c: r[c] for c in _MODE_COLUMNS}, **dict(zip(zs, r["z"].values()))} for r in gm.records]


def _write_effects(path: Path, effects) -> None:
    """``effects.csv``: one row per ranked effect, its held-out gap, frequency and FRF errors."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(_EFFECT_COLUMNS)
        for i, e in enumerate(effects):
            before, after = e.heldout_before, e.heldout_after
            w.writerow([i + 1, e.name, e.chosen, e.description, f"{e.confidence:.4g}", f"{e.shrink:.4g}",
                        f"{before['gap']:.4g}", f"{after['gap']:.4g}", f"{before['f_err']:.4g}",
                        f"{after['f_err']:.4g}", f"{before['frf_db']:.4g}", f"{after['frf_db']:.4g}"])


def _write_modes(path: Path, gm) -> None:
    """A gap map's records (:class:`~rmbench.gap.frf.where.GapMap`), one row per measured mode."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        rows = mode_rows(gm)
        w.writerow(_MODE_COLUMNS + ["z_f", "z_zeta", "z_scale", "z_shape"])
        for r in rows:
            w.writerow([r[c] for c in _MODE_COLUMNS] + [f"{r[z]:.4g}" for z in ("z_f", "z_zeta", "z_scale", "z_shape")])
