"""``rmbench predict``: posture-dependent modal parameters — cross-validate, train, predict, plot."""

from __future__ import annotations

from pathlib import Path

from rmbench.cli._common import add_report_option, command_group, load_dataset, print_json, report_path
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    from rmbench.predict import LEARNERS, SAVEABLE

    g = command_group(sub, "predict", "posture-dependent modal parameters: learners, scores, predictions")
    cv = g.add_parser("cv", help="cross-validated R² of a learner on every modal parameter")
    cv.add_argument("modal", help="modal dataset (netCDF) from `rmbench modal fit`")
    cv.add_argument("--model", choices=LEARNERS, default="mtgp-grouped",
                    help="seed's grouped multi-task GPs, one Kronecker MTGP of all parameters (and "
                         "low rank), single-task GPs, inverse-distance k-NN, random forest, gradient "
                         "boosting, elastic net (default mtgp-grouped)")
    cv.add_argument("--folds", type=int, default=5, help="folds of the random split (default 5)")
    cv.add_argument("--split", choices=("random", "angle"), default="random",
                    help="random folds, or every posture of one redundant angle held out per fold")
    cv.add_argument("--seed", type=int, default=0)
    cv.add_argument("--json", action="store_true", help="print the scores as JSON")
    cv.add_argument("--order", choices=("frequency", "tracked"), default="frequency",
                    help="learn each band's modes in order of frequency (default), or as tracked")
    add_report_option(cv, "the out-of-fold scatter, residuals and R² per parameter")
    cv.set_defaults(func=cmd_cv)

    tr = g.add_parser("train", help="learn every modal parameter over the posture; save the predictor")
    tr.add_argument("modal", help="modal dataset (netCDF) from `rmbench modal fit`")
    tr.add_argument("--model", choices=SAVEABLE, default="mtgp-grouped")
    tr.add_argument("--out", required=True, help="predictor file (.npz: arrays and JSON, no pickle)")
    tr.add_argument("--order", choices=("frequency", "tracked"), default="frequency",
                    help="learn each band's modes in order of frequency (default), or as tracked")
    tr.add_argument("--vectors", choices=("gauge", "dataset"), default="gauge",
                    help="learn the mode vectors in a gauge per mode (default: no near-zero element "
                         "is divided by) or as the modal stage normalised them")
    tr.add_argument("--clusters", choices=("auto", "none"), default="auto",
                    help="also learn veering modes as clusters, for the FRF (default), or every "
                         "mode alone")
    tr.set_defaults(func=cmd_train)

    at = g.add_parser("at", help="modal parameters (and FRF matrix) predicted at a posture")
    at.add_argument("predictor", help="file from `rmbench predict train`")
    at.add_argument("--posture", required=True, action="append",
                    help="x,y,theta in mm, mm, degrees (repeat for several)")
    at.add_argument("--frf", help="also write the FRF matrices rebuilt from the parameters (netCDF)")
    at.add_argument("--json", action="store_true",
                    help="print the parameters as JSON (a parameter the predictor has no value for, "
                         "e.g. of a mode found at too few training postures, is null and listed in "
                         "its mode's not_predicted)")
    at.set_defaults(func=cmd_at)

    pl = g.add_parser("plot", help="cross-validation scatter and residuals; parameter maps")
    pl.add_argument("modal", help="modal dataset (netCDF) from `rmbench modal fit`")
    pl.add_argument("--model", choices=LEARNERS, default="mtgp-grouped")
    pl.add_argument("--predictor", help="also draw parameter maps over the workspace from this predictor")
    pl.add_argument("--mode", type=int, default=0, help="mode of the maps (default 0)")
    pl.add_argument("--out", default=None, help="output folder for the figures")
    pl.add_argument("--order", choices=("frequency", "tracked"), default="frequency",
                    help="learn each band's modes in order of frequency (default), or as tracked")
    add_report_option(pl, "the cross-validation and (with --predictor) the maps of every mode")
    pl.set_defaults(func=cmd_plot)


def _modal(args):
    from rmbench.predict.data import frequency_ordered

    ds = _open_modal(args.modal)
    return frequency_ordered(ds) if args.order == "frequency" and "modal" in ds else ds


def _open_modal(path):
    return load_dataset(path, "modal dataset")


def cmd_cv(args) -> int:
    from rmbench.predict import cross_validate, training_set

    report = report_path(args)
    ts = training_set(_modal(args))
    res = cross_validate(ts, args.model, folds=args.folds, split=args.split, seed=args.seed)
    if report:
        from rmbench.report import Page
        from rmbench.report.predict import cv_sections

        page = Page(f"Cross-validation of {args.model} on {Path(args.modal).name}",
                    {"modal dataset": args.modal, "learner": args.model, "split": args.split, "folds": args.folds,
                     "seed": args.seed})
        cv_sections(page, ts, [res])
        page.write(report)
        if not args.json:
            print(f"wrote {report}")
    if args.json:
        print_json(res.to_dict())
        return 0
    print(res.summary())
    return 0


