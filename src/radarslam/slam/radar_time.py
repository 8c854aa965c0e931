"""Each radar's time offset as a state (docs/method.md c.13.2): a radar whose stamps are late or early
against the odometry by a constant ``tau_j``, learnt through the landmarks.

Under ``filter.radar_time_states`` the platform block ends with one state ``tau_j`` (s) per radar of
the rig (``EstimatorConfig.rig``'s ``sensor_id``, in sensor-id order), after the odometry-bias
states (c.11) and the yaw offsets (c.13.1) when those are on. A scan stamped ``t`` by radar ``j``
was measured at ``t + tau_j`` (the sign of ``radarslam calibrate``'s ``time_offset_s``, c.16: a
radar's stamps early by this much), when the platform was at

    p(t + tau_j) ~= p + tau_j f,    f = (v cos(theta), v sin(theta), omega),

``f`` the pose's rate under the latest odometry reading corrected by the current bias estimates
(c.11.2), the thrust-turned direction under the thrust state (c.11.12): :func:`pose_rate`, the
motion model's own step over a short ``h`` so that every model (unicycle, Ackermann) and the thrust
turn come out of the same code. For the span of the scan the pose block becomes the pose at the
measurement: ``x_p <- x_p + x_tau f``, ``P <- G_tau P G_tau^T``, ``G_tau = I + f e_tau^T`` (the
pose rows gain ``f`` times the offset's row, and the columns alike), *before* c.13's lever arm and
c.13.1's yaw offset (the mounting is rigid on the platform, so the radar's pose at ``t + tau`` is
the mounting applied to the platform's pose then); after the scan, in the reverse order, the pose
rows lose it again with the same ``f`` (``G_tau^{-1} = I - f e_tau^T``), exactly.

``f`` is held a known constant, evaluated at the estimate when the scan enters, so that ``G_tau``
is linear with an exact inverse. Neglected: ``tau d f / d theta`` (the rate turns with the heading:
40 ms at 9 m/s is 0.36 m of position per rad of heading error, i.e. 6 mm per degree), ``tau d f/d b``
(the bias states' effect on the rate), the odometry reading's own noise in ``f`` and the
acceleration within ``tau`` (``a tau^2 / 2``: 2.4 mm at 3 m/s^2 and 40 ms). The prediction carries
each ``tau_j`` as a random walk of drift ``filter.radar_time_drift_ms_per_rt_s`` (0: a constant of
the car) beside the odometry biases (``slam/bias.py``; their ``C_b`` columns 0).

What is observable (c.13.2): only motion shows a time offset (``f = 0``: nothing); on a straight
drive at constant speed a common offset of every radar moves the whole map along the track and is
not observable (only the radars' differences are, through the landmarks they share); changes of
speed and turns (the heading's ``tau omega``) show each offset itself. No reference is held: the
odometry's clock is the reference, each offset is free within its prior.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import ConfigError
from radarslam.slam.bias import turned_step
from radarslam.slam.rig_states import PerRadarStates, rig_ids

__all__ = ["RATE_STEP_S", "RadarTimeStates", "enter_time", "leave_time", "pose_rate", "radar_time_states", "rate_of_step"]

_TWO_PI = 2.0 * math.pi

#: The step (s) over which :func:`pose_rate` differences the motion model (its error O(h omega v)).
RATE_STEP_S = 1e-4


def enter_time(x: np.ndarray, P: np.ndarray, i: int, f: np.ndarray) -> None:
    """``p <- p + tau f`` (in place): the pose block (indices 0-2) of a state ``(x, P)`` moved by the
    offset at index ``i`` along the rate ``f`` (3,), ``P <- G P G^T`` with ``G = I + f e_i^T``. A kernel."""
    x[:3] += x[i] * f
    for r in range(3):
        P[r, :] += f[r] * P[i, :]
    for r in range(3):
        P[:, r] += f[r] * P[:, i]


def leave_time(x: np.ndarray, P: np.ndarray, i: int, f: np.ndarray) -> None:
    """The inverse of :func:`enter_time` with the same ``f`` (in place): ``G^{-1} = I - f e_i^T``. A kernel."""
    enter_time(x, P, i, -f)


def pose_rate(bias, model, x: np.ndarray, u: np.ndarray | None) -> np.ndarray:
    """``f`` (3,): the platform pose's rate ``d(x, y, theta)/dt`` at the pose ``x[:3]`` under the
    odometry reading ``u`` corrected by the bias states of ``x`` (``bias``, a
    :class:`~radarslam.slam.bias.BiasStates`), the position's step turned by the thrust angle when it
    is a state (c.11.12); zeros before any reading. The model's step over :data:`RATE_STEP_S`
    differenced (module docstring)."""
    if u is None:
        return np.zeros(3)
    pose, b = x[:3], x[3:3 + bias.dim]
    nxt = model.step(pose, bias.spec.correct(u, b), RATE_STEP_S)
    thrust = bias.thrust_index
    return rate_of_step(pose, nxt, b[thrust] if thrust >= 0 else 0.0, thrust >= 0, RATE_STEP_S)


def rate_of_step(pose, nxt, beta, turned, h):
    """``(nxt - pose) / h`` (3,), the heading's step wrapped to ``[-pi, pi]``: the pose's rate of
    c.13.2 from the motion model's step ``nxt`` over ``h`` from ``pose``, its position increment turned
    by the thrust angle ``beta`` when ``turned`` (c.11.12). A kernel."""
    d = (turned_step(pose, nxt, beta) if turned else nxt.copy()) - pose
    d[2] = d[2] - _TWO_PI * round(d[2] / _TWO_PI)
    return d / h


class RadarTimeStates(PerRadarStates):
    """The rig's time-offset states: their sensor ids (in state order), prior std (s) and drift (s/sqrt(s))."""

    prefix = "time_offset"


def radar_time_states(config) -> RadarTimeStates | None:
    """The time-offset states of ``config`` (``filter.radar_time_states``), or None; one-line
    :class:`ConfigError` without the odometry-bias states' block, without a rig or without the
    odometer driving the prediction (c.13.2)."""
    f = config.filter
    if not f.radar_time_states:
        return None
    ids = rig_ids(config, "radar_time_states", "c.13.2")
    if f.odometry != "odometer":
        raise ConfigError("filter.radar_time_states: expected filter.odometry 'odometer' (the offsets are against "
                          f"the odometer's clock; the Doppler input comes from the radars' own scans, c.13.2), got "
                          f"{f.odometry!r}")
    return RadarTimeStates(ids, 1e-3 * f.radar_time_std_ms, 1e-3 * f.radar_time_drift_ms_per_rt_s)
