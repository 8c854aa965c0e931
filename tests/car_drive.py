"""A synthetic drive of a car with a five-radar rig and known fixed errors: the
thrust angle, each radar's yaw and time offset, the wheel-speed scale and the gyro's bias, with
accelerations and turns; static scatterers seen by every radar, and a share of moving returns."""

from __future__ import annotations

import math

import numpy as np

from radarslam.egomotion.rig import Rig

#: The rig: (x m, y m, yaw rad), a front, two front corners, two rear corners (nuScenes-like).
MOUNT = np.array([[3.4, 0.0, 0.0], [2.4, 0.8, math.radians(90)], [2.4, -0.8, math.radians(-90)],
                  [-0.6, 0.7, math.radians(150)], [-0.6, -0.7, math.radians(-150)]])
#: The injected errors: their yaw offsets sum to zero (the rig is the reference, c.16.1).
TRUE = {"thrust_angle_rad": math.radians(0.5), "wheel_scale": 1.01, "gyro_bias_rad_s": math.radians(0.3),
        "yaw_offset_rad": np.radians([1.5, -1.5, 1.0, -0.5, -0.5]),
        "time_offset_s": np.array([0.0, 0.015, 0.030, 0.045, 0.060])}


def true_motion(t):
    """The rear axle's speed (m/s) and the yaw rate (rad/s) at ``t``: speeding up and slowing down, turning both ways."""
    v = 9.0 + 4.0 * np.sin(0.21 * t) + 1.5 * np.sin(0.9 * t)
    om = 0.25 * np.sin(0.13 * t) + 0.1 * np.sin(0.7 * t)
    return v, om


def drive(seed: int = 1, seconds: float = 90.0, points: int = 40, moving_share: float = 0.1,
          doppler_std: float = 0.05, true: dict = TRUE) -> Rig:
    """The rig's detections (stamped by each radar's early clock) and the car's odometry (50 Hz)."""
    rng = np.random.default_rng(seed)
    k, d, b = true["wheel_scale"], true["thrust_angle_rad"], true["gyro_bias_rad_s"]
    to = np.arange(0.0, seconds, 0.02)
    v, om = true_motion(to)
    odometry = np.column_stack([to, v / k, om + b])          # the car's own wheels and gyro
    rows = []
    for j, (x, y, yaw) in enumerate(MOUNT):
        stamps = np.arange(0.5 + 0.013 * j, seconds - 0.5, 1 / 13.0)
        for ts in stamps:
            tt = ts + true["time_offset_s"][j]                    # when the radar truly measured
            vv, ww = true_motion(tt)
            ux, uy = vv - ww * y, vv * math.tan(d) + ww * x
            a = yaw + true["yaw_offset_rad"][j]
            wx, wy = math.cos(a) * ux + math.sin(a) * uy, -math.sin(a) * ux + math.cos(a) * uy
            az = rng.uniform(-1.05, 1.05, points)
            dop = (-(np.cos(az) * wx + np.sin(az) * wy) * true.get("doppler_scale", 1.0)
                   + doppler_std * rng.standard_normal(points))
            mov = rng.random(points) < moving_share
            dop[mov] += rng.uniform(-8.0, 8.0, mov.sum())
            rows.append(np.column_stack([np.full(points, ts), rng.uniform(3, 60, points), az, dop,
                                         np.full(points, j)]))
    a = np.concatenate(rows)
    a = a[np.argsort(a[:, 0], kind="stable")]
    return Rig(a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4].astype(np.int64), np.arange(5), ["front", "fl", "fr", "bl",
                                                                                            "br"],
               MOUNT.copy(), odometry)


def truth(seconds: float = 90.0, thrust_angle_rad: float = TRUE["thrust_angle_rad"], dt: float = 0.01):
    """The drive's reference trajectory ``(t, poses (n, 3))``: the rear axle moving at
    ``v (1, tan delta)`` in the car's frame, turning at the true yaw rate (a survey of the calibration
    drive, c.16.2)."""
    t = np.arange(0.0, seconds, dt)
    v, om = true_motion(t)
    vx, vy = v, v * math.tan(thrust_angle_rad)
    head = np.concatenate([[0.0], np.cumsum(om[:-1] * dt)])
    x = np.concatenate([[0.0], np.cumsum((vx * np.cos(head) - vy * np.sin(head))[:-1] * dt)])
    y = np.concatenate([[0.0], np.cumsum((vx * np.sin(head) + vy * np.cos(head))[:-1] * dt)])
    return t, np.column_stack([x, y, head])
