"""The 'ideal' radar of both papers (docs/method.md b.4)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.config import RadarConfig
from radarslam.core.angles import wrap_pi
from radarslam.simulation.world import Vehicle

#: Source label of a clutter detection in :attr:`GroundTruth.sources`.
CLUTTER = -1


def vehicle_points(v: Vehicle, radar: RadarConfig, rng: np.random.Generator) -> np.ndarray:
    """Kept detection points of one in-range vehicle, ``(m, 2)`` in the world frame.

    ``n = floor(N(0.8 A, 1.5))`` potential points uniform on the rectangle, each kept with P_D.
    """
    n = math.floor(radar.points_per_m2 * v.area + math.sqrt(radar.points_var) * rng.standard_normal())
    if n <= 0:
        return np.empty((0, 2))
    pts = rng.random((n, 2)) * [v.size_x, v.size_y] + [v.x_left, v.y_bottom]
    keep = rng.random(n) < radar.detection_probability
    return pts[keep]


def clutter_points(pose: np.ndarray, radar: RadarConfig, rng: np.random.Generator) -> np.ndarray:
    """Poisson clutter on the scene grid, kept within range of the true platform, ``(c, 2)``.

    Positions are the centres of a ``clutter_grid_m`` grid over the square scene ([PROP]: the
    reference code's ``-15 + 0.2 floor(300 U) - 0.1`` sits half a cell off its own grid).
    """
    side = radar.scene_max_m - radar.scene_min_m
    n = rng.poisson(radar.clutter_rate_per_m2 * side * side)
    cells = max(1, int(round(side / radar.clutter_grid_m)))
    pts = radar.scene_min_m + (np.floor(cells * rng.random((n, 2))) + 0.5) * (side / cells)
    d = pts - pose[:2]
    return pts[d[:, 0] ** 2 + d[:, 1] ** 2 <= radar.max_range_m**2]


def simulate_scan(pose: np.ndarray, vehicles: list[Vehicle], k: int, radar: RadarConfig,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """One scan from the true ``pose`` at step ``k``.

    Returns
    -------
    polar : ndarray, shape (m, 2)
        ``[range, azimuth]``; vehicle detections carry range and azimuth noise, clutter none.
    sources : ndarray of int, shape (m,)
        Index of the vehicle that produced each detection, :data:`CLUTTER` for clutter.
    """
    pts, src = [], []
    for v in vehicles:
        if not v.present(k):
            continue
        c = v.center
        if math.hypot(c[0] - pose[0], c[1] - pose[1]) > radar.max_range_m:
            continue
        p = vehicle_points(v, radar, rng)
        pts.append(p)
        src.append(np.full(p.shape[0], v.index))
    xy = np.concatenate(pts) if pts else np.empty((0, 2))
    d = xy - pose[:2]
    polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
    polar[:, 0] += radar.range_std_m * rng.standard_normal(polar.shape[0])
    polar[:, 1] += math.radians(radar.azimuth_std_deg) * rng.standard_normal(polar.shape[0])
    flip = polar[:, 0] < 0.0  # a noisy range below zero is the same point seen the other way
    polar[flip, 0] *= -1.0
    polar[flip, 1] += math.pi
    clutter = clutter_points(pose, radar, rng)
    dc = clutter - pose[:2]
    polar_c = np.column_stack([np.hypot(dc[:, 0], dc[:, 1]), np.arctan2(dc[:, 1], dc[:, 0]) - pose[2]])
    polar = np.concatenate([polar, polar_c])
    polar[:, 1] = wrap_pi(polar[:, 1]) if polar.shape[0] else polar[:, 1]
    sources = np.concatenate([np.concatenate(src) if src else np.empty(0, int),
                              np.full(clutter.shape[0], CLUTTER)]).astype(int)
    if radar.shuffle_detections and polar.shape[0] > 1:
        order = rng.permutation(polar.shape[0])
        polar, sources = polar[order], sources[order]
    return polar, sources
