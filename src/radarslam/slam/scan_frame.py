"""A scan measured from its own radar at its own time (docs/method.md c.13, c.13.1, c.13.2): for the
span of the scan's steps the state's pose block is the radar's pose when it measured, entered and
left exactly (each change is linear with an exact inverse).

The order is the physical one: the platform's pose at the measurement's time first (c.13.2's time
offset, along the pose's rate ``rate``), then the rigid mounting (c.13's lever arm), then the radar's
yaw offset about its own position (c.13.1); leaving undoes them in reverse.
"""

from __future__ import annotations

from contextlib import contextmanager

from radarslam.slam import sensor_frame
from radarslam.slam.radar_time import enter_time, leave_time
from radarslam.slam.radar_yaw import enter_yaw, leave_yaw

__all__ = ["measured_from"]


@contextmanager
def measured_from(state, mount, yaw: int | None, tau: int | None, rate, first):
    """Within the block, ``state``'s pose block is the radar's pose at its measurement: ``mount`` (a
    :class:`~radarslam.core.mounting.Mounting`), the yaw offset's state index ``yaw`` and the time
    offset's ``tau`` (None: not states) with the pose's rate ``rate`` (3,). Yields the first estimate
    of that pose from the platform's first estimate ``first`` (first-estimates Jacobians, c.2.1), or
    None when ``first`` is None."""
    if tau is not None:                               # c.13.2: the pose when the radar measured
        enter_time(state.x, state.P, tau, rate)
    sensor_frame.state_to_sensor(state.x, state.P, mount)
    if yaw is not None:                               # c.13.1: turned by its yaw offset's estimate
        enter_yaw(state.x, state.P, 2, yaw)
    lin = None
    if first is not None:
        shifted = first if tau is None else first + state.x[tau] * rate
        lin = sensor_frame.sensor_pose(shifted, mount.x, mount.y, mount.yaw)
        if yaw is not None:
            lin[2] += state.x[yaw]
    try:
        yield lin
    finally:
        if yaw is not None:
            leave_yaw(state.x, state.P, 2, yaw)
        sensor_frame.state_to_platform(state.x, state.P, mount)
        if tau is not None:
            leave_time(state.x, state.P, tau, rate)
