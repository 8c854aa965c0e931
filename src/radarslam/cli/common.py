"""Helpers shared by subcommands."""

from __future__ import annotations

import argparse

from radarslam.config import Config, load_config, profile_config, validate


def add_config_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--profile", choices=("apsipa", "reference"), default=None,
                   help="parameter profile (default: the config file's, else apsipa)")
    p.add_argument("--config", metavar="FILE.toml", default=None, help="configuration overrides (TOML)")


def config_from_args(args: argparse.Namespace) -> Config:
    """Profile defaults, overlaid by ``--config``; ``--profile`` wins over the file's profile key."""
    if args.config:
        return load_config(args.config, profile=args.profile)
    return validate(profile_config(args.profile or "apsipa"))
