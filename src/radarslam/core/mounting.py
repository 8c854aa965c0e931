"""A radar's mounting on the platform: the one type of it from the readers to the filter.

A :class:`Mounting` is where one radar sits on the platform (planar: ``x`` ahead, ``y`` left, ``yaw``
counter-clockwise from the heading) with what a rig says of it (its ``sensor_id``, ``name``, its own
range and field of view for the M/N view test) and where it was read (``source``). The readers
return it (``sensors.csv``, a bag's ``/tf_static``, the config's ``[[sensors]]``), a scan carries its
radar's (``Scan.sensor``, docs/method.md c.13), and the filter's sensor frame
(``slam/sensor_frame.py``), the Doppler gate and odometry, and the rig's ego-motion (its ``(S, 3)``
array, :meth:`Mounting.stack`) take it.

The configuration states one mounting as ``[sensor]`` ``mount_x_m``, ``mount_y_m``,
``mount_yaw_deg``; :meth:`Mounting.from_config` reads it (degrees at the edge, radians inside) and
:meth:`Mounting.sensor_config` writes one into it; a ``[[sensors]]`` table is
:meth:`Mounting.from_rig_config`.

Two kinds of things move between the radar's frame and the platform's: *detections* (points,
:func:`detections_to_platform`, :func:`detections_to_sensor`, here) and the filter's *state* (its
pose block and covariance, ``slam/sensor_frame.py``: ``state_to_sensor``, ``state_to_platform``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError

__all__ = ["ORIGIN", "Mounting", "detections_to_platform", "detections_to_sensor"]


@dataclass(frozen=True)
class Mounting:
    """A radar's pose in the platform frame: ``x`` ahead (m), ``y`` left (m), ``yaw`` (rad, CCW).

    ``source`` says where it was read (a file, ``/tf_static``, ``"config"``); a multi-radar rig
    (``sensors.csv``, docs/recordings.md "Several radars") gives each radar its ``sensor_id`` and
    ``name`` and, optionally, its ``max_range_m`` and full field of view ``fov_rad`` (None: not
    stated; the M/N view test then takes ``filter.max_range_m``, ``filter.field_of_view_deg``).
    Only ``x``, ``y`` and ``yaw`` move detections or the state.
    """

    x: float = 0.0
    y: float = 0.0
    yaw: float = 0.0
    source: str = "config"
    sensor_id: int = 0
    name: str = ""
    max_range_m: float | None = None
    fov_rad: float | None = None

    @property
    def is_identity(self) -> bool:
        """A radar at the platform origin along the heading: nothing to move."""
        return self.x == 0.0 and self.y == 0.0 and self.yaw == 0.0

    def as_array(self) -> np.ndarray:
        """``[x, y, yaw]`` ``(3,)``: the array form the compiled kernels take (the fused engine's
        ``Stream.mount`` rows, the Doppler stream's mounting)."""
        return np.array([self.x, self.y, self.yaw], dtype=float)

    @staticmethod
    def stack(mountings) -> np.ndarray:
        """``(S, 3)`` rows :meth:`as_array` of each of ``mountings`` in order (a rig's ``mount``)."""
        return np.array([m.as_array() for m in mountings], dtype=float).reshape(-1, 3)

    @classmethod
    def from_config(cls, sensor) -> "Mounting":
        """The mounting a :class:`radarslam.config.SensorConfig` states (``mount_x_m``, ``mount_y_m``,
        ``mount_yaw_deg``; degrees at the edge, radians inside), ``source`` "config"."""
        return cls(float(sensor.mount_x_m), float(sensor.mount_y_m), math.radians(sensor.mount_yaw_deg), "config")

    @classmethod
    def from_rig_config(cls, table, where: str = "the config's [[sensors]]") -> "Mounting":
        """The mounting of one ``[[sensors]]`` table (:class:`radarslam.config.RigSensorConfig`), as
        ``sensors.csv`` would give it: the yaw and the field of view in radians (``math.radians`` of the
        degrees), ``source`` naming ``where``."""
        return cls(float(table.x_m), float(table.y_m), math.radians(table.yaw_deg), where, int(table.id), table.name,
                   None if table.max_range_m is None else float(table.max_range_m),
                   None if table.fov_deg is None else math.radians(table.fov_deg))

    def sensor_config(self, sensor):
        """``sensor`` (a :class:`radarslam.config.SensorConfig`) stating this mounting in its ``mount_x_m``,
        ``mount_y_m``, ``mount_yaw_deg`` (the inverse of :meth:`from_config`; its other keys kept)."""
        return dataclasses.replace(sensor, mount_x_m=self.x, mount_y_m=self.y, mount_yaw_deg=math.degrees(self.yaw))

    @classmethod
    def coerce(cls, value) -> "Mounting":
        """``value`` as a :class:`Mounting`: itself, or the former ``(x m, y m, yaw rad)`` triple that
        public signatures took before this type (``DopplerGate``, ``DopplerOdometry``, a rig's rows)."""
        if isinstance(value, Mounting):
            return value
        try:
            x, y, yaw = (float(v) for v in value)
        except (TypeError, ValueError):
            raise InputError(f"mounting: expected a Mounting or (x m, y m, yaw rad), got {value!r}") from None
        return cls(x, y, yaw)


#: A radar at the platform origin along the heading: nothing moves. A scan in its own radar's frame
#: (docs/method.md c.13) is gated and fitted about it.
ORIGIN = Mounting()


def detections_to_platform(polar: np.ndarray, m: Mounting) -> np.ndarray:
    """Detections ``(n, 2)`` ``[range m, azimuth rad]`` in the radar's frame -> the same about the
    platform origin along the heading (``p = [x, y] + R(yaw) [r cos a, r sin a]``); a zero mounting
    returns ``polar`` itself (no round trip through x, y)."""
    if m.is_identity:
        return polar
    r, a = polar[:, 0], polar[:, 1] + m.yaw
    x, y = m.x + r * np.cos(a), m.y + r * np.sin(a)
    return np.column_stack([np.hypot(x, y), np.arctan2(y, x)])


def detections_to_sensor(polar: np.ndarray, m: Mounting) -> np.ndarray:
    """The inverse of :func:`detections_to_platform`: detections about the platform origin -> the radar's frame."""
    if m.is_identity:
        return polar
    x = polar[:, 0] * np.cos(polar[:, 1]) - m.x
    y = polar[:, 0] * np.sin(polar[:, 1]) - m.y
    c, s = math.cos(m.yaw), math.sin(m.yaw)
    xs, ys = c * x + s * y, -s * x + c * y
    return np.column_stack([np.hypot(xs, ys), np.arctan2(ys, xs)])
