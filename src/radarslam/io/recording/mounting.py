"""Mountings as the readers meet them: a bag's ``/tf_static`` transform (quaternions) as a
:class:`~radarslam.core.mounting.Mounting`, the one mounting type (defined in ``core``, re-exported here).

A recording's detections are in their radar's frame; the filter measures each scan from its radar's
pose (docs/method.md c.13), and :func:`detections_to_platform` / :func:`detections_to_sensor` move
detections between that frame and the platform's (docs/recordings.md "Mounting")::

    p_platform = [x_m, y_m] + R(yaw) [r cos(phi), r sin(phi)]
    r' = |p_platform|,  phi' = atan2(p_platform)

A zero mounting leaves the numbers untouched (no round trip through x, y). ``to_platform`` and
``to_sensor``, their former names, still import, with a :class:`DeprecationWarning` (the filter's
state moves by ``slam/sensor_frame.py``'s ``state_to_sensor`` / ``state_to_platform``).
"""

from __future__ import annotations

import math

from radarslam.core.deprecation import renamed
from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting, detections_to_platform, detections_to_sensor

__all__ = ["MAX_TILT_RAD", "Mounting", "detections_to_platform", "detections_to_sensor", "mounting_from_transform",
           "quaternion_to_rpy", "yaw_quaternion"]

__getattr__ = renamed(__name__, {"to_platform": (detections_to_platform, "detections_to_platform"),
                                 "to_sensor": (detections_to_sensor, "detections_to_sensor")})


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
