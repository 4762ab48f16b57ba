"""``rmbench campaign run|export|import|plot``."""

from __future__ import annotations

from pathlib import Path

from rmbench.cli._common import add_report_option, command_group, print_json, report_path
from rmbench.errors import InputError

__all__ = ["register"]


def register(sub) -> None:
    csub = command_group(sub, "campaign", "virtual impact campaigns: FRF matrices across postures")
    run = csub.add_parser("run", help="run a campaign from a TOML config (resumable)")
    run.add_argument("config", help="TOML file, or a bundled config name (seed_full, demo, tool_calibration, ...)")
    run.add_argument("--out", required=False, help="dataset file to write (netCDF)")
    run.add_argument("--workers", type=int, default=None, help="local worker processes (default: all cores; 0: in this process)")
    run.add_argument("--scheduler", default=None, help="address of an existing dask scheduler")
    run.add_argument("--method", choices=("time", "linear"), default=None, help="override the config's method")
    run.add_argument("--robot", default=None, help="override the config's robot (name or MJCF path)")
    run.add_argument("--tool", default=None, help="override the config's tool (bundled name or MJCF path)")
    run.add_argument("--commands-from", default=None, metavar="NOMINAL",
                     help="command each posture with the rigid-body IK of this nominal robot (name or MJCF "
                          "path), as a real controller would, then settle the robot under test there")
    run.add_argument("--force", action="store_true",
                     help="simulate every posture again even if --out is a finished run of this config")
    run.add_argument("--dry-run", action="store_true", help="validate and estimate, run nothing")
    run.add_argument("--no-progress", action="store_true", help="no progress bar")
    run.add_argument("--json", action="store_true", help="print a JSON summary")
    run.set_defaults(func=cmd_run)

    exp = csub.add_parser("export", help="write a dataset's FRFs as UFF58 files")
    exp.add_argument("data")
    exp.add_argument("--uff", required=True, help="directory for the UFF58 files")
    exp.add_argument("--binary", action="store_true", help="binary UFF58b (exact) instead of ASCII")
    exp.set_defaults(func=cmd_export)

    imp = csub.add_parser("import", help="make a dataset from UFF58 files (e.g. a real test)")
    imp.add_argument("dir")
    imp.add_argument("--out", required=True)
    imp.add_argument("--node-map", default=None, metavar="N:1,M:1a",
                     help="map the file's node numbers to points 1 and 1a, e.g. 101:1,102:1a")
    imp.set_defaults(func=cmd_import)

    plot = csub.add_parser("plot", help="measured vs exact FRF matrix of one posture")
    plot.add_argument("data")
    where = plot.add_mutually_exclusive_group(required=True)
    where.add_argument("--posture", help="x,y,theta in mm, mm, degrees")
    where.add_argument("--index", type=int, help="posture position in the dataset")
    plot.add_argument("--band", choices=("low", "high"), default=None)
    plot.add_argument("--out", default=None, help="PNG file")
    add_report_option(plot, "the whole campaign (this posture shown first)")
    plot.set_defaults(func=cmd_plot)


def cmd_run(args) -> int:
    from rmbench.impact import dry_run, load_config, run_campaign

    cfg = load_config(args.config)
    path = Path(args.config)
    toml = path.read_text() if path.is_file() else ""
    overrides = {}
    if args.method:
        overrides["method"] = args.method
    if args.robot:
        overrides["robot_name"] = args.robot
    if args.tool:
        overrides["robot_tool"] = args.tool
    if args.commands_from:
        overrides["robot_commands_from"] = args.commands_from
    if overrides:
        cfg = cfg.with_overrides(**overrides)
    if args.workers is not None and args.workers < 0:
        raise InputError(f"--workers must be >= 0, got {args.workers}")
    if args.dry_run:
        est = dry_run(cfg)
        if args.json:
            print_json(est)
            return 0
        print(f"campaign {cfg.name!r}: {est['n_postures']} postures, method {cfg.method}")
        for label in est["postures"]:
            print(f"  {label}")
        for band, b in est["bands"].items():
            extra = f", dt {b['dt'] * 1e6:.2f} us, {b['steps_per_s']:.0f} steps/s" if "dt" in b else ""
            print(f"  {band} band: {b['steps_per_posture']} steps per posture{extra}")
        workers = args.workers or __import__("os").cpu_count() or 1
        print(f"  steps to simulate: {est['steps_total']}; estimated time "
              f"{est['estimated_core_seconds'] / max(workers, 1):.0f} s on {workers} workers")
        return 0
    if not args.out:
        raise InputError("--out is required (the dataset file to write)")
    from rmbench.impact import CampaignSummary, is_complete

    kept = not args.force and is_complete(cfg, args.out)
    out = run_campaign(cfg, args.out, toml=toml, workers=args.workers, scheduler=args.scheduler,
                       progress=not args.no_progress, force=args.force)
    summary = CampaignSummary.load(out, kept=kept)
    if args.json:
        print_json(summary.to_dict())
    else:
        print(summary.summary())
    return 0


def cmd_export(args) -> int:
    from rmbench.impact import open_campaign
    from rmbench.io import write_uff58

    ds = open_campaign(args.data)
    files = write_uff58(ds[["H"]].assign_attrs(ds.attrs), args.uff, binary=args.binary)
    print(f"wrote {len(files)} files to {args.uff}")
    return 0


def cmd_import(args) -> int:
    from rmbench.impact.dataset import DATASET_VERSION, save
    from rmbench.io import read_uff58

    node_map = None
    if args.node_map:
        node_map = {}
        for item in args.node_map.split(","):
            try:
                node, point = item.split(":")
                node_map[int(node)] = point
            except ValueError:
                raise InputError(f"--node-map must look like 101:1,102:1a, got {args.node_map!r}") from None
    ds = read_uff58(args.dir, node_map=node_map)
    ds.attrs.setdefault("rmbench_dataset_version", DATASET_VERSION)
    ds.attrs["rmbench_dataset_version"] = DATASET_VERSION
    ds.attrs["upstream"] = str(args.dir)
    save(ds, args.out)
    print(f"wrote {args.out}: {ds.sizes['posture']} postures, {ds.sizes['freq']} lines (no ground truth)")
    return 0


def cmd_plot(args) -> int:
    from rmbench.impact import open_campaign
    from rmbench.impact.dataset import find_posture
    from rmbench.impact.plot import plot_frf_matrix
    from rmbench.robot import parse_posture

    report = report_path(args)
    if args.out is None and report is None:
        raise InputError("give --out PNG, --report HTML, or both")
    ds = open_campaign(args.data)
    if args.index is not None:
        if not 0 <= args.index < ds.sizes["posture"]:
            raise InputError(f"--index {args.index} is outside 0..{ds.sizes['posture'] - 1}")
        index = args.index
    else:
        index = find_posture(ds, parse_posture(args.posture))
        if index is None:
            raise InputError(f"posture {args.posture} is not in {args.data}")
    if not bool(ds.ok.values[index]):
        raise InputError(f"posture {index} failed in this campaign: {ds.reason.values[index]}")
    if args.out:
        plot_frf_matrix(ds, index, args.out, band=args.band)
        print(f"wrote {args.out}")
    if report:
        from rmbench.report import Page, campaign_sections, dataset_meta

        page = Page(f"Impact campaign {Path(args.data).name}", dataset_meta(ds, args.data))
        campaign_sections(page, ds, start=index)
        print(f"wrote {page.write(report)}")
    return 0


