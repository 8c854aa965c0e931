"""The 'ideal' radar of both papers (docs/method.md b.4)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.config import RadarConfig
from radarslam.core.angles import wrap_pi
from radarslam.core.errors import InputError
from radarslam.simulation.faces import all_sides, on_segments, visible_sides
from radarslam.simulation.world import Vehicle

#: Source label of a clutter detection in :attr:`GroundTruth.sources`.
CLUTTER = -1


def vehicle_points(v: Vehicle, radar: RadarConfig, rng: np.random.Generator,
                   sensor: np.ndarray | None = None) -> np.ndarray:
    """Kept detection points of one in-range vehicle, ``(m, 2)`` in the world frame (b.4, b.4.1).

    ``radar.spread_model``:

    - ``"surface"`` (the paper's): ``n = floor(N(0.8 A, 1.5))`` potential points uniform on the
      rectangle;
    - ``"contour"``: the same count, uniform along the outline (by arc length);
    - ``"visible-faces"``: on the sides whose outward normal points towards the ``sensor`` position,
      uniform by arc length, ``n = floor(N(points_per_m w, 1.5))`` with ``w`` the width of the
      rectangle seen from the sensor (the sum of the visible sides' lengths projected across the line
      of sight): a car seen broadside gets more points than one seen end-on;
    - ``"scatter-centres"``: Poisson returns from the visible corners and wheel houses, the visible
      faces and the footprint, fewer with range (b.4.2,
      :func:`radarslam.simulation.scatterers.scatter_centre_points`).

    Each potential point is kept with P_D.
    """
    model = radar.spread_model
    if model == "scatter-centres":     # docs/method.md b.4.2; never compiled (simulation._compiled: surface only)
        if sensor is None:
            raise InputError("sensor: expected the sensor position (2,) for radar.spread_model = 'scatter-centres', "
                             "got None")
        from radarslam.simulation.scatterers import scatter_centre_points   # it builds on this module

        return scatter_centre_points(v, radar, rng, sensor)
    noise = math.sqrt(radar.points_var) * rng.standard_normal()
    if model == "visible-faces":
        if sensor is None:
            raise InputError("sensor: expected the sensor position (2,) for radar.spread_model = 'visible-faces', got None")
        sides = visible_sides(v, np.asarray(sensor, dtype=float)[:2])
        n = math.floor(radar.points_per_m * sum(w for *_, w in sides) + noise)
    else:
        sides = None
        n = math.floor(radar.points_per_m2 * v.area + noise)
    if n <= 0:
        return np.empty((0, 2))
    if model == "surface":
        pts = rng.random((n, 2))
        pts *= v.size
        pts += v.corner
    else:
        if sides is None:
            sides = all_sides(v)
        pts = on_segments(sides, n, rng)
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
                  rng: np.random.Generator, *, true_azimuth: bool = False):
    """One scan from the true ``pose`` at step ``k``.

    Returns
    -------
    polar : ndarray, shape (m, 2)
        ``[range, azimuth]``; vehicle detections carry range and azimuth noise, clutter none.
    sources : ndarray of int, shape (m,)
        Index of the vehicle that produced each detection, :data:`CLUTTER` for clutter.
    true_az : ndarray, shape (m,)
        Only with ``true_azimuth``: the noise-free azimuths (rad, not wrapped), for the Doppler
        (b.4.3); the draws are the same either way.
    """
    pts, owners, counts = [], [], []
    px, py = float(pose[0]), float(pose[1])
    for v in vehicles:
        if not v.present(k):
            continue
        if math.hypot(v.x_left + 0.5 * v.size_x - px, v.y_bottom + 0.5 * v.size_y - py) > radar.max_range_m:
            continue
        p = vehicle_points(v, radar, rng, pose[:2])
        pts.append(p)
        owners.append(v.index)
        counts.append(p.shape[0])
    xy = np.concatenate(pts) if pts else np.empty((0, 2))
    d = xy - pose[:2]
    polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
    az0 = polar[:, 1].copy() if true_azimuth else None
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
    sources = np.concatenate([np.repeat(np.array(owners, dtype=int), counts),
                              np.full(clutter.shape[0], CLUTTER, dtype=int)])
    if true_azimuth:
        az0 = np.concatenate([az0, polar_c[:, 1]])
    if radar.shuffle_detections and polar.shape[0] > 1:
        order = rng.permutation(polar.shape[0])
        polar, sources = polar[order], sources[order]
        az0 = az0[order] if true_azimuth else None
    return (polar, sources, az0) if true_azimuth else (polar, sources)
