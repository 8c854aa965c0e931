"""``radarslam dump-config``: print the default configuration as TOML."""

from __future__ import annotations

import argparse

from radarslam.cli.common import add_config_args, config_from_args
from radarslam.config import to_toml


def add_parser(sub) -> None:
    p = sub.add_parser("dump-config", help="print the (default or effective) configuration as TOML")
    add_config_args(p)
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    print(to_toml(config_from_args(args)), end="")
    return 0
