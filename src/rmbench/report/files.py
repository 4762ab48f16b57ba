"""A report from a file the other stages wrote, its kind read from the file itself:

========================================  ============================================
file                                      report
========================================  ============================================
campaign netCDF (``H``)                   FRF matrix per posture, accuracy, postures
modal netCDF (``modal``)                  the campaign's report with fitted overlays (when
                                          the campaign is given or named ``upstream``),
                                          parameter maps, stabilisation diagram
predictor ``.npz``                        parameter maps; its cross-validation, given
controller ``.npz`` (``A B C D``)         controller response; sensitivity with ``runs``
control runs netCDF (``case``)            sensitivity, stroke and force use
gap diagnosis folder                      verdict, ranked effects, gap maps, before/after
========================================  ============================================

Files are parsed (netCDF, ``.npz`` without pickle, JSON, CSV), never unpickled or evaluated.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rmbench.errors import InputError
from rmbench.report.page import Page

__all__ = ["report_of", "write_report", "kind_of"]


def _load_nc(path):
    import xarray as xr

    if not Path(path).is_file():
        raise InputError(f"file not found: {path}")
    try:
        return xr.load_dataset(path, engine="h5netcdf")    # as rmbench writes them (complex H)
    except Exception as err:  # h5py/h5netcdf raise many types for a bad file
        first = str(err).strip().splitlines()[0] if str(err).strip() else type(err).__name__
        raise InputError(f"{path}: not a readable netCDF dataset ({first})") from None


def kind_of(path) -> str:
    """``"campaign"``, ``"modal"``, ``"predictor"``, ``"controller"``, ``"control_runs"`` or
    ``"gap"``; a one-line :class:`InputError` for anything else."""
    p = Path(path)
    if p.is_dir():
        if (p / "diagnosis.json").is_file():
            return "gap"
        raise InputError(f"{p}: a folder without diagnosis.json (reports read gap diagnosis folders)")
    if not p.is_file():
        raise InputError(f"file not found: {p}")
    if p.suffix == ".npz":
        try:
            z = np.load(p, allow_pickle=False)
            if not isinstance(z, np.lib.npyio.NpzFile):
                raise ValueError("a single array, not an .npz archive")
            with z:
                keys = set(z.files)
        except (OSError, ValueError, EOFError) as err:
            raise InputError(f"{p}: not a readable .npz file ({str(err).splitlines()[0]})") from None
        if {"A", "B", "C", "D"} <= keys:
            return "controller"
        return "predictor"
    ds = _load_nc(p)
    if "modal" in ds and "H" not in ds:
        return "modal"
    if "H" in ds:
        return "campaign"
    if "case" in ds.dims and "sensitivity" in ds:
        return "control_runs"
    raise InputError(f"{p}: not a campaign, modal, or control-run dataset (no H, modal or sensitivity)")


def report_of(path, *, data=None, runs=None, validation=None, posture: int = 0) -> Page:
    """The report page of one file.

    Parameters
    ----------
    path : path-like
        A campaign, modal fit, predictor, controller, control runs or gap diagnosis folder.
    data : path-like, optional
        For a modal fit: its campaign (default: the file named in its ``upstream`` attribute,
        when it exists).
    runs : path-like, optional
        For a controller: the runs ``rmbench control run --out`` wrote.
    validation : (TrainingSet, list of CVScores), optional
        For a predictor: its cross-validation (:func:`rmbench.predict.validate_predictor`).
    posture : int
        Posture of the stabilisation diagram (modal fits).
    """
    kind = kind_of(path)
    p = Path(path)
    if kind == "campaign":
        from rmbench.report.campaign import campaign_sections, dataset_meta

        ds = _load_nc(p)
        page = Page(f"Impact campaign {p.name}", dataset_meta(ds, p))
        campaign_sections(page, ds)
        return page
    if kind == "modal":
        from rmbench.report.campaign import campaign_sections, dataset_meta, modal_sections

        fit = _load_nc(p)
        src = data if data is not None else _upstream(fit, p)
        ds = _load_nc(src) if src is not None else None
        if ds is not None and not _same_postures(ds, fit):
            if data is not None:
                raise InputError(f"{src} is not the campaign of {p.name}: its postures differ from the fit's")
            ds = None                          # the upstream file changed since: the report goes without it
        if not 0 <= posture < fit.sizes["posture"]:
            raise InputError(f"posture {posture} is outside 0..{fit.sizes['posture'] - 1}")
        meta = dataset_meta(fit, p)
        if ds is not None:
            meta["campaign"] = str(src)
        page = Page(f"Modal fit {p.name}", meta)
        if ds is not None:
            campaign_sections(page, ds, fit=fit)
        modal_sections(page, fit, ds, stab_posture=posture)
        return page
    if kind == "predictor":
        from rmbench.predict import PosturePredictor
        from rmbench.report.predict import cv_sections, predictor_sections

        pred = PosturePredictor.load(p)
        page = Page(f"Posture predictor {p.name}", {"file": str(p), "learner": pred.model,
                                                    "trained on": f"{len(pred.X_train_)} postures",
                                                    "source": str(getattr(pred, "source_", ""))})
        predictor_sections(page, pred)
        if validation is not None:
            cv_sections(page, *validation)
        return page
    if kind == "controller":
        from rmbench.control import Controller
        from rmbench.report.control import control_sections

        k = Controller.load(p)
        page = Page(f"Controller {p.name}", {"file": str(p), "axes": ", ".join(k.axes), "order": k.order})
        control_sections(page, _split_runs(_load_nc(runs)) if runs is not None else None, controller=k)
        return page
    if kind == "control_runs":
        from rmbench.report.campaign import dataset_meta
        from rmbench.report.control import control_sections

        ds = _load_nc(p)
        page = Page(f"Suppression runs {p.name}", dataset_meta(ds, p))
        control_sections(page, _split_runs(ds))
        return page
    from rmbench.report.gap import gap_sections

    page = Page(f"Gap diagnosis {p.name}", {"folder": str(p)})
    gap_sections(page, p)
    return page


def _upstream(fit, path: Path):
    """The campaign a modal fit names as ``upstream``: as written, or beside the fit file."""
    up = str(fit.attrs.get("upstream") or "")
    if not up:
        return None
    for cand in (Path(up), path.parent / Path(up).name):
        if cand.is_file():
            return cand
    return None


def _same_postures(ds, fit) -> bool:
    if "posture" not in ds.dims or ds.sizes["posture"] != fit.sizes["posture"]:
        return False
    try:
        return all(np.allclose(ds[c].values, fit[c].values, atol=1e-9) for c in ("x", "y", "theta"))
    except (KeyError, ValueError, TypeError):
        return False


def _split_runs(ds) -> dict:
    if "case" not in ds.dims or "sensitivity" not in ds:
        raise InputError("control runs must have a 'case' dimension and 'sensitivity' (rmbench control run --out)")
    return {str(c): ds.sel(case=c) for c in ds.case.values}


def write_report(path, out, **kw) -> Path:
    """:func:`report_of` written to ``out`` (an ``.html`` file)."""
    out = Path(out)
    if out.suffix.lower() not in (".html", ".htm"):
        raise InputError(f"a report must be an .html file, got {out}")
    return report_of(path, **kw).write(out)
