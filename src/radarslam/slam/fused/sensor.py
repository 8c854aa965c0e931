"""The fused engine's scan from its own radar (docs/method.md c.13): the kernels of
:mod:`radarslam.slam.sensor_frame`, compiled as they are."""

from __future__ import annotations


from radarslam.core.jit import compile_kernels, compiled_only
from radarslam.slam import sensor_frame as _sf

_K = compile_kernels(_sf.lever_column, _sf.sensor_pose, _sf.platform_pose, _sf.shear, _sf.state_to_sensor_kernel,
                     _sf.state_to_platform_kernel)
sensor_pose, state_to_sensor_kernel, state_to_platform_kernel = (_K["sensor_pose"], _K["state_to_sensor_kernel"],
                                                                 _K["state_to_platform_kernel"])


@compiled_only
def enter_sensor(x, P, stream, s, pose_first):  # pragma: no cover - compiled
    """Before scan ``s``: the pose block of ``(x, P)`` becomes its radar's (in place) when the scan is
    in its radar's frame (``stream.has_mount[s]``; ``stream.mount[s]`` its mounting's
    :meth:`~radarslam.core.mounting.Mounting.as_array`); returns the FEJ first estimate moved likewise."""
    if not stream.has_mount[s]:
        return pose_first
    m = stream.mount[s]
    state_to_sensor_kernel(x, P, m[0], m[1], m[2])
    return sensor_pose(pose_first, m[0], m[1], m[2])


@compiled_only
def leave_sensor(x, P, stream, s):  # pragma: no cover - compiled
    """After scan ``s``: the inverse of :func:`enter_sensor` (in place)."""
    if stream.has_mount[s]:
        m = stream.mount[s]
        state_to_platform_kernel(x, P, m[0], m[1], m[2])
