"""One state per radar of the rig (docs/method.md c.13.1, c.13.2): what the yaw-offset and the
time-offset states share, their sensor ids in state order, prior std and drift, and their names."""

from __future__ import annotations

from radarslam.core.errors import ConfigError

__all__ = ["PerRadarStates", "rig_ids"]


def rig_ids(config, key: str, section: str) -> list[int]:
    """The rig's sensor ids (sorted: the states' order) for the per-radar states of ``filter.<key>``
    (docs/method.md ``section``); one-line :class:`ConfigError` without the odometry-bias states'
    block, which they join, or without a rig."""
    f = config.filter
    if f.odometry_bias != "states":
        raise ConfigError(f"filter.{key}: expected filter.odometry_bias 'states' (the offsets join the "
                          f"odometry-bias block, {section}; set its priors to 0 to hold the odometry's), got "
                          f"{f.odometry_bias!r}")
    if not config.rig:
        raise ConfigError(f"filter.{key}: expected a rig of radars (a recording's sensors.csv or "
                          "[[sensors]] in the config), got none")
    return sorted(int(m.sensor_id) for m in config.rig)


class PerRadarStates:
    """One state per radar: ``sensor_ids`` (in state order), the prior std and the random walk's drift
    per sqrt(s), in the states' unit; a subclass names them ``<prefix>_<sensor id>``."""

    prefix = "offset"

    def __init__(self, sensor_ids, prior_std: float, drift: float):
        self.sensor_ids = tuple(int(s) for s in sensor_ids)
        self.prior_std = float(prior_std)
        self.drift = float(drift)

    @property
    def dim(self) -> int:
        return len(self.sensor_ids)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(f"{self.prefix}_{s}" for s in self.sensor_ids)

    def position(self, sensor_id: int) -> int | None:
        """The state's position among these, or None for a radar not in the rig."""
        try:
            return self.sensor_ids.index(int(sensor_id))
        except ValueError:
            return None
