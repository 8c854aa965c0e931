"""A scan measured from its own radar at its own time (docs/method.md c.13, c.13.1, c.13.2): for the
span of the scan's steps the state's pose block is the radar's pose when it measured, entered and
left exactly (each change is linear with an exact inverse).

The order is the physical one: the platform's pose at the measurement's time first (c.13.2's time
offset, along the pose's rate ``rate``), then the rigid mounting (c.13's lever arm), then the radar's
yaw offset about its own position (c.13.1); leaving undoes them in reverse.

:func:`enter_frame`, :func:`leave_frame`, :func:`frame_first` (and c.13.2's pose rate, :func:`~radarslam.slam.radar_time.rate_of_step`) are kernels:
the fused engine
(``slam/fused/sensor.py``) calls them compiled; a state index of -1 means "not a state".
"""

from __future__ import annotations

import numpy as np

from radarslam.slam.consider import restore
from radarslam.slam.radar_time import enter_time, leave_time
from radarslam.slam.radar_yaw import enter_yaw, leave_yaw
from radarslam.slam.sensor_frame import sensor_pose, state_to_platform_kernel, state_to_sensor_kernel

__all__ = ["enter_frame", "frame_first", "leave_frame", "rehold"]

#: :func:`enter_frame`'s arguments after the pose block for a scan measured from the platform itself.
def enter_frame(x, P, mx, my, myaw, yaw, tau, rate):
    """The pose block of ``(x, P)`` (in place) becomes the radar's pose at its measurement: moved along
    ``rate`` (3,) by the time offset at index ``tau`` (c.13.2), by the mounting ``(mx, my, myaw)``
    (c.13), turned by the yaw offset at index ``yaw`` (c.13.1). A kernel."""
    if tau >= 0:
        enter_time(x, P, tau, rate)
    state_to_sensor_kernel(x, P, mx, my, myaw)
    if yaw >= 0:
        enter_yaw(x, P, 2, yaw)


def leave_frame(x, P, mx, my, myaw, yaw, tau, rate):
    """The inverse of :func:`enter_frame` with the same arguments (in place). A kernel."""
    if yaw >= 0:
        leave_yaw(x, P, 2, yaw)
    state_to_platform_kernel(x, P, mx, my, myaw)
    if tau >= 0:
        leave_time(x, P, tau, rate)


def rehold(x, P, xc, Pcc, lo, in_frame, mx, my, myaw, yaw, tau, rate):
    """c.13.4 after the scan's update: the held states ``x[lo:lo + len(xc)]`` put back to ``(xc, Pcc)``
    in the platform's coordinates (in place): the frame left with the offsets as the update moved
    them, the held mean and block restored, the frame entered again (``in_frame``: the scan is in
    its radar's frame, :func:`enter_frame`'s arguments follow). A kernel."""
    if in_frame:
        leave_frame(x, P, mx, my, myaw, yaw, tau, rate)
    restore(x, P, xc, Pcc, lo)
    if in_frame:
        enter_frame(x, P, mx, my, myaw, yaw, tau, rate)


def frame_first(first, x, mx, my, myaw, yaw, tau, rate):
    """The first estimate (c.2.1) of the radar's pose at its measurement, from the platform's first
    estimate ``first`` (3,) and the offsets' estimates in ``x``, as :func:`enter_frame` moves the
    estimate. A kernel; returns a new array."""
    shifted = first.copy()
    if tau >= 0:
        shifted = shifted + x[tau] * rate
    lin = sensor_pose(shifted, mx, my, myaw)
    if yaw >= 0:
        lin[2] += x[yaw]
    return lin
