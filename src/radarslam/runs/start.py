"""Where a recording's run starts (docs/recordings.md "Where a run starts, and its frame"): the start
pose by its source (the truth's first pose, zero, the configuration's), the start's std by that
source (docs/method.md b.5.1), and the lever between the platform and the filter's reference point."""

from __future__ import annotations

import math

import numpy as np

from radarslam.config import Config
from radarslam.core.angles import wrap_pi
from radarslam.core.errors import InputError
from radarslam.io.recording.stream import Recording


#: What ``map.json`` says its frame is, by where the run started (``metrics.json["start"]["from"]``).
FRAMES = {"truth": "the truth's frame (the run starts at its first pose)",
          "zero": "the platform pose at the first scan",
          "config": "the frame of filter.initial_pose (the config's start pose at the first scan)"}


def sensor_lever(config: Config) -> tuple[float, float] | None:
    """The ``ackermann`` model's sensor position ``(L + a, b)`` on the platform, whose pose the filter
    estimates (models/ackermann.py); None for the other models (the platform's own pose)."""
    f = config.filter
    return (f.vehicle_L_m + f.sensor_a_m, f.sensor_b_m) if f.motion_model == "ackermann" else None


def platform_to_filter(poses: np.ndarray, config: Config) -> np.ndarray:
    """Platform poses ``(K, 3)`` as the filter's state (the sensor's under ``ackermann``)."""
    return _shift(poses, sensor_lever(config), 1.0)


def filter_to_platform(poses: np.ndarray, config: Config) -> np.ndarray:
    """The filter's poses ``(K, 3)`` as the platform's (the inverse of :func:`platform_to_filter`)."""
    return _shift(poses, sensor_lever(config), -1.0)


def filter_cov_to_platform(poses: np.ndarray, covs: np.ndarray, config: Config) -> np.ndarray:
    """The filter's pose covariances ``(K, 3, 3)`` at its poses ``(K, 3)`` as the platform's: moved
    with the pose by :func:`filter_to_platform`'s Jacobian (``d p / d theta = R'(theta) lever``
    under ``ackermann``), unchanged for the other models."""
    covs = np.array(covs, dtype=float)
    lever = sensor_lever(config)
    if lever is None:
        return covs
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    J = np.tile(np.eye(3), (poses.shape[0], 1, 1))
    J[:, 0, 2] = s * lever[0] + c * lever[1]
    J[:, 1, 2] = -c * lever[0] + s * lever[1]
    return J @ covs @ np.swapaxes(J, 1, 2)


def _shift(poses: np.ndarray, lever, sign: float) -> np.ndarray:
    poses = np.array(poses, dtype=float)
    if lever is None:
        return poses
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    poses[:, 0] += sign * (c * lever[0] - s * lever[1])
    poses[:, 1] += sign * (s * lever[0] + c * lever[1])
    return poses


def start_pose(rec: Recording, config: Config, t_first: float, start: str = "auto") -> tuple[list[float], str]:
    """Where a recording run starts: ``(pose, from)``.

    ``start`` "auto": the config's ``filter.initial_pose`` when it differs from its profile's value
    (the user set it), else the truth's pose at the first scan when the truth covers it, else zero;
    never the profile's value, which is the simulator's injected error (docs/method.md b.5). "truth",
    "zero" and "config" force one. The pose is the filter's state (the sensor's under ``ackermann``).
    """
    from radarslam.config import profile_config

    at = None if rec.truth is None else _truth_at_start(t_first, rec.truth_t, rec.truth)
    if start == "auto":
        own = list(config.filter.initial_pose) != list(profile_config(config.profile).filter.initial_pose)
        start = "config" if own else "truth" if at is not None and np.all(np.isfinite(at)) else "zero"
    if start == "config":
        return [float(v) for v in config.filter.initial_pose], "config"
    if start == "zero":
        pose = np.zeros((1, 3))
    elif start == "truth":
        if at is None or not np.all(np.isfinite(at)):
            raise InputError(f"{rec.source}: expected a truth covering the first scan ({t_first} s) to start at, got "
                             + ("none" if at is None else f"one over {rec.truth_t[0]} .. {rec.truth_t[-1]} s"))
        pose = at
    else:
        raise InputError(f"start: expected auto, truth, zero or config, got {start!r}")
    pose = platform_to_filter(pose, config)[0]
    if config.filter.motion_model == "ackermann":
        pose[2] = pose[2] % (2 * math.pi)          # that model's heading is in [0, 2 pi)
    return [float(v) for v in pose], start


#: Where a run's initial std comes from, by where it started (docs/method.md b.5.1).
START_STD = {"truth": "filter.truth_pose_std (the truth's own accuracy)",
             "zero": "0 (the anchored frame: the map's frame is the first pose)",
             "config": "filter.initial_pose_std"}


def start_std(config: Config, origin: str) -> list[float]:
    """The initial pose std ``[x_m, y_m, theta_rad]`` of a run started at ``origin``:
    at the truth, the truth's own accuracy (``filter.truth_pose_std``); at zero, 0, for the map's
    frame is the first pose (P_1 = 0, the anchored frame); at the config's pose, the user's
    ``filter.initial_pose_std``. Never the profile's simulator std for a start that did not come from it."""
    if origin == "truth":
        return [float(v) for v in config.filter.truth_pose_std]
    if origin == "zero":
        return [0.0, 0.0, 0.0]
    if origin == "config":
        return [float(v) for v in config.filter.initial_pose_std]
    raise InputError(f"origin: expected truth, zero or config, got {origin!r}")


def _truth_at_start(t: float, truth_t: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """The truth ``(1, 3)`` at ``t``; a first scan up to one truth interval before the truth's first
    sample (a 50 Hz truth starting 6 ms after the radar) takes the line through its first two samples."""
    at = truth_at(np.array([t]), truth_t, truth)
    if not np.all(np.isfinite(at)) and truth_t.size >= 2 and 0 < truth_t[0] - t <= truth_t[1] - truth_t[0]:
        w = (t - truth_t[0]) / (truth_t[1] - truth_t[0])
        d = truth[1] - truth[0]
        d[2] = wrap_pi(d[2])
        at = (truth[0] + w * d)[None, :]
        at[0, 2] = wrap_pi(at[0, 2])
    return at


def truth_at(times: np.ndarray, truth_t: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Truth poses ``(K, 3)`` at ``times`` by linear interpolation (yaw unwrapped); NaN outside its span
    (and within 1 ns of a truth sample, that sample exactly)."""
    out = np.full((times.size, 3), np.nan)
    ok = (times >= truth_t[0] - 1e-9) & (times <= truth_t[-1] + 1e-9)
    tc = np.clip(times[ok], truth_t[0], truth_t[-1])
    yaw = np.unwrap(truth[:, 2])
    out[ok] = np.column_stack([np.interp(tc, truth_t, truth[:, 0]), np.interp(tc, truth_t, truth[:, 1]),
                               wrap_pi(np.interp(tc, truth_t, yaw))])
    j = np.searchsorted(truth_t, tc).clip(0, truth_t.size - 1)
    exact = np.abs(truth_t[j] - tc) <= 1e-9
    idx = np.flatnonzero(ok)[exact]
    out[idx] = truth[j[exact]]
    return out
