"""The ``scatter-centres`` radar spread model (docs/method.md b.4.2): a second, physically motivated
generator of a car's detections, unlike ``visible-faces`` (b.4.1) in where the returns come from and
how many there are.

A car (an axis-aligned rectangle, :class:`~radarslam.simulation.world.Vehicle`) holds eight point
scatterers, its four corners and its four wheel houses, plus two diffuse sources: its faces in view
and its footprint (far-side and under-body returns by multipath). Each source that the sensor can
see emits a Poisson number of potential returns whose mean falls with range; each return is kept
with P_D, like the other models.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.config import RadarConfig
from radarslam.simulation.faces import on_segments, visible_sides
from radarslam.simulation.world import Vehicle


def scatterers(v: Vehicle, wheel_inset_m: float) -> tuple[np.ndarray, np.ndarray]:
    """The eight point scatterers of ``v`` and the sides each one belongs to.

    Parameters
    ----------
    v : Vehicle
    wheel_inset_m : float
        Distance of a wheel centre from the nearer end of the car (m); at most a quarter of the
        length is used, so a short car keeps its wheels apart.

    Returns
    -------
    points : ndarray, shape (8, 2)
        World positions (m): the corners counter-clockwise from ``(x_left, y_bottom)``, then the wheel
        houses (rear-left, front-left, rear-right, front-right in the sense of the long axis; the
        order is fixed, the labels are not used).
    sides : ndarray of bool, shape (8, 4)
        ``sides[i, j]``: scatterer ``i`` lies on side ``j`` (bottom, right, top, left, as in
        ``radar._all_sides``); a scatterer is visible when any of its sides faces the sensor.
    """
    x0, y0, sx, sy = v.x_left, v.y_bottom, v.size_x, v.size_y
    x1, y1 = x0 + sx, y0 + sy
    inset = min(wheel_inset_m, 0.25 * v.length)
    if sx >= sy:     # long axis along x: wheels on the bottom and top sides
        wheels = [(x0 + inset, y0), (x1 - inset, y0), (x0 + inset, y1), (x1 - inset, y1)]
        wheel_sides = [0, 0, 2, 2]
    else:            # long axis along y: wheels on the left and right sides
        wheels = [(x0, y0 + inset), (x0, y1 - inset), (x1, y0 + inset), (x1, y1 - inset)]
        wheel_sides = [3, 3, 1, 1]
    points = np.array([(x0, y0), (x1, y0), (x1, y1), (x0, y1)] + wheels, dtype=float)
    sides = np.zeros((8, 4), dtype=bool)
    for i, (a, b) in enumerate(((3, 0), (0, 1), (1, 2), (2, 3))):   # the two sides meeting at corner i
        sides[i, a] = sides[i, b] = True
    sides[4 + np.arange(4), wheel_sides] = True
    return points, sides


def facing_sides(v: Vehicle, sensor: np.ndarray) -> np.ndarray:
    """Which sides (bottom, right, top, left) have their outward normal towards ``sensor``, ``(4,)`` bool."""
    sx, sy = float(sensor[0]), float(sensor[1])
    return np.array([sy < v.y_bottom, sx > v.x_left + v.size_x, sy > v.y_bottom + v.size_y, sx < v.x_left])


def range_gain(distance_m: float, radar: RadarConfig) -> float:
    """Factor on every mean count at ``distance_m`` from the car's centre (docs/method.md b.4.2):
    ``(r_ref / max(r, r_near))^p``, 1 at the reference range."""
    r = max(distance_m, radar.scatter_near_range_m)
    return (radar.scatter_ref_range_m / r) ** radar.scatter_range_exponent


def expected_counts(v: Vehicle, radar: RadarConfig, sensor: np.ndarray) -> np.ndarray:
    """Mean potential returns of each source, ``(10,)``: the eight scatterers of :func:`scatterers`
    (0 when hidden), the faces in view, the footprint; before P_D (docs/method.md b.4.2)."""
    facing = facing_sides(v, sensor)
    _, sides = scatterers(v, radar.scatter_wheel_inset_m)
    visible = (sides & facing).any(axis=1)
    per = np.array([radar.scatter_corner_points] * 4 + [radar.scatter_wheel_points] * 4)
    width = sum(w for *_, w in visible_sides(v, sensor))
    lam = np.concatenate([np.where(visible, per, 0.0),
                          [radar.scatter_face_points_per_m * width, radar.scatter_underbody_points]])
    return lam * range_gain(math.hypot(*(v.center - sensor)), radar)


def scatter_centre_points(v: Vehicle, radar: RadarConfig, rng: np.random.Generator,
                          sensor: np.ndarray) -> np.ndarray:
    """Kept detection points of one vehicle under ``scatter-centres``, ``(m, 2)`` in the world frame (b.4.2).

    Draws, in this order: the ten Poisson counts of :func:`expected_counts` (one call); the
    scatterer returns' jitter, ``N(0, scatter_jitter_m^2)`` per axis; the face returns' positions,
    uniform by arc length on the sides facing the sensor; the footprint returns, uniform on the
    rectangle; then the P_D thinning of all of them. Points are ordered scatterers (corners, then
    wheel houses), faces, footprint.
    """
    sensor = np.asarray(sensor, dtype=float)[:2]
    counts = rng.poisson(expected_counts(v, radar, sensor))
    points, _ = scatterers(v, radar.scatter_wheel_inset_m)
    n_s = int(counts[:8].sum())
    pts_s = np.repeat(points, counts[:8], axis=0) + radar.scatter_jitter_m * rng.standard_normal((n_s, 2))
    n_f = int(counts[8])
    pts_f = on_segments(visible_sides(v, sensor), n_f, rng) if n_f > 0 else np.empty((0, 2))
    pts_u = rng.random((int(counts[9]), 2)) * v.size + v.corner
    pts = np.concatenate([pts_s, pts_f, pts_u])
    keep = rng.random(pts.shape[0]) < radar.detection_probability
    return pts[keep]
