"""Helpers shared by subcommands."""

from __future__ import annotations

import argparse
import sys

from radarslam.config import Config, list_profiles, load_config, profile_config, validate
from radarslam.core.errors import InputError
from radarslam.core.registry import BACKENDS


def add_config_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--profile", choices=list_profiles(), default=None,
                   help="parameter profile (default: the config file's, else apsipa)")
    p.add_argument("--config", metavar="FILE.toml", default=None, help="configuration overrides (TOML)")


def add_backend_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--backend", choices=BACKENDS, default=None,
                   help="the filter's steps: numba (compiled, the default) or python (the same functions by the "
                        "interpreter: the reference, for checking)")


def with_backend(config: Config, args: argparse.Namespace) -> Config:
    """``--backend`` overrides ``filter.backend``."""
    import dataclasses

    if getattr(args, "backend", None):
        config = dataclasses.replace(config, filter=dataclasses.replace(config.filter, backend=args.backend))
    return config


def config_from_args(args: argparse.Namespace) -> Config:
    """Profile defaults, overlaid by ``--config``; ``--profile`` wins over the file's profile key."""
    if args.config:
        cfg = load_config(args.config, profile=args.profile)
    else:
        cfg = validate(profile_config(args.profile or "apsipa"))
    return with_backend(cfg, args)


# --- the radar topics of a bag (--radar-topic) ---


def radar_topics(args) -> list[str]:
    """The ``--radar-topic`` values (each may be a comma-separated list), in the order given."""
    return [t for a in (args.radar_topic or []) for t in a.split(",") if t]


def topic_arg(args):
    """What ``read_bag`` takes: None, the one topic (as before), or the list of a rig's topics."""
    topics = radar_topics(args)
    return None if not topics else topics[0] if len(topics) == 1 else topics


def one_topic(args, what: str) -> str:
    """The single ``--radar-topic`` of a run that takes one radar (``what``), refusing several."""
    topics = radar_topics(args)
    if len(topics) > 1:
        raise InputError(f"--radar-topic: {what} takes one radar topic, got {len(topics)} ({', '.join(topics)})")
    return topics[0]


def stream_first_run(config, n_scans: int, n_detections: int):
    """The plan of a recording's run (:func:`radarslam.compiling.stream_plan.first_run_plan`), its
    first line said on stderr."""
    from radarslam.compiling.stream_plan import first_run_plan

    plan = first_run_plan(config, n_scans, bool(config.filter.fused), n_detections=n_detections)
    if plan.announce:
        print(f"run: {plan.announce}", file=sys.stderr, flush=True)
    return plan
