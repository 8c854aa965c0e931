"""One state per radar of the rig (docs/method.md c.13.1, c.13.2): what the yaw-offset and the
time-offset states share, their sensor ids in state order, prior std and drift, and their names."""

from __future__ import annotations

__all__ = ["PerRadarStates"]


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