def cmd_train(args) -> int:
    from rmbench.predict import PosturePredictor

    out = Path(args.out)
    if not out.parent.is_dir():
        raise InputError(f"output folder does not exist: {out.parent}")
    pred = PosturePredictor(args.model, args.order, args.vectors, args.clusters).fit(_open_modal(args.modal))
    pred.save(out)
    lr = pred.learner_
    note = ""
    if getattr(lr, "jitter_added_", 0.0) > 0:
        note = f"; covariance needed jitter up to {lr.jitter_added_:.0e} (retried {lr.retries_} times)"
    dropped = getattr(lr, "dropped_", 0)
    if dropped:
        note += f"; {dropped} postures left out of some models (a mode not found there)"
    if pred.clusters_:
        note += "; veering clusters " + ", ".join("modes " + "-".join(map(str, c.modes)) for c in pred.clusters_)
    print(f"{args.model}: {len(pred.live_)} parameters from {len(pred.X_train_)} postures in "
          f"{pred.train_seconds_:.1f} s{note}; wrote {out}")
    return 0


def cmd_at(args) -> int:
    import warnings

    import numpy as np

    from rmbench.predict import ExtrapolationWarning, PosturePredictor, predicted_frf_dataset
    from rmbench.robot import parse_posture

    pred = PosturePredictor.load(args.predictor)
    postures = [parse_posture(p) for p in args.posture]
    X = np.array([[p.x, p.y, p.theta] for p in postures])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ExtrapolationWarning)
        out = pred.predict(X)
    notes = [str(w.message) for w in caught if issubclass(w.category, ExtrapolationWarning)]
    if args.frf:
        from rmbench.impact.dataset import save

        save(predicted_frf_dataset(out, model=pred.model, source=str(args.predictor)), args.frf)
    if args.json:
        print_json({"model": pred.model, "warnings": notes, "postures": [
            {"x_mm": 1e3 * x[0], "y_mm": 1e3 * x[1], "theta_deg": float(np.degrees(x[2])),
             "outside_hull": bool(out.outside_hull.values[i]),
             "modes": [{"mode": int(m), "band": str(out.mode_band.values[k]),
                        "params": {str(p): float(out.modal.values[i, k, j])
                                   for j, p in enumerate(out.param.values)},
                        "std": {str(p): float(out.modal_std.values[i, k, j])
                                for j, p in enumerate(out.param.values)},
                        "not_predicted": [str(p) for j, p in enumerate(out.param.values)
                                          if not np.isfinite(out.modal.values[i, k, j])]}
                       for k, m in enumerate(out.mode.values)]}
            for i, x in enumerate(X)], "frf": args.frf})
        return 0
    for w in notes:
        print(f"warning: {w}")
    has_fz = {"f_n", "zeta"} <= set(out.param.values)
    for i, x in enumerate(X):
        print(f"posture ({1e3 * x[0]:.0f} mm, {1e3 * x[1]:.0f} mm, {np.degrees(x[2]):.0f}°)"
              + ("  [outside the training hull]" if out.outside_hull.values[i] else ""))
        if not has_fz:
            continue
        for k, m in enumerate(out.mode.values):
            f, fs = out.modal.sel(param="f_n").values[i, k], out.modal_std.sel(param="f_n").values[i, k]
            z, zs = out.modal.sel(param="zeta").values[i, k], out.modal_std.sel(param="zeta").values[i, k]
            print(f"  mode {int(m)} ({out.mode_band.values[k]}): f_n {f:8.3f} ± {fs:.3f} Hz, "
                  f"ζ {100 * z:6.3f} ± {100 * zs:.3f} %")
    if args.frf:
        print(f"wrote {args.frf} (H, m/N, rebuilt from the predicted parameters)")
    return 0


def cmd_plot(args) -> int:
    from rmbench.predict import PosturePredictor, cross_validate, training_set
    from rmbench.predict.plot import plot_cv, plot_maps

    report = report_path(args)
    if args.out is None and report is None:
        raise InputError("give --out FOLDER, --report HTML, or both")
    pred = PosturePredictor.load(args.predictor) if args.predictor else None
    if pred is not None and args.mode not in pred.modes_:
        raise InputError(f"no mode {args.mode} in the predictor (modes {list(pred.modes_)})")
    ts = training_set(_modal(args))
    cv = cross_validate(ts, args.model)
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        print(f"wrote {plot_cv(ts, cv, out / f'cv_{args.model}.png')}")
        if pred is not None:
            print(f"wrote {plot_maps(pred, out / f'map_mode{args.mode}_f_n.png', mode=args.mode)}")
    if report:
        from rmbench.report import Page
        from rmbench.report.predict import cv_sections, predictor_sections

        page = Page(f"Posture prediction on {Path(args.modal).name}",
                    {"modal dataset": args.modal, "learner": args.model, "predictor": args.predictor or ""})
        if pred is not None:
            predictor_sections(page, pred)
        cv_sections(page, ts, [cv])
        print(f"wrote {page.write(report)}")
    return 0
