"""Exception hierarchy.

Every error raised for bad input at a public boundary is an :class:`InputError`, a ``ValueError``
subclass, whose message names the argument, what was expected and what was given.
"""


class RadarSlamError(Exception):
    """Base class of all radarslam errors."""


class InputError(RadarSlamError, ValueError):
    """Bad input at a public boundary (shape, dtype, non-finite values, out of range)."""


class ConfigError(InputError):
    """A configuration key that is unknown, of the wrong type or out of range."""


class DataError(InputError):
    """A dataset file that is missing, truncated or malformed."""
