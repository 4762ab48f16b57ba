"""``rmbench modal fit`` and ``rmbench modal plot``."""

from __future__ import annotations

from pathlib import Path

from rmbench.cli._common import add_report_option, command_group, print_json, report_path
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    msub = command_group(sub, "modal", "MDOF modal fitting of measured FRF matrices")
    fit = msub.add_parser("fit", help="fit all 16 FRFs per band with shared poles and left/right eigenvectors")
    fit.add_argument("data", help="campaign dataset (netCDF) or a directory of UFF58 files")
    fit.add_argument("--out", default=None, help="modal dataset to write (netCDF)")
    fit.add_argument("--band", choices=("low", "high", "both"), default="both")
    fit.add_argument("--modes", type=int, default=None, help="modes per band (default: chosen by the data)")
    fit.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores; 0: here)")
    fit.add_argument("--csv", default=None, help="also write the parameters as CSV")
    fit.add_argument("--uff", default=None, help="also write UFF55 modal files into this directory")
    fit.add_argument("--json", action="store_true", help="print the modes as JSON (one posture: its modes)")
    add_report_option(fit, "the campaign with the fitted overlays, parameter maps and a stabilisation diagram")
    fit.set_defaults(func=cmd_fit)

    plot = msub.add_parser("plot", help="stabilisation diagram and measured vs fitted FRF matrix of one posture")
    plot.add_argument("data", help="campaign dataset or UFF58 directory")
    plot.add_argument("--index", type=int, default=0, help="posture position")
    plot.add_argument("--band", choices=("low", "high"), default="high")
    plot.add_argument("--out", default=None, help="PNG file (the FRF matrix goes beside it, *_frf.png)")
    add_report_option(plot, "the campaign and the stabilisation diagrams of this posture")
    plot.set_defaults(func=cmd_plot)


def _load(path: str):
    from rmbench.impact import open_campaign

    p = Path(path)
    if p.is_dir():
        from rmbench.io import read_uff58

        ds = read_uff58(p)
        ds.attrs["source_file"] = str(p)
        return ds
    ds = open_campaign(p)
    ds.attrs["source_file"] = str(p)
    return ds


def cmd_fit(args) -> int:
    from rmbench.impact.dataset import save
    from rmbench.modal.campaign_fit import fit_campaign
    from rmbench.modal.campaign_result import CampaignFit

    if args.modes is not None and args.modes < 1:
        raise InputError(f"--modes must be at least 1, got {args.modes}")
    report = report_path(args)
    ds = _load(args.data)
    bands = ("low", "high") if args.band == "both" else (args.band,)
    res = fit_campaign(ds, bands=bands, n_modes=args.modes, workers=args.workers)
    if args.out:
        save(res, args.out)
    if args.csv or args.uff:
        from rmbench.io import write_modal_csv, write_uff55

        if args.csv:
            write_modal_csv(res, args.csv)
        if args.uff:
            write_uff55(res, args.uff)
    if report:
        from rmbench.report import Page, campaign_sections, dataset_meta, modal_sections

        page = Page(f"Modal fit of {Path(args.data).name}", {**dataset_meta(res, args.out), "campaign": args.data})
        campaign_sections(page, ds, fit=res)
        modal_sections(page, res, ds)
        page.write(report)
    account = CampaignFit(res)
    if args.json:
        print_json(account.to_dict())
        return 0
    print(account.summary(bands))
    if args.out:
        print(f"wrote {args.out}")
    if report:
        print(f"wrote {report}")
    return 0


def cmd_plot(args) -> int:
    import warnings

    from rmbench.modal import ModalFit, ModalFitWarning
    from rmbench.modal.plot import plot_fit

    report = report_path(args)
    if args.out is None and report is None:
        raise InputError("give --out PNG, --report HTML, or both")
    ds = _load(args.data)
    if not 0 <= args.index < ds.sizes["posture"]:
        raise InputError(f"--index {args.index} is outside 0..{ds.sizes['posture'] - 1}")
    sel = ds.band.values == args.band
    if not sel.any():
        raise InputError(f"no {args.band}-band lines in {args.data}")
    freq = ds.freq.values[sel]
    h = ds.H.values[args.index][sel]
    coh = ds.coherence.values[args.index][sel] if "coherence" in ds else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModalFitWarning)   # the verdict is printed below
        fit = ModalFit().fit(freq, h, coherence=coh)
    if args.out:
        out = Path(args.out)
        plot_fit(fit, freq, h, out, out.with_name(out.stem + "_frf.png"))
    print(fit.summary())
    if args.out:
        print(f"wrote {out} and {out.with_name(out.stem + '_frf.png')}")
    if report:
        from rmbench.report import Page, campaign_sections, dataset_meta
        from rmbench.report.campaign import stabilisation_section

        page = Page(f"Campaign {Path(args.data).name}, posture {args.index}", dataset_meta(ds, args.data))
        stabilisation_section(page, ds, args.index)
        campaign_sections(page, ds, start=args.index)
        print(f"wrote {page.write(report)}")
    return 0
