"""``python -m radarslam`` runs the CLI."""

from radarslam.cli.main import entry_point

entry_point()
