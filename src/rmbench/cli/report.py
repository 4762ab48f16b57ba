"""``rmbench report``: one self-contained HTML report of a campaign, modal fit, predictor,
controller (or its runs), or gap diagnosis folder."""

from __future__ import annotations

from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    p = sub.add_parser("report", help="an interactive HTML report of a campaign, fit, predictor, controller or diagnosis")
    p.add_argument("path", help="campaign or modal netCDF, predictor or controller .npz, control runs netCDF, "
                                "or a gap diagnosis folder")
    p.add_argument("--out", required=True, help="HTML file to write")
    p.add_argument("--data", default=None,
                   help="modal fit: its campaign (default: the file it names as upstream); "
                        "predictor: the modal dataset it learnt, to cross-validate (GPs, rf and enet take minutes)")
    p.add_argument("--learners", default=None,
                   help="predictor with --data: learners to cross-validate, comma-separated "
                        "(default: the predictor's own and knn)")
    p.add_argument("--runs", default=None, help="controller: the runs 'rmbench control run --out' wrote")
    p.add_argument("--posture", type=int, default=0, help="modal fit: posture index of the stabilisation diagram")
    p.set_defaults(func=cmd_report)


def cmd_report(args) -> int:
    from rmbench.cli._common import report_path
    from rmbench.report.files import kind_of, write_report

    out = report_path(args, "--out")
    kind = kind_of(args.path)
    learners = None
    if args.learners:
        from rmbench.predict import LEARNERS

        learners = [s.strip() for s in args.learners.split(",") if s.strip()]
        bad = [s for s in learners if s not in LEARNERS]
        if bad:
            raise InputError(f"unknown learner {bad[0]!r}; choose from {', '.join(LEARNERS)}")
    for opt, kinds in (("data", ("modal", "predictor")), ("runs", ("controller",)), ("learners", ("predictor",))):
        if getattr(args, opt) is not None and kind not in kinds:
            raise InputError(f"--{opt} applies to {' or '.join(kinds)} reports, not to a {kind.replace('_', ' ')}")
    validation, data = None, args.data
    if kind == "predictor" and data is not None:
        from rmbench.cli._common import load_dataset
        from rmbench.predict import PosturePredictor, validate_predictor

        modal = load_dataset(data, "modal dataset")
        if "modal" not in modal:
            raise InputError(f"{data}: not a modal dataset (no 'modal'): --data must be what the predictor learnt")
        validation, data = validate_predictor(PosturePredictor.load(args.path), modal, learners), None
    path = write_report(args.path, out, data=data, runs=args.runs, validation=validation, posture=args.posture)
    print(f"wrote {path} ({kind.replace('_', ' ')} report, {path.stat().st_size / 1e6:.1f} MB)")
    return 0
