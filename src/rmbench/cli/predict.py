"""``rmbench predict cv``: cross-validated accuracy of the posture predictors (issue 15, in progress)."""

from __future__ import annotations

from pathlib import Path

from rmbench.cli._common import command_group, print_json
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    from rmbench.predict import LEARNERS

    g = command_group(sub, "predict", "posture-dependent modal parameters: learners and their scores")
    cv = g.add_parser("cv", help="cross-validated R² of a learner on every modal parameter")
    cv.add_argument("modal", help="modal dataset (netCDF) from `rmbench modal fit`")
    cv.add_argument("--model", choices=LEARNERS, default="knn",
                    help="learner: inverse-distance k-NN, random forest, gradient boosting, elastic net")
    cv.add_argument("--folds", type=int, default=5, help="folds of the random split (default 5)")
    cv.add_argument("--split", choices=("random", "angle"), default="random",
                    help="random folds, or every posture of one redundant angle held out per fold")
    cv.add_argument("--seed", type=int, default=0)
    cv.add_argument("--json", action="store_true", help="print the scores as JSON")
    cv.set_defaults(func=cmd_cv)


def cmd_cv(args) -> int:
    import numpy as np
    import xarray as xr

    from rmbench.predict import cross_validate, training_set

    path = Path(args.modal)
    if not path.is_file():
        raise InputError(f"modal dataset not found: {path}")
    try:
        ds = xr.open_dataset(path)
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: not a readable netCDF dataset ({err})") from None
    with ds:
        ts = training_set(ds)
    res = cross_validate(ts, args.model, folds=args.folds, split=args.split, seed=args.seed)
    if args.json:
        print_json(res.to_dict())
        return 0
    ok = np.isfinite(res.r2_mean)
    print(f"{args.model}, {args.split} split: mean R² {np.mean(res.r2_mean[ok]):.3f} over "
          f"{int(ok.sum())} parameters (mean spread over folds {np.mean(res.r2_std[ok]):.3f}); "
          f"{len(res.skipped)} skipped")
    worst = np.argsort(np.where(ok, res.r2_mean, np.inf))[:5]
    for t in worst:
        if ok[t]:
            print(f"  {res.tasks[t]}: R² {res.r2_mean[t]:.3f} ± {res.r2_std[t]:.3f}")
    for task, why in list(res.skipped.items())[:5]:
        print(f"  skipped {task}: {why}")
    if res.notes:
        print(f"  {len(res.notes)} parameters' fits needed jitter, e.g. {next(iter(res.notes))}: "
              f"{next(iter(res.notes.values()))}")
    return 0
