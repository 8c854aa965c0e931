"""``radarslam montecarlo`` and ``radarslam reproduce``: the seed paper's Monte Carlo."""

from __future__ import annotations

import argparse
import os
import sys

from radarslam.cli.common import add_backend_arg, add_config_args, config_from_args, with_backend
from radarslam.config import profile_config, validate
from radarslam.core.errors import InputError
from radarslam.io.results import prepare_out_dir


def _add_exec_args(p: argparse.ArgumentParser, default_jobs: int) -> None:
    p.add_argument("--seed", type=int, default=1, help="master seed S; trial t uses SeedSequence(S).spawn(N)[t-1]")
    p.add_argument("--jobs", "-j", type=int, default=default_jobs, help=f"local worker processes (default {default_jobs})")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run the trials on this Dask distributed scheduler")
    g.add_argument("--dask-local", type=int, metavar="N", help="start a local Dask cluster of N worker processes")
    p.add_argument("--no-report", action="store_true", help="do not write the report at the end")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_backend_arg(p)


def add_parser(sub) -> None:
    p = sub.add_parser("montecarlo", help="run (or resume) N Monte Carlo trials, No extent and With extent on the same data")
    p.add_argument("--trials", "-n", type=int, required=True, help="number of trials N")
    add_config_args(p)
    p.add_argument("--out", required=True, metavar="DIR", help="result directory (created; rerun to resume)")
    _add_exec_args(p, 1)
    p.set_defaults(func=run_montecarlo_cmd)

    r = sub.add_parser("reproduce", help="the seed paper's experiment: montecarlo + report with the paper's settings")
    r.add_argument("--trials", "-n", type=int, default=1000, help="number of trials (default 1000, as in the paper)")
    r.add_argument("--out", default="out/reproduce", metavar="DIR", help="result directory (default out/reproduce)")
    _add_exec_args(r, os.cpu_count() or 1)
    r.set_defaults(func=run_reproduce_cmd)


def _execute(config, args) -> int:
    from radarslam.experiments.montecarlo import run_montecarlo

    if args.seed < 0:
        raise InputError(f"--seed: expected an integer >= 0, got {args.seed}")
    out = prepare_out_dir(args.out)
    try:
        summary = run_montecarlo(config, args.seed, args.trials, out, jobs=args.jobs, scheduler=args.scheduler,
                                 dask_local=args.dask_local, progress=not args.quiet)
    except KeyboardInterrupt:
        from radarslam.experiments.store import TrialStore

        n = len(TrialStore.read(out).stored())
        print(f"\nradarslam: interrupted; {n} finished trials are stored in {out}; rerun the same command to resume",
              file=sys.stderr)
        return 130
    print(f"montecarlo: {summary.n_trials} trials in {out} ({summary.computed} computed, {summary.resumed} resumed, "
          f"{summary.recomputed_corrupt} corrupt recomputed) in {summary.seconds:.1f} s", file=sys.stderr)
    if not args.no_report:
        from radarslam.experiments.report import write_report

        rep = write_report(out)
        print((out / "report" / "report.md").read_text())
        print(f"figures and tables: {out / 'report'}/", file=sys.stderr)
        del rep
    return 0


def run_montecarlo_cmd(args: argparse.Namespace) -> int:
    return _execute(config_from_args(args), args)


def run_reproduce_cmd(args: argparse.Namespace) -> int:
    # The paper's settings: the default (apsipa, APSIPA Table I) profile, seed Section 4 extents.
    return _execute(with_backend(validate(profile_config("apsipa")), args), args)
