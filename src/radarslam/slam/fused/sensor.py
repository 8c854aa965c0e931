"""The fused engine's scan from its own radar at its own time (docs/method.md c.13, c.13.1, c.13.2):
the kernels of :mod:`radarslam.slam.scan_frame`, compiled as they are, and the pose's rate of c.13.2
from the motion model's compiled step (:func:`radarslam.slam.radar_time.rate_of_step`)."""

from __future__ import annotations

import numpy as np
from numba import njit

from radarslam.core.jit import compile_kernels, compiled_only
from radarslam.slam import consider as _cs
from radarslam.slam import radar_time as _rt
from radarslam.slam import radar_yaw as _ry
from radarslam.slam import scan_frame as _sc
from radarslam.slam import sensor_frame as _sf
from radarslam.slam.bias import turned_step as _turned_step
from radarslam.slam.fused.bias import _correct_input
from radarslam.slam.fused.tracking import _motion
from radarslam.slam.layout import POSE_DIM

_K = compile_kernels(_sf.lever_column, _sf.sensor_pose, _sf.platform_pose, _sf.shear, _sf.state_to_sensor_kernel,
                     _sf.state_to_platform_kernel, _rt.enter_time, _rt.leave_time, _ry.enter_yaw, _ry.leave_yaw,
                     _sc.enter_frame, _sc.leave_frame, _sc.frame_first, _turned_step, _rt.rate_of_step, _cs.held,
                     _cs.restore, _sc.rehold)
_enter_frame, _leave_frame, _frame_first, _rate_of_step = (_K["enter_frame"], _K["leave_frame"], _K["frame_first"],
                                                           _K["rate_of_step"])
#: c.13.4's Schmidt-Kalman hold of the car's states over a scan (:mod:`radarslam.slam.consider`).
held, restore, _rehold = _K["held"], _K["restore"], _K["rehold"]


@njit(cache=True, inline="always")
def scan_rate(x, u, cfg):  # pragma: no cover - compiled
    """c.13.2's pose rate (3,) at ``x`` under the odometer's latest reading ``u`` corrected by the bias
    states of ``x``, as :func:`radarslam.slam.radar_time.pose_rate` (with bias states only)."""
    b = x[POSE_DIM:cfg.platform].copy()
    uc = _correct_input(u, b, cfg.bias_scaled, cfg.bias_offset, cfg.bias_turn)
    nxt = _motion(x, uc, _rt.RATE_STEP_S, cfg.motion, cfg)[0]
    turned = cfg.bias_thrust >= 0
    return _rate_of_step(x[:POSE_DIM].copy(), nxt, b[cfg.bias_thrust] if turned else 0.0, turned, _rt.RATE_STEP_S)


@njit(cache=True, inline="always")
def _in_frame(stream, s):  # pragma: no cover - compiled
    """Whether scan ``s`` is measured in its radar's frame: a mounting of its own, or its radar's yaw or
    time offset a state."""
    return stream.has_mount[s] or stream.yaw_i[s] >= 0 or stream.tau_i[s] >= 0


@compiled_only
def enter_sensor(x, P, stream, s, pose_first, rate):  # pragma: no cover - compiled
    """Before scan ``s``: the pose block of ``(x, P)`` becomes its radar's at its measurement (in place)
    when the scan is in its radar's frame (``stream.has_mount[s]``; ``stream.mount[s]`` its
    mounting's :meth:`~radarslam.core.mounting.Mounting.as_array`) or its radar has a yaw or time
    offset state (``stream.yaw_i[s]``, ``stream.tau_i[s]``, -1 for none; ``rate`` the pose's rate);
    returns the FEJ first estimate moved likewise."""
    if not _in_frame(stream, s):
        return pose_first
    m = stream.mount[s]
    _enter_frame(x, P, m[0], m[1], m[2], stream.yaw_i[s], stream.tau_i[s], rate)
    return _frame_first(pose_first, x, m[0], m[1], m[2], stream.yaw_i[s], stream.tau_i[s], rate)


@compiled_only
def leave_sensor(x, P, stream, s, rate, x_held, P_held):  # pragma: no cover - compiled
    """After scan ``s``: the inverse of :func:`enter_sensor` (in place), then the held states put back
    (c.13.4; ``held``'s copies, empty when none are held)."""
    if _in_frame(stream, s):
        m = stream.mount[s]
        _leave_frame(x, P, m[0], m[1], m[2], stream.yaw_i[s], stream.tau_i[s], rate)
    restore(x, P, x_held, P_held, POSE_DIM)


@compiled_only
def rehold(x, P, x_held, P_held, stream, s, rate):  # pragma: no cover - compiled
    """c.13.4 after scan ``s``'s update: the held states put back in the platform's coordinates
    (:func:`radarslam.slam.scan_frame.rehold`, in place); nothing when none are held."""
    if x_held.shape[0] == 0:
        return
    m = stream.mount[s]
    _rehold(x, P, x_held, P_held, POSE_DIM, _in_frame(stream, s), m[0], m[1], m[2], stream.yaw_i[s], stream.tau_i[s], rate)
