"""The scans of a trial simulated in one compiled call (the surface spread model, docs/method.md b.4).

:func:`radarslam.simulation.radar.simulate_scan` is the reference: one Python call per scan and per
vehicle in range, ~0.2 ms a scan. :func:`simulate_scans` runs the same draws in the same order over
every scan inside numba. numba's ``numpy.random.Generator`` methods share the generator's state and
algorithms with numpy, so the detections are the reference's bit for bit
(``tests/test_simulation.py`` compares whole scenarios), and the generator leaves in the same state.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.angles import wrap_pi

@njit(cache=True)
def _grow(a, n):  # pragma: no cover - compiled
    """``a`` with ``n`` rows, the old ones kept."""
    b = np.empty((n,) + a.shape[1:], dtype=a.dtype)
    b[:a.shape[0]] = a
    return b


@njit(cache=True)
def simulate_scans(poses, rects, departures, ids, rng, points_per_m2, points_std, p_detect, clutter_rate, scene_min,
                   scene_max, clutter_grid, max_range, shuffle):  # pragma: no cover - compiled
    """Scans ``k = 1..K`` from the true ``poses (K, 3)`` of the vehicles ``rects (V, 4)``
    (``[x_left, y_bottom, size_x, size_y]``, present while ``k < departures[v]``, labelled ``ids[v]``).

    Only the draws happen here, in the reference's order; the arithmetic that numpy vectorises
    (``hypot``, ``arctan2``, whose SIMD forms may differ from the scalar ones in the last bit) is
    left to :func:`simulate`, which applies it to every scan at once. Returns ``(offsets (K + 1,),
    xy (M, 2), noise (M, 2), vehicle (M,), sources (M,), gather (M,))``: scan ``k`` owns rows
    ``offsets[k - 1]:offsets[k]``: its world-frame points, vehicle points first, then clutter; the
    range and azimuth noise of each (zero for clutter); which are vehicle points; the source of each
    (vehicle id, -1 clutter); and ``gather``, the rows in the order of the scan's shuffle.
    """
    K = poses.shape[0]
    V = rects.shape[0]
    offsets = np.zeros(K + 1, dtype=np.int64)
    cap = 1024
    xy_all = np.empty((cap, 2))
    noise_all = np.empty((cap, 2))
    src_all = np.empty(cap, dtype=np.int64)
    vehicle = np.empty(cap, dtype=np.bool_)
    gather = np.empty(cap, dtype=np.int64)
    side = scene_max - scene_min
    cells = max(1, int(round(side / clutter_grid)))
    step = side / cells
    lam = clutter_rate * side * side
    for k in range(1, K + 1):
        px, py = poses[k - 1, 0], poses[k - 1, 1]
        # vehicle points (simulate_scan / vehicle_points, surface model)
        xs = np.empty((0, 2))
        owners = np.empty(0, dtype=np.int64)
        for v in range(V):
            if not k < departures[v]:
                continue
            x0, y0, sx, sy = rects[v, 0], rects[v, 1], rects[v, 2], rects[v, 3]
            if math.hypot(x0 + 0.5 * sx - px, y0 + 0.5 * sy - py) > max_range:
                continue
            noise = points_std * rng.standard_normal()
            n = math.floor(points_per_m2 * (sx * sy) + noise)
            if n <= 0:
                continue
            u = rng.random((n, 2))
            keep = rng.random(n) < p_detect
            nk = 0
            for i in range(n):
                if keep[i]:
                    nk += 1
            pts = np.empty((nk, 2))
            q = 0
            for i in range(n):
                if keep[i]:
                    pts[q, 0] = u[i, 0] * sx + x0
                    pts[q, 1] = u[i, 1] * sy + y0
                    q += 1
            xs = np.concatenate((xs, pts))
            owners = np.concatenate((owners, np.full(nk, ids[v], dtype=np.int64)))
        m = xs.shape[0]
        nr = rng.standard_normal(m)       # range and azimuth noise of the vehicle points
        na = rng.standard_normal(m)
        # clutter (clutter_points)
        nc = rng.poisson(lam)
        cu = rng.random((nc, 2))
        pc = np.empty((nc, 2))
        q = 0
        for i in range(nc):
            cx = scene_min + (math.floor(cells * cu[i, 0]) + 0.5) * step
            cy = scene_min + (math.floor(cells * cu[i, 1]) + 0.5) * step
            dx, dy = cx - px, cy - py
            if dx ** 2 + dy ** 2 <= max_range ** 2:
                pc[q, 0], pc[q, 1] = cx, cy
                q += 1
        total = m + q
        order = np.arange(total)
        if shuffle and total > 1:
            order = rng.permutation(total)
        base = offsets[k - 1]
        if base + total > xy_all.shape[0]:
            grow = max(base + total, 2 * xy_all.shape[0])
            xy_all = _grow(xy_all, grow)
            noise_all = _grow(noise_all, grow)
            src_all = _grow(src_all, grow)
            vehicle = _grow(vehicle, grow)
            gather = _grow(gather, grow)
        xy_all[base:base + m] = xs
        xy_all[base + m:base + total] = pc[:q]
        noise_all[base:base + m, 0] = nr
        noise_all[base:base + m, 1] = na
        noise_all[base + m:base + total] = 0.0
        src_all[base:base + m] = owners
        src_all[base + m:base + total] = -1
        vehicle[base:base + m] = True
        vehicle[base + m:base + total] = False
        for i in range(total):
            gather[base + i] = base + order[i]
        offsets[k] = base + total
    M = offsets[K]
    return offsets, xy_all[:M], noise_all[:M], vehicle[:M], src_all[:M], gather[:M]


def simulate(poses: np.ndarray, vehicles, radar, rng: np.random.Generator, true_azimuth: bool = False):
    """Every scan of :func:`radarslam.simulation.radar.simulate_scan` from the true ``poses``:
    ``(offsets, polar, sources)``, scan ``k`` in rows ``offsets[k - 1]:offsets[k]``. The draws come
    from :func:`simulate_scans`; the conversion to range and azimuth, the noise, the flip of
    negative ranges, the wrap and the shuffle are the reference's numpy operations, on all scans at
    once. ``true_azimuth``: also the noise-free azimuths (the Doppler's, b.4.3), the draws unchanged."""
    rects = np.array([[v.x_left, v.y_bottom, v.size_x, v.size_y] for v in vehicles], dtype=float).reshape(-1, 4)
    never = np.iinfo(np.int64).max
    departures = np.array([never if v.departure is None else v.departure for v in vehicles], dtype=np.int64)
    ids = np.array([v.index for v in vehicles], dtype=np.int64)
    offsets, xy, noise, vehicle, sources, gather = simulate_scans(
        np.ascontiguousarray(poses, dtype=float), rects, departures, ids, rng, float(radar.points_per_m2),
        math.sqrt(radar.points_var), float(radar.detection_probability), float(radar.clutter_rate_per_m2),
        float(radar.scene_min_m), float(radar.scene_max_m), float(radar.clutter_grid_m), float(radar.max_range_m),
        bool(radar.shuffle_detections))
    pose = np.repeat(np.asarray(poses, dtype=float), np.diff(offsets), axis=0)
    d = xy - pose[:, :2]
    polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[:, 2]])
    az0 = polar[:, 1].copy() if true_azimuth else None
    v = np.flatnonzero(vehicle)
    polar[v, 0] += radar.range_std_m * noise[v, 0]
    polar[v, 1] += math.radians(radar.azimuth_std_deg) * noise[v, 1]
    flip = vehicle & (polar[:, 0] < 0.0)   # a noisy range below zero is the same point seen the other way
    polar[flip, 0] *= -1.0
    polar[flip, 1] += math.pi
    polar[:, 1] = wrap_pi(polar[:, 1])
    if true_azimuth:
        return offsets, polar[gather], sources[gather], az0[gather]
    return offsets, polar[gather], sources[gather]
