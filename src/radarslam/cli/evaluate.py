"""``radarslam evaluate``: every scene of a dataset, or a list of recordings, run as ``radarslam run``
runs one, into one table (docs/datasets.md "A whole dataset: radarslam evaluate")."""

from __future__ import annotations

import argparse
import os
import shlex
import sys

from radarslam.cli.common import add_backend_arg, add_config_args, config_from_args
from radarslam.core.errors import InputError

#: The options of a bag, passed to ``radarslam run`` for every bag of ``--recordings``.
_BAG = (("--radar-topic", "radar_topic"), ("--odom-topic", "odom_topic"), ("--truth-topic", "truth_topic"),
        ("--doppler-field", "doppler_field"))


def add_parser(sub) -> None:
    p = sub.add_parser("evaluate", help="run every scene of a dataset (or several recordings) as 'radarslam run' "
                       "does, on local workers or Dask, resumably, into one table with a summary")
    p.add_argument("--recordings", nargs="+", metavar="PATH", help="recordings as 'run --recording' takes them "
                   "(plain folders or .npz files, bags); each is a scene named by its folder or file name")
    p.add_argument("--dataset", nargs=2, metavar=("NAME", "DATAROOT"),
                   help="nuscenes or radarscenes in its official layout (docs/datasets.md)")
    p.add_argument("--scenes", nargs="+", metavar="NAME", help="--dataset: 'all' or the scenes to run (nuScenes: "
                   "scene names, e.g. scene-0061; RadarScenes: sequence numbers, e.g. 105)")
    p.add_argument("--version", dest="nuscenes_version", metavar="VERSION",
                   help="--dataset nuscenes: the tables' folder in DATAROOT, e.g. v1.0-mini (default: the one there)")
    add_config_args(p)
    p.add_argument("--calibration", metavar="FILE.json", help="the car's fixed errors from 'radarslam calibrate', "
                   "applied to every scene as 'run --calibration' does")
    p.add_argument("--align", choices=("none", "first-pose", "se2"), default="none",
                   help="how each estimate is aligned to its truth before its errors are taken, as 'run --align'")
    for opt, _ in _BAG:
        p.add_argument(opt, metavar="TOPIC" if opt != "--doppler-field" else "NAME", action=(
            "append" if opt == "--radar-topic" else "store"), help=f"bags of --recordings: as 'run {opt}'")
    add_backend_arg(p)
    p.add_argument("--no-plot", action="store_true", help="no figures in the scenes' folders")
    p.add_argument("--out", required=True, metavar="DIR", help="result directory (created; rerun to resume)")
    cores = os.cpu_count() or 1
    p.add_argument("--workers", type=int, default=cores, metavar="N", help=f"local worker processes (default {cores}, the cores)")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run the scenes on this Dask distributed scheduler")
    g.add_argument("--dask-local", type=int, metavar="N", help="start a local Dask cluster of N worker processes")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=evaluate_cmd)


def run_scene(argv: list[str]) -> int:
    """``radarslam run`` with the command line ``argv`` (``["run", ...]``): the ``run`` command's own
    parser and function, ``sys.argv`` the equivalent command for the scene's run.json."""
    from radarslam.cli import run as run_cli

    p = argparse.ArgumentParser(prog="radarslam")
    run_cli.add_parser(p.add_subparsers(dest="command", required=True))
    args = p.parse_args(argv)
    old = sys.argv
    sys.argv = ["radarslam", *argv]
    try:
        return int(args.func(args) or 0)
    finally:
        sys.argv = old


