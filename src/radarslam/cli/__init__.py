"""Command-line interface: ``radarslam <command>``."""
