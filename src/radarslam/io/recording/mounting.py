"""The radar's planar mounting on the platform and the move of detections into the platform frame.

The filter's measurement model (docs/method.md a.1) has the sensor at the platform origin looking
along the heading. A recording's detections are in the sensor frame, so each detection is moved to
the platform frame before it reaches the filter (docs/recordings.md "Mounting")::

    p_platform = [x_m, y_m] + R(yaw) [r cos(phi), r sin(phi)]
    r' = |p_platform|,  phi' = atan2(p_platform)

The filter then sees ranges and azimuths about the platform origin; its range-azimuth noise is
applied there (exact for a zero lever arm, an approximation of the order of the lever arm over the
range otherwise). A zero mounting leaves the numbers untouched (no round trip through x, y).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError


@dataclass(frozen=True)
class Mounting:
    """Sensor pose in the platform frame: ``x`` ahead (m), ``y`` left (m), ``yaw`` (rad, CCW).

    A multi-radar rig (``sensors.csv``, docs/recordings.md "Several radars") gives each sensor its
    ``sensor_id`` and ``name`` and, optionally, its ``max_range_m`` and full field of view ``fov_rad``
    (None: not stated). Only ``x``, ``y`` and ``yaw`` move detections.
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
        return self.x == 0.0 and self.y == 0.0 and self.yaw == 0.0

    @classmethod
    def from_config(cls, sensor) -> "Mounting":
        """From a :class:`radarslam.config.SensorConfig` (degrees at the edge, radians inside)."""
        return cls(float(sensor.mount_x_m), float(sensor.mount_y_m), math.radians(sensor.mount_yaw_deg), "config")


def to_platform(polar: np.ndarray, m: Mounting) -> np.ndarray:
    """Sensor-frame ``(n, 2)`` ``[range m, azimuth rad]`` -> the same about the platform origin."""
    if m.is_identity:
        return polar
    r, a = polar[:, 0], polar[:, 1] + m.yaw
    x, y = m.x + r * np.cos(a), m.y + r * np.sin(a)
    return np.column_stack([np.hypot(x, y), np.arctan2(y, x)])


def to_sensor(polar: np.ndarray, m: Mounting) -> np.ndarray:
    """The inverse of :func:`to_platform`: platform-frame polar detections -> sensor frame."""
    if m.is_identity:
        return polar
    x = polar[:, 0] * np.cos(polar[:, 1]) - m.x
    y = polar[:, 0] * np.sin(polar[:, 1]) - m.y
    c, s = math.cos(m.yaw), math.sin(m.yaw)
    xs, ys = c * x + s * y, -s * x + c * y
    return np.column_stack([np.hypot(xs, ys), np.arctan2(ys, xs)])


def quaternion_to_rpy(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """Roll, pitch, yaw (rad, ZYX convention) of a unit quaternion ``(x, y, z, w)``."""
    n = math.sqrt(x * x + y * y + z * z + w * w)
    if not n > 0 or not math.isfinite(n):
        raise InputError(f"quaternion: expected a non-zero finite quaternion, got ({x}, {y}, {z}, {w})")
    x, y, z, w = x / n, y / n, z / n, w / n
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def yaw_quaternion(yaw: float) -> tuple[float, float, float, float]:
    """``(x, y, z, w)`` of a rotation by ``yaw`` about z."""
    return 0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)


#: Roll or pitch beyond this (rad) makes a mounting non-planar: refused (an upside-down radar mirrors azimuths).
MAX_TILT_RAD = math.radians(10.0)


def mounting_from_transform(translation, rotation, where: str) -> Mounting:
    """A planar :class:`Mounting` from a tf ``Transform`` (translation x, y; rotation quaternion).

    Raises :class:`InputError` when the rotation tilts the sensor by more than :data:`MAX_TILT_RAD`.
    """
    roll, pitch, yaw = quaternion_to_rpy(rotation.x, rotation.y, rotation.z, rotation.w)
    if abs(roll) > MAX_TILT_RAD or abs(pitch) > MAX_TILT_RAD:
        raise InputError(f"{where}: expected a planar mounting (roll and pitch within "
                         f"{math.degrees(MAX_TILT_RAD):g} deg), got roll {math.degrees(roll):.1f} deg, "
                         f"pitch {math.degrees(pitch):.1f} deg")
    return Mounting(float(translation.x), float(translation.y), yaw, where)
