"""Helpers shared by subcommands."""

from __future__ import annotations

import argparse

from radarslam.config import Config, list_profiles, load_config, profile_config, validate
from radarslam.core.registry import BACKENDS


def add_config_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--profile", choices=list_profiles(), default=None,
                   help="parameter profile (default: the config file's, else apsipa)")
    p.add_argument("--config", metavar="FILE.toml", default=None, help="configuration overrides (TOML)")


def add_backend_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--backend", choices=BACKENDS, default=None,
                   help="per-scan steps: numba (compiled, the default) or python (the reference, for checking)")


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
