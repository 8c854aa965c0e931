"""A scan measured from its own radar's pose (docs/method.md c.13).

The method's measurement model (a.1) has the radar at the platform origin looking along the heading.
A radar mounted at ``m = (m_x, m_y, m_yaw)`` on the platform sees from the sensor pose

    s = g(p) = (t + R(theta) [m_x, m_y],  theta + m_yaw),

so for the span of one scan the filter takes ``s`` as its pose: the state's pose block is replaced by
``g(p)`` and the covariance's pose rows and columns by ``G P G^T`` with ``G = dg/dp``; every step of
the scan (sifting, association and update, the M/N view test, the extent step's ``W(i)``, the partial
view's viewpoint, the Doppler's static world, landmark creation) then runs unchanged about the
sensor, with the radar's range-azimuth noise ``R`` where it arises. After the scan the pose block
goes back, ``p = g^{-1}(s)``, with ``dg^{-1}/ds`` at the updated pose. ``g`` is a bijection for a
fixed mounting and its Jacobian is exact to first order, so the scan's update equals one made with
the lever arm in the measurement model, ``H_p = H_s G`` (the Jacobians evaluated at the same point).

``G`` differs from the identity only in the heading column:
``G = [[1, 0, a], [0, 1, b], [0, 0, 1]]`` with ``(a, b) = d(R(theta) m)/d theta
= (-sin(theta) m_x - cos(theta) m_y,  cos(theta) m_x - sin(theta) m_y)``, and ``G^{-1}`` has
``(-a, -b)`` there; so the transform costs O(n) (two row and two column updates), in place.
A mounting at zero leaves the state untouched, bit for bit.

The mounting is the one type :class:`~radarslam.core.mounting.Mounting` (``Scan.sensor``):
:func:`state_to_sensor` and :func:`state_to_platform` move the *state* (not detections) by it; the
kernels they call take its ``x``, ``y``, ``yaw`` (compiled, its :meth:`~Mounting.as_array` rows).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.deprecation import renamed
from radarslam.core.mounting import Mounting


def lever_column(theta: float, mx: float, my: float) -> tuple[float, float]:
    """``d(R(theta) [mx, my]) / d theta`` (2,): the heading column of ``G`` (module docstring)."""
    c, s = math.cos(theta), math.sin(theta)
    return -s * mx - c * my, c * mx - s * my


def sensor_pose(pose: np.ndarray, mx: float, my: float, myaw: float) -> np.ndarray:
    """``g(p)``: the sensor's pose ``(3,)`` of a platform pose ``(3,)`` (module docstring)."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    return np.array([pose[0] + c * mx - s * my, pose[1] + s * mx + c * my, pose[2] + myaw])


def platform_pose(sensor: np.ndarray, mx: float, my: float, myaw: float) -> np.ndarray:
    """``g^{-1}(s)``: the platform pose ``(3,)`` of a sensor pose ``(3,)``."""
    theta = sensor[2] - myaw
    c, s = math.cos(theta), math.sin(theta)
    return np.array([sensor[0] - (c * mx - s * my), sensor[1] - (s * mx + c * my), theta])


def shear(P: np.ndarray, a: float, b: float) -> None:
    """``P <- G P G^T`` for ``G`` = identity with ``(a, b)`` in the heading column (rows 0, 1, col 2)."""
    P[0, :] += a * P[2, :]
    P[1, :] += b * P[2, :]
    P[:, 0] += a * P[:, 2]
    P[:, 1] += b * P[:, 2]


def state_to_sensor_kernel(x: np.ndarray, P: np.ndarray, mx: float, my: float, myaw: float) -> None:
    """Replace the pose block of the state ``(x, P)`` (in place) by the sensor's pose and its
    covariance, for a radar mounted at ``(mx, my, myaw)``. A kernel (the fused engine compiles it as
    it is, slam/fused/sensor.py); from Python, :func:`state_to_sensor`."""
    a, b = lever_column(x[2], mx, my)
    x[:3] = sensor_pose(x[:3], mx, my, myaw)
    shear(P, a, b)


def state_to_platform_kernel(x: np.ndarray, P: np.ndarray, mx: float, my: float, myaw: float) -> None:
    """The inverse of :func:`state_to_sensor_kernel` (in place), its Jacobian at the updated pose. A kernel."""
    x[:3] = platform_pose(x[:3], mx, my, myaw)
    a, b = lever_column(x[2], mx, my)
    shear(P, -a, -b)


def state_to_sensor(x: np.ndarray, P: np.ndarray, m: Mounting) -> None:
    """The state ``(x, P)`` (in place) about the sensor's pose of the radar at ``m`` for a scan (module
    docstring). Not the detections: those move by :func:`radarslam.core.mounting.detections_to_sensor`."""
    state_to_sensor_kernel(x, P, m.x, m.y, m.yaw)


def state_to_platform(x: np.ndarray, P: np.ndarray, m: Mounting) -> None:
    """The inverse of :func:`state_to_sensor` (in place): the state back about the platform's pose."""
    state_to_platform_kernel(x, P, m.x, m.y, m.yaw)


def scan_mounting(sensor: Mounting | None) -> Mounting | None:
    """The mounting a scan's state moves by (``Scan.sensor``), or None for none or a zero mounting
    (the scan is then processed exactly as before, bit for bit)."""
    return None if sensor is None or sensor.is_identity else sensor


def _to_sensor(x, P, mount) -> None:
    state_to_sensor(x, P, Mounting.coerce(mount))


def _to_platform(x, P, mount) -> None:
    state_to_platform(x, P, Mounting.coerce(mount))


def _mount_of(sensor):
    m = scan_mounting(sensor)
    return None if m is None else (float(m.x), float(m.y), float(m.yaw))


#: The former names (``to_sensor`` and ``to_platform`` clashed with the detections' moves of the
#: readers; they took ``(x, y, yaw)`` tuples), with a DeprecationWarning.
__getattr__ = renamed(__name__, {
    "to_sensor": (_to_sensor, "state_to_sensor(x, P, mounting)"),
    "to_platform": (_to_platform, "state_to_platform(x, P, mounting)"),
    "to_sensor_xyz": (state_to_sensor_kernel, "state_to_sensor_kernel"),
    "to_platform_xyz": (state_to_platform_kernel, "state_to_platform_kernel"),
    "mount_of": (_mount_of, "scan_mounting (a Mounting or None)")})
