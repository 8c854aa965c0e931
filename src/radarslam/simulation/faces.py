"""The outline of a simulated car as a radar sees it: its sides, the sides facing a sensor, and points
spread over them by arc length (docs/method.md b.4)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.simulation.world import Vehicle


def all_sides(v: Vehicle) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """The four sides as ``(start (2,), end (2,), weight)``, counter-clockwise."""
    x0, y0, x1, y1 = v.x_left, v.y_bottom, v.x_left + v.size_x, v.y_bottom + v.size_y
    c = [np.array(p, dtype=float) for p in ((x0, y0), (x1, y0), (x1, y1), (x0, y1))]
    return [(c[i], c[(i + 1) % 4], 0.0) for i in range(4)]


def visible_sides(v: Vehicle, sensor: np.ndarray) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """The sides facing ``sensor``, each with its length projected across the line of sight to the
    car's centre (the width it presents)."""
    los = v.center - sensor
    dist = math.hypot(los[0], los[1])
    u = los / dist if dist > 0 else np.array([1.0, 0.0])
    out = []
    for a, b, _ in all_sides(v):
        edge = b - a
        normal = np.array([edge[1], -edge[0]])           # outward for a counter-clockwise outline
        if float(normal @ (sensor - 0.5 * (a + b))) > 0.0:
            out.append((a, b, abs(float(edge[0] * u[1] - edge[1] * u[0]))))
    return out


def on_segments(sides, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points uniform by arc length over the segments ``sides``."""
    lengths = np.array([math.hypot(*(b - a)) for a, b, _ in sides])
    s = rng.random(n) * lengths.sum()
    edges = np.concatenate([[0.0], np.cumsum(lengths)])
    i = np.clip(np.searchsorted(edges, s, side="right") - 1, 0, len(sides) - 1)
    t = (s - edges[i]) / lengths[i]
    a = np.array([sides[j][0] for j in i])
    b = np.array([sides[j][1] for j in i])
    return a + t[:, None] * (b - a)
