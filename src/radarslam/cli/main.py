"""``radarslam`` entry point: parse, call one library function, save the result.

Known errors (bad input, bad config, unwritable output) become one line on stderr and exit 1;
argparse usage errors exit 2.
"""

from __future__ import annotations

import argparse
import os
import sys

from radarslam import __version__
from radarslam.core.errors import RadarSlamError


def build_parser() -> argparse.ArgumentParser:
    from radarslam.cli import calibrate, dump_config, evaluate, montecarlo, recording, report, run

    p = argparse.ArgumentParser(prog="radarslam", description="Radar EKF-SLAM with extended landmarks.")
    p.add_argument("--version", action="version", version=f"radarslam {__version__}")
    sub = p.add_subparsers(dest="command", required=True)
    for mod in (run, evaluate, montecarlo, report, dump_config, calibrate):
        mod.add_parser(sub)
    recording.add_parsers(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run the CLI with ``argv`` (default ``sys.argv[1:]``); return the exit code."""
    parser = build_parser()
    args = parser.parse_args(argv)
    args.argv = list(sys.argv[1:] if argv is None else argv)      # what was asked, for the records
    try:
        return int(args.func(args) or 0)
    except RadarSlamError as exc:
        print(f"radarslam {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"radarslam {args.command}: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (radarslam ... | head): every result file is written; leave quietly.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0


#: LLVM's optimisation level of what a ``radarslam`` command compiles (numba's ``NUMBA_OPT``, whose own
#: default is 3), unless the environment sets one. Level 1 compiles the default family's fused engine
#: with about 22% less CPU and the same machine speed, the results equal to the last bit (docs/speed.md
#: "Optimisation level"). It is process-wide, so it is set here, for the command's own process and
#: those it starts, and not at ``import radarslam``, which leaves a program's own numba code alone.
COMPILE_OPT = "1"


def entry_point() -> None:  # pragma: no cover - thin wrapper
    os.environ.setdefault("NUMBA_OPT", COMPILE_OPT)      # before anything imports numba
    sys.exit(main())
