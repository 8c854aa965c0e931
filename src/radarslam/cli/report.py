"""``radarslam report DIR``: tables, curves and figures of a Monte Carlo directory."""

from __future__ import annotations

import argparse
from pathlib import Path

from radarslam.core.errors import InputError


def add_parser(sub) -> None:
    p = sub.add_parser("report", help="write the Monte Carlo report (Table 1, Fig. 3, Table II, NEES) into DIR/report/")
    p.add_argument("dir", metavar="DIR", help="a directory written by 'radarslam montecarlo'")
    p.add_argument("--overwrite", action="store_true", help="replace the report already in DIR/report/")
    p.add_argument("--bootstrap", type=int, default=2000, metavar="N",
                   help="bootstrap resamples for the Table 1 confidence intervals (default 2000)")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    from radarslam.montecarlo.report import write_report

    if args.bootstrap < 1:
        raise InputError(f"--bootstrap: expected an integer >= 1, got {args.bootstrap}")
    from radarslam.io.results import refuse_finished

    refuse_finished(Path(args.dir) / "report" / "report.md", "DIR", args.overwrite)
    write_report(args.dir, n_boot=args.bootstrap)
    print((Path(args.dir) / "report" / "report.md").read_text(encoding="utf-8"), end="")
    return 0
