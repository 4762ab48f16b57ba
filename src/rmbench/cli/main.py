"""Entry point: argument parsing, dispatch, and one-line errors with exit code 2."""

from __future__ import annotations

import argparse
import os
import sys

from rmbench._version import __version__
from rmbench.errors import RmbenchError
from rmbench.threads import limit_threads, process_threads

__all__ = ["main", "build_parser"]


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage problem as one line and exit code 2."""

    def error(self, message):
        self.exit(2, f"rmbench: error: {message} (see '{self.prog} --help')\n")


def build_parser() -> argparse.ArgumentParser:
    from rmbench.cli import campaign, control, demo, gap, lobes, modal, model, path, predict, rcsa, report, tracker

    parser = _Parser(prog="rmbench", description="Virtual test bench for robotic machining dynamics.")
    parser.add_argument("--version", action="version", version=f"rmbench {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of errors")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    model.register(sub)
    campaign.register(sub)
    modal.register(sub)
    predict.register(sub)
    rcsa.register(sub)
    lobes.register(sub)
    lobes.register_mill(sub)
    tracker.register(sub)
    control.register(sub)
    gap.register(sub)
    path.register(sub)
    report.register(sub)
    demo.register(sub)
    return parser


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"rmbench: warning: {message}\n"


def main(argv=None) -> int:
    import warnings

    warnings.formatwarning = _one_line_warning   # the command line's warnings: one line each
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        # this process's BLAS/OpenMP/torch pools, and its workers', within their share of the cores
        limit_threads(process_threads())
        return int(args.func(args) or 0)
    except RmbenchError as err:
        if args.debug or os.environ.get("RMBENCH_DEBUG"):
            raise
        print(f"rmbench: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("rmbench: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # output piped into `head` and the like
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0


if __name__ == "__main__":
    sys.exit(main())
