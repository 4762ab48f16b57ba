"""Options shared by several commands, and their conversion from UI units (mm, degrees) to SI."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rmbench.errors import InputError

__all__ = ["command_group", "add_robot_options", "load_robot", "resolve_posture", "print_json", "load_dataset",
           "add_report_option", "report_path", "read_test_design"]


def command_group(sub, name: str, help: str):
    """Add the command ``name`` with its own subcommands; returns their argparse subparsers.

    Given without a subcommand, the command prints its help and exits with 2.
    """
    p = sub.add_parser(name, help=help)
    p.set_defaults(func=lambda args: p.print_help() or 2)
    return p.add_subparsers(dest=f"{name}_command", metavar="SUBCOMMAND", parser_class=type(p))


def add_robot_options(p, *, posture: bool = True) -> None:
    p.add_argument("--robot", default="irb6660", help="bundled robot name or MJCF path (default irb6660)")
    p.add_argument("--tool", default=None,
                   help="bundled tool name (dummy, endmill) or tool MJCF path (default: the robot's own)")
    p.add_argument("--spindle-rpm", type=float, default=0.0,
                   help="spindle speed, rev/min (non-zero adds gyroscopic, non-reciprocal coupling)")
    if posture:
        p.add_argument("--posture", default=None,
                       help="x,y,theta in mm, mm, degrees (default: 1800,-200,0, or the robot's reference posture)")
        p.add_argument("--joints", default=None,
                       help="arm joint commands in degrees, comma-separated (instead of --posture)")


def add_report_option(p, what: str = "the results") -> None:
    p.add_argument("--report", default=None, metavar="HTML",
                   help=f"write {what} as one self-contained interactive HTML report")


def report_path(args, option: str = "--report"):
    """The ``--report`` file checked before any work starts (an .html file in an existing
    folder), or None."""
    r = getattr(args, option.lstrip("-").replace("-", "_"), None)
    if r is None:
        return None
    path = Path(r)
    if path.suffix.lower() not in (".html", ".htm"):
        raise InputError(f"{option} must name an .html file, got {r}")
    if not path.resolve().parent.is_dir():
        raise InputError(f"folder for {option} does not exist: {path.parent}")
    return path


def read_test_design(args) -> str | None:
    """Text of the ``--test`` campaign TOML (the test design), or None when not given."""
    if args.test is None:
        return None
    path = Path(args.test)
    if not path.is_file():
        raise InputError(f"test design file not found: {path}")
    return path.read_text()


def load_robot(args):
    from rmbench.robot import Robot

    return Robot.load(args.robot, tool=args.tool, spindle_rpm=args.spindle_rpm)


def resolve_posture(robot, args):
    """A Posture or a joint vector (rad) from --posture / --joints / the robot's defaults."""
    from rmbench.robot import parse_posture
    from rmbench.robot.spec import custom_numeric

    if args.posture and args.joints:
        raise InputError("give either --posture or --joints, not both")
    if args.joints:
        try:
            q = np.radians([float(v) for v in args.joints.split(",")])
        except ValueError:
            raise InputError(f"--joints must be numbers in degrees, got {args.joints!r}") from None
        if len(q) != len(robot.arm_joints):
            raise InputError(f"--joints needs {len(robot.arm_joints)} values, got {len(q)}")
        return q
    if args.posture:
        return parse_posture(args.posture)
    ref = custom_numeric(robot.spec, "rmbench_reference_q")
    return ref if ref is not None else robot.validation()[0]


def load_dataset(path, what: str = "dataset"):
    """A netCDF file read into memory, or a one-line error naming what is wrong with it."""
    import xarray as xr

    path = Path(path)
    if not path.is_file():
        raise InputError(f"{what} not found: {path}")
    try:
        return xr.load_dataset(path)
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: not a readable netCDF dataset ({err})") from None


def print_json(obj) -> None:
    """Print ``obj`` as one line of strict JSON (every command's ``--json``).

    numpy values become Python numbers and lists, NaN and ±inf become ``null``
    (:func:`rmbench.io.strict_json.strict_dumps`); a value JSON cannot hold (a complex number, an
    arbitrary object) raises ``TypeError`` rather than print something invalid.
    """
    from rmbench.io.strict_json import strict_dumps   # here: rmbench.io loads xarray and pyuff

    print(strict_dumps(obj))
