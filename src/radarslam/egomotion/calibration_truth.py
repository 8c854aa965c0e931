"""What a reference trajectory of the calibration drive says of the car (docs/method.md c.16.2): its
thrust angle, its wheels' scale, its gyro's bias (:func:`truth_motion`) and its radars' Doppler scale
(:func:`truth_doppler_scale`), each a median over short windows with the standard error of a median:
the anchors of :func:`~radarslam.egomotion.car_calibration.calibrate_car` under ``reference = "truth"``.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.egomotion.calibrate import MIN_SPEED_MPS
from radarslam.egomotion.rig import Rig

__all__ = ["truth_doppler_scale", "truth_motion"]


def truth_doppler_scale(rig: Rig, rng: np.random.Generator, t: np.ndarray, poses: np.ndarray,
                        min_speed_mps: float = MIN_SPEED_MPS, window_s: float = 0.2) -> tuple[float, float]:
    """The radars' own Doppler scale a reference trajectory shows (c.16.2): the rig's joint fit's speed
    at the rear axle (c.12.4) against the truth's speed over ``window_s`` about each fit, the median of
    their ratio over the fits of a moving car, with the standard error of a median over the
    independent windows. ``(g, sd)``; what a 2-D radar's Doppler reads of the car's speed (the
    detections' elevation, cos(el) < 1, makes it read low: 0.9938-0.9976 on the four nuScenes scenes)."""
    from radarslam.egomotion.rig import rig_ego_velocity

    t, poses = _finite(t, poses)
    series = rig_ego_velocity(rig, rng)
    tc = series.t
    fit = (series.status == 0) & np.all(np.isfinite(series.theta[:, :2]), axis=1)
    inside = (tc - window_s / 2 >= t[0]) & (tc + window_s / 2 <= t[-1])
    dx = np.interp(tc + window_s / 2, t, poses[:, 0]) - np.interp(tc - window_s / 2, t, poses[:, 0])
    dy = np.interp(tc + window_s / 2, t, poses[:, 1]) - np.interp(tc - window_s / 2, t, poses[:, 1])
    truth_speed = np.hypot(dx, dy) / window_s
    use = fit & inside & (truth_speed >= min_speed_mps)
    if np.count_nonzero(use) < 20:
        raise InputError(f"truth: expected at least 20 Doppler fits of a moving car (>= {min_speed_mps} m/s) to "
                         f"measure the Doppler's scale, got {int(np.count_nonzero(use))}")
    g = np.hypot(series.theta[use, 0], series.theta[use, 1]) / truth_speed[use]
    return float(np.median(g)), max(_median_se(g, tc[use], window_s), 1e-5)


def truth_motion(t: np.ndarray, poses: np.ndarray, odo: np.ndarray, min_speed_mps: float = MIN_SPEED_MPS,
                 window_s: float = 0.2) -> tuple[float, float, float, float, float, float]:
    """The thrust angle and the wheel scale a reference trajectory shows: at every truth sample of a
    moving car, the direction of its displacement over ``window_s`` against its heading, and its
    speed against the wheels'; their medians, each with the standard error of a median from the
    samples' robust spread over the independent windows; and the gyro's bias, the median over every
    window of the gyro's mean less the truth's turn rate. ``(delta, sd, k, sd, b, sd)``."""
    t, poses = _finite(t, poses)
    lo = np.searchsorted(t, t - window_s / 2)
    hi = np.clip(np.searchsorted(t, t + window_s / 2) - 1, 0, t.size - 1)
    dt = t[hi] - t[lo]
    dx, dy = poses[hi, 0] - poses[lo, 0], poses[hi, 1] - poses[lo, 1]
    head = poses[lo, 2] + 0.5 * np.angle(np.exp(1j * (poses[hi, 2] - poses[lo, 2])))   # the mid heading
    wheel = np.interp(t, odo[:, 0], odo[:, 1])
    use = (dt > 0.5 * window_s) & (wheel >= min_speed_mps)
    if np.count_nonzero(use) < 20:
        raise InputError(f"truth: expected at least 20 samples of a moving car (>= {min_speed_mps} m/s) to fix the "
                         f"car's axis, got {int(np.count_nonzero(use))}")
    delta = np.angle(np.exp(1j * (np.arctan2(dy[use], dx[use]) - head[use])))
    k = np.hypot(dx[use], dy[use]) / dt[use] / wheel[use]
    # the gyro's bias: its mean over each window against the truth's turn over it, every window (a
    # car at rest measures it best)
    rate = np.angle(np.exp(1j * (poses[hi, 2] - poses[lo, 2]))) / np.where(dt > 0, dt, np.inf)
    gyro = np.interp(0.5 * (t[lo] + t[hi]), odo[:, 0], odo[:, 2])
    turn = dt > 0.5 * window_s
    b = gyro[turn] - rate[turn]
    return (float(np.median(delta)), max(_median_se(delta, t[use], window_s), 1e-5), float(np.median(k)),
            max(_median_se(k, t[use], window_s), 1e-5), float(np.median(b)), max(_median_se(b, t, window_s), 1e-6))


def _finite(t, poses) -> tuple[np.ndarray, np.ndarray]:
    """The reference's samples with a finite pose, as float arrays."""
    t, poses = np.asarray(t, dtype=float), np.asarray(poses, dtype=float)
    ok = np.all(np.isfinite(poses), axis=1)
    return t[ok], poses[ok]


def _median_se(v: np.ndarray, times: np.ndarray, window_s: float) -> float:
    """The standard error of ``v``'s median (1.2533 times the robust std, 1.4826 MAD) over the
    independent windows of ``window_s`` its samples' ``times`` span."""
    n_ind = max(1.0, (times[-1] - times[0]) / window_s)
    return 1.2533 * 1.4826 * float(np.median(np.abs(v - np.median(v)))) / math.sqrt(n_ind)
