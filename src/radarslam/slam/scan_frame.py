"""A scan measured from its own radar at its own time (docs/method.md c.13, c.13.1, c.13.2): for the
span of the scan's steps the state's pose block is the radar's pose when it measured, entered and
left exactly (each change is linear with an exact inverse).

The order is the physical one: the platform's pose at the measurement's time first (c.13.2's time
offset, along the pose's rate ``rate``), then the rigid mounting (c.13's lever arm), then the radar's
yaw offset about its own position (c.13.1); leaving undoes them in reverse.

:func:`enter_frame`, :func:`leave_frame`, :func:`frame_first` (and c.13.2's pose rate, :func:`~radarslam.slam.radar_time.rate_of_step`) are kernels:
the orchestrator (:func:`measured_from`) calls them as Python, the fused engine
(``slam/fused/sensor.py``) the same functions compiled; a state index of -1 means "not a state".
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np

from radarslam.slam.consider import restore
from radarslam.slam.radar_time import enter_time, leave_time
from radarslam.slam.radar_yaw import enter_yaw, leave_yaw
from radarslam.slam.sensor_frame import sensor_pose, state_to_platform_kernel, state_to_sensor_kernel

__all__ = ["NO_FRAME", "enter_frame", "frame_args", "frame_first", "leave_frame", "measured_from", "rehold"]

#: :func:`enter_frame`'s arguments after the pose block for a scan measured from the platform itself.
NO_FRAME = (0.0, 0.0, 0.0, -1, -1, np.zeros(3))


def frame_args(mount, yaw, tau, rate) -> tuple:
    """:func:`enter_frame`'s arguments after the pose block: the mounting ``mount`` (a
    :class:`~radarslam.core.mounting.Mounting`), the yaw and time offsets' state indices (None: not
    states) and the pose's rate (None: zeros)."""
    return (float(mount.x), float(mount.y), float(mount.yaw), -1 if yaw is None else int(yaw),
            -1 if tau is None else int(tau), np.zeros(3) if rate is None else np.asarray(rate, dtype=float))

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


@contextmanager
def measured_from(state, args: tuple, first):
    """Within the block, ``state``'s pose block is the radar's pose at its measurement, ``args`` the
    frame's (:func:`frame_args`: the mounting, the yaw and time offsets' state indices, the pose's
    rate). Yields the first estimate of that pose from the platform's first estimate ``first``
    (first-estimates Jacobians, c.2.1), or None when ``first`` is None."""
    enter_frame(state.x, state.P, *args)
    lin = None if first is None else frame_first(np.asarray(first, dtype=float), state.x, *args)
    try:
        yield lin
    finally:
        leave_frame(state.x, state.P, *args)
