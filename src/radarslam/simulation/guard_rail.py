"""A straight road between guard rails, driven at speed by a car with one forward radar (docs/method.md
c.17): the world where a long object seen in part drags the pose along the road.

The road runs along x. Each side has a rail of segments (``rail_length_m`` long, ``rail_gap_m``
apart, ``rail_offset_m`` from the road's centre line, ``rail_width_m`` wide), and a post (a sign, a
lamp: a point-like object of ``post_size_m``) stands every ``post_every_m`` on alternate sides at
``post_offset_m``. The car drives the centre line at ``speed_mps`` with a gentle speed change
(``speed_swing``, a sine over the drive). The radar sits at the platform's origin, looking forward,
and sees what lies within ``range_m`` and ``fov_deg``: of a rail segment the part inside that
sector, the only part that returns (a Poisson number of detections, ``detections_per_m`` per metre
of the part in view, uniform along it and across its width); of a post a Poisson number
``post_detections`` about its centre. Range and azimuth carry the configuration's noise; the
odometer's speed and yaw rate carry the configuration's U at its quoted interval (c.2.2).

The mean of a rail's detections is the centre of the part in view, which moves forward with the car
while the rail stays put: a filter that takes it for the rail's centre learns that the car moves
slower than its odometer says.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.types import Odometry, Scan

__all__ = ["Road", "drive", "objects", "road_config", "road_errors", "run_road"]


@dataclass(frozen=True)
class Road:
    """The road, the drive and the radar (module docstring); lengths in m, times in s."""

    speed_mps: float = 20.0
    duration_s: float = 20.0
    speed_swing: float = 0.1
    scan_dt_s: float = 1.0 / 13.0
    rail_offset_m: float = 4.0
    rail_length_m: float = 40.0
    rail_gap_m: float = 2.0
    rail_width_m: float = 0.3
    post_every_m: float = 60.0
    post_offset_m: float = 8.0
    post_size_m: float = 0.3
    range_m: float = 70.0
    fov_deg: float = 120.0
    detections_per_m: float = 0.3
    post_detections: float = 3.0


def objects(road: Road) -> tuple[np.ndarray, np.ndarray]:
    """``(rails (n, 3) [x_start, x_end, y], posts (p, 2))`` along the whole drive and the range ahead."""
    end = road.speed_mps * (1.0 + road.speed_swing) * road.duration_s + road.range_m + road.rail_length_m
    starts = np.arange(-road.rail_length_m, end, road.rail_length_m + road.rail_gap_m)
    rails = np.concatenate([np.column_stack([starts, starts + road.rail_length_m, np.full(starts.size, side * road.rail_offset_m)])
                            for side in (1.0, -1.0)])
    px = np.arange(road.post_every_m / 2, end, road.post_every_m)
    posts = np.column_stack([px, np.where(np.arange(px.size) % 2 == 0, 1.0, -1.0) * road.post_offset_m])
    return rails, posts


def _in_view(xy: np.ndarray, pose: np.ndarray, road: Road) -> np.ndarray:
    d = xy - pose[:2]
    az = np.arctan2(d[:, 1], d[:, 0]) - pose[2]
    az = (az + math.pi) % (2 * math.pi) - math.pi
    return (np.hypot(d[:, 0], d[:, 1]) <= road.range_m) & (np.abs(az) <= math.radians(road.fov_deg) / 2)


def _rail_points(rails: np.ndarray, pose: np.ndarray, road: Road, rng: np.random.Generator) -> np.ndarray:
    """Detections of the rails' parts in view: on a straight road (heading ~0) each segment's part
    in view is the interval of x where its line lies inside the radar's sector."""
    half = math.radians(road.fov_deg) / 2
    out = []
    for x0, x1, y in rails:
        dy = abs(y - pose[1])
        if dy >= road.range_m:
            continue
        reach = math.sqrt(road.range_m ** 2 - dy ** 2)           # the range circle's chord
        near = dy / math.tan(half) if half < math.pi / 2 else -reach   # the sector's edge
        lo, hi = max(x0, pose[0] + near), min(x1, pose[0] + reach)
        if hi <= lo:
            continue
        n = rng.poisson(road.detections_per_m * (hi - lo))
        pts = np.column_stack([rng.uniform(lo, hi, n), y + road.rail_width_m * (rng.uniform(size=n) - 0.5)])
        out.append(pts[_in_view(pts, pose, road)])
    return np.concatenate(out) if out else np.empty((0, 2))