def _scenes(args: argparse.Namespace):
    """The scenes the arguments name, checked before anything is written."""
    from radarslam.runs.evaluate_scenes import dataset_scenes, recording_scenes

    if args.recordings and args.dataset:
        raise InputError("--recordings: expected either --recordings or --dataset, got both")
    if not args.recordings and not args.dataset:
        raise InputError("--recordings/--dataset: expected recordings or a dataset to evaluate, got neither")
    if args.scenes and not args.dataset:
        raise InputError("--scenes: expected with --dataset nuscenes|radarscenes DATAROOT, got no --dataset")
    if args.nuscenes_version and not (args.dataset and args.dataset[0] == "nuscenes"):
        raise InputError("--version: expected with --dataset nuscenes DATAROOT, got "
                         + (f"--dataset {args.dataset[0]}" if args.dataset else "no --dataset"))
    if args.recordings:
        return recording_scenes([os.path.abspath(p) for p in args.recordings])
    used = [opt for opt, dest in _BAG if getattr(args, dest)]
    if used:
        raise InputError(f"{used[0]}: defined for bags (--recordings), got --dataset {args.dataset[0]}")
    if not args.scenes:
        raise InputError(f"--scenes: expected with --dataset {args.dataset[0]} ('all' or the scenes' names), got none")
    return dataset_scenes(args.dataset[0], os.path.abspath(args.dataset[1]), args.scenes, args.nuscenes_version)


def run_options(args: argparse.Namespace) -> list[str]:
    """The ``radarslam run`` options every scene is run with (paths made absolute, for workers elsewhere)."""
    opts = []
    if args.profile:
        opts += ["--profile", args.profile]
    for opt, value in (("--config", args.config), ("--calibration", args.calibration)):
        if value:
            opts += [opt, os.path.abspath(value)]
    if args.backend:
        opts += ["--backend", args.backend]
    if args.align != "none":
        opts += ["--align", args.align]
    for opt, dest in _BAG:
        values = getattr(args, dest)
        for v in (values if isinstance(values, list) else [values] if values else []):
            opts += [opt, v]
    return opts + (["--no-plot"] if args.no_plot else [])


def evaluate_cmd(args: argparse.Namespace) -> int:
    """``radarslam evaluate (--recordings PATH ... | --dataset NAME DATAROOT --scenes ...) --out DIR``."""
    from radarslam.runs.evaluate import evaluate

    scenes = _scenes(args)
    if args.workers < 1:
        raise InputError(f"--workers: expected an integer >= 1, got {args.workers}")
    if args.dask_local is not None and args.dask_local < 1:
        raise InputError(f"--dask-local: expected an integer >= 1, got {args.dask_local}")
    config = config_from_args(args)
    if args.calibration:                    # read once here: a bad file is one line before any scene runs
        from radarslam.egomotion.car_calibration import read_car_calibration

        read_car_calibration(args.calibration)
    argv = list(getattr(args, "argv", sys.argv[1:]))        # cli/main.py: the arguments it parsed
    record = {"command": shlex.join(["radarslam", *argv]), "argv": argv,
              "arguments": {k: v for k, v in vars(args).items() if k not in ("func", "argv")}}
    out = os.path.abspath(args.out)
    try:
        ev = evaluate(scenes, out, run_scene, config=config, options=run_options(args), record=record,
                      workers=args.workers, scheduler=args.scheduler, dask_local=args.dask_local,
                      progress=not args.quiet)
    except KeyboardInterrupt:
        from radarslam.runs.evaluate import EvaluationStore

        n = sum(EvaluationStore(out).finished(s.name) for s in scenes)
        print(f"\nradarslam: interrupted; {n} finished scenes are stored in {out}; rerun the same command to resume",
              file=sys.stderr)
        return 130
    print(f"evaluate: {len(ev.rows)} scenes in {out} ({ev.computed} run, {ev.resumed} resumed, {len(ev.failed)} "
          f"failed) in {ev.seconds:.1f} s", file=sys.stderr)
    from radarslam.runs.evaluate_table import table_md

    print(table_md(ev.rows))
    print(f"wrote {out}/ ({', '.join(ev.files)}; scenes/<name>/ as 'radarslam run' writes them)")
    return 0
