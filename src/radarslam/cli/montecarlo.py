"""``radarslam montecarlo`` and ``radarslam reproduce``: the seed paper's Monte Carlo, over named variants."""

from __future__ import annotations

import argparse
import os
import sys

from radarslam.cli.common import add_backend_arg, add_config_args, config_from_args, with_backend
from radarslam.config import profile_config, validate
from radarslam.core.errors import InputError
from radarslam.io.results import prepare_out_dir


VARIANT_HELP = """\
variants:
  Every trial simulates one car park and runs each variant on that same data. The
  default variants are 'noext' (No extent: extent.use_in_slam = false, the baseline)
  and 'ext' (With extent: extent.use_in_slam = true). Each --variant NAME=FILE.toml
  appends one more: NAME matches [a-z0-9][a-z0-9_-]*, FILE.toml is an overlay over
  the run's configuration (any section except trajectory, odometer, radar, world and
  profile, which define the shared simulated data) with an optional top-level
  label = "..." (default NAME). Example, FILE.toml:

      label = "With extent, no contour sifting"
      [extent]
      use_in_slam = true
      contour_sifting = false

  The report gives every variant its own column, curve and legend entry, and the
  paired change of each against the first. A result directory is bound to its list of
  variants: resuming it with another list is refused.
"""


def _add_exec_args(p: argparse.ArgumentParser, default_jobs: int) -> None:
    p.add_argument("--variant", action="append", default=[], metavar="NAME=FILE.toml",
                   help="add a variant: a configuration overlay run on the same data (repeatable; see below)")
    p.add_argument("--seed", type=int, default=1, help="master seed S; trial t uses SeedSequence(S).spawn(N)[t-1]")
    p.add_argument("--jobs", "-j", type=int, default=default_jobs, help=f"local worker processes (default {default_jobs})")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run the trials on this Dask distributed scheduler")
    g.add_argument("--dask-local", type=int, metavar="N", help="start a local Dask cluster of N worker processes")
    p.add_argument("--no-report", action="store_true", help="do not write the report at the end")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_backend_arg(p)


def add_parser(sub) -> None:
    p = sub.add_parser("montecarlo", help="run (or resume) N Monte Carlo trials, every variant on the same data",
                       epilog=VARIANT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--trials", "-n", type=int, required=True, help="number of trials N")
    add_config_args(p)
    p.add_argument("--out", required=True, metavar="DIR", help="result directory (created; rerun to resume)")
    _add_exec_args(p, 1)
    p.set_defaults(func=run_montecarlo_cmd)

    r = sub.add_parser("reproduce", help="the seed paper's experiment: montecarlo + report with the paper's settings",
                       epilog=VARIANT_HELP, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("--trials", "-n", type=int, default=1000, help="number of trials (default 1000, as in the paper)")
    r.add_argument("--out", default="out/reproduce", metavar="DIR", help="result directory (default out/reproduce)")
    r.add_argument("--study", choices=("paper", "partial-view"), default="paper",
                   help="paper: Table 1, Figs. 2-3 (default); partial-view: the Monte Carlo under the surface, "
                        "visible-faces and scatter-centres radar models side by side (docs/method.md a.12), "
                        "a directory per model and DIR/partial_view_study.md")
    _add_exec_args(r, os.cpu_count() or 1)
    r.set_defaults(func=run_reproduce_cmd)


def variants_from_args(args: argparse.Namespace) -> tuple:
    """The default variants followed by every ``--variant NAME=FILE.toml``, names unique."""
    from radarslam.config.variants import DEFAULT_VARIANTS, check_variants, parse_variant_arg

    return check_variants(DEFAULT_VARIANTS + tuple(parse_variant_arg(a) for a in args.variant), what="--variant")


def _execute(config, args) -> int:
    from radarslam.montecarlo.trials import run_montecarlo
    from radarslam.config.variants import apply_variant

    if args.seed < 0:
        raise InputError(f"--seed: expected an integer >= 0, got {args.seed}")
    if args.trials < 1:   # checked here too, so that an argument error leaves no directory behind
        raise InputError(f"--trials: expected an integer >= 1, got {args.trials}")
    if args.jobs < 1:
        raise InputError(f"--jobs: expected an integer >= 1, got {args.jobs}")
    variants = variants_from_args(args)
    from radarslam.simulation.trial import check_simulation_config

    for v in variants:  # an unknown overlay key fails before the directory is created
        check_simulation_config(apply_variant(config, v))
    out = prepare_out_dir(args.out)
    try:
        summary = run_montecarlo(config, args.seed, args.trials, out, jobs=args.jobs, scheduler=args.scheduler,
                                 dask_local=args.dask_local, progress=not args.quiet, variants=variants)
    except KeyboardInterrupt:
        from radarslam.montecarlo.store import TrialStore

        n = len(TrialStore.read(out).stored())
        print(f"\nradarslam: interrupted; {n} finished trials are stored in {out}; rerun the same command to resume",
              file=sys.stderr)
        return 130
    print(f"montecarlo: {summary.n_trials} trials in {out} ({summary.computed} computed, {summary.resumed} resumed, "
          f"{summary.recomputed_corrupt} corrupt recomputed) in {summary.seconds:.1f} s", file=sys.stderr)
    if not args.no_report:
        from radarslam.montecarlo.report import write_report

        rep = write_report(out)
        print((out / "report" / "report.md").read_text(encoding="utf-8"), end="")
        print(f"figures and tables: {out / 'report'}/", file=sys.stderr)
        del rep
    return 0


def run_montecarlo_cmd(args: argparse.Namespace) -> int:
    return _execute(config_from_args(args), args)


def run_reproduce_cmd(args: argparse.Namespace) -> int:
    # The paper's settings: the default (apsipa, APSIPA Table I) profile, seed Section 4 extents.
    config = with_backend(validate(profile_config("apsipa")), args)
    if args.study == "paper":
        return _execute(config, args)
    return _study(config, args)


def _study(config, args: argparse.Namespace) -> int:
    """``reproduce --study partial-view`` (montecarlo/partial_view_study.py)."""
    from radarslam.montecarlo.partial_view_study import run_study

    if args.variant or args.scheduler or args.dask_local:
        raise InputError("--study partial-view: runs its own variants on local workers; --variant, --scheduler and "
                         "--dask-local are not taken")
    if args.trials < 1 or args.jobs < 1 or args.seed < 0:
        raise InputError(f"--trials, --jobs: expected integers >= 1 and --seed >= 0, got {args.trials}, {args.jobs}, "
                         f"{args.seed}")
    out = prepare_out_dir(args.out)
    run_study(config, args.seed, args.trials, out, jobs=args.jobs, progress=not args.quiet,
              log=lambda s: print(s, file=sys.stderr))
    print((out / "partial_view_study.md").read_text(encoding="utf-8"), end="")
    print(f"per-model reports: {out}/<model>/report/ (radarslam report {out}/<model>)", file=sys.stderr)
    return 0