def _post_points(posts: np.ndarray, pose: np.ndarray, road: Road, rng: np.random.Generator) -> np.ndarray:
    seen = posts[_in_view(posts, pose, road)]
    counts = rng.poisson(road.post_detections, seen.shape[0])
    pts = np.repeat(seen, counts, axis=0)
    return pts + road.post_size_m * (rng.uniform(size=pts.shape) - 0.5)


def drive(road: Road, range_std_m: float, azimuth_std_rad: float, speed_std: float, turn_std: float,
          noise_interval_s: float, rng: np.random.Generator):
    """The drive's ``(events, truth (K, 3) at each scan, scan times (K,))``: one odometer reading
    (noisy ``[v, omega]``, stds quoted over ``noise_interval_s``) then one scan per ``scan_dt_s``."""
    rails, posts = objects(road)
    dt = road.scan_dt_s
    K = int(round(road.duration_s / dt))
    pose = np.zeros(3)
    events, truth, times = [], [], []
    scale = math.sqrt(noise_interval_s / dt)                  # c.2.2: a white rate's std over dt
    for k in range(1, K + 1):
        t = k * dt
        v = road.speed_mps * (1.0 + road.speed_swing * math.sin(2 * math.pi * t / road.duration_s))
        pose = pose + np.array([v * dt, 0.0, 0.0])
        u = np.array([v + speed_std * scale * rng.standard_normal(), turn_std * scale * rng.standard_normal()])
        events.append(Odometry(t, dt, u))
        xy = np.concatenate([_rail_points(rails, pose, road, rng), _post_points(posts, pose, road, rng)])
        d = xy - pose[:2]
        polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]) + range_std_m * rng.standard_normal(xy.shape[0]),
                                 np.arctan2(d[:, 1], d[:, 0]) - pose[2] + azimuth_std_rad * rng.standard_normal(xy.shape[0])])
        events.append(Scan(t, k, polar))
        truth.append(pose.copy())
        times.append(t)
    return events, np.array(truth), np.array(times)


def road_errors(poses: np.ndarray, truth: np.ndarray) -> dict:
    """The pose's error along the road (x: negative, a lag), across it (y) and in heading (deg):
    mean over the drive and at its end."""
    e = poses - truth
    head = np.degrees(np.angle(np.exp(1j * e[:, 2])))
    return {"along_mean_m": float(e[:, 0].mean()), "along_end_m": float(e[-1, 0]),
            "cross_mean_m": float(e[:, 1].mean()), "cross_end_m": float(e[-1, 1]),
            "heading_mean_deg": float(head.mean()), "heading_end_deg": float(head[-1])}


def road_config(config, view_offset: str):
    """``config`` (a :class:`~radarslam.config.Config`, e.g. the ``automotive`` profile) for the road:
    one radar at the platform's origin (no rig, no Doppler: the gate off), the start at the truth's
    first pose with the anchored std of b.5.1, and ``extent.view_offset``."""
    from dataclasses import replace

    f = replace(config.filter, doppler_gate=False, initial_pose=[0.0, 0.0, 0.0], initial_pose_std=[1e-3, 1e-3, 1e-4])
    return replace(config, filter=f, extent=replace(config.extent, view_offset=view_offset), sensors=[])


def run_road(config, road: Road, seed: int) -> dict:
    """One drive of ``road`` with ``seed``'s draws through EKF-SLAM under ``config``
    (:func:`road_config`): :func:`road_errors` and the number of landmarks at the end."""
    from radarslam.slam import EkfSlam

    f = config.filter
    events, truth, _ = drive(road, f.range_std_m, math.radians(f.azimuth_std_deg), f.speed_std_mps,
                             math.radians(f.turn_rate_std_deg_s), f.noise_interval_s, np.random.default_rng(seed))
    slam = EkfSlam(config)
    poses = [slam.pose.copy() for e in events if slam.process(e) is not None]
    return {**road_errors(np.array(poses), truth), "landmarks": slam.state.n_landmarks}
