"""The evaluation's landmark-to-vehicle matching of every scan in one compiled call.

:func:`radarslam.metrics.landmarks.match` is the reference: per scan, scipy's
``linear_sum_assignment`` on the Euclidean distances, out-of-gate pairs at cost 1e6, then the
out-of-gate pairs dropped. ~20 us of Python per scan. Here the same problem is solved for all
scans at once by the shortest-augmenting-path form of the Hungarian algorithm with dual
potentials (Kuhn-Munkres with Dijkstra-like row insertion; O(n^2 m) for n <= m), written for
numba from the algorithm. Both return an optimal assignment of the same cost matrix; the optimum
is unique unless two assignments cost exactly the same, so the matches are the reference's
(``tests/test_metrics.py`` compares them on random and simulated maps).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: Cost of an out-of-gate pair (as in :func:`radarslam.metrics.landmarks.match`).
BIG = 1e6


@njit(cache=True)
def _assign(cost):  # pragma: no cover - compiled
    """Column assigned to each row of ``cost (n, m)``, ``n <= m``: a minimum-cost assignment of
    every row. Rows are inserted one at a time; each insertion grows a shortest-path tree over the
    columns with the reduced costs ``cost[i, j] - u[i] - v[j]`` and augments along it."""
    n, m = cost.shape
    u = np.zeros(n + 1)
    v = np.zeros(m + 1)
    owner = np.zeros(m + 1, dtype=np.int64)     # 1-based row holding column j; column 0 is the root
    way = np.zeros(m + 1, dtype=np.int64)
    minv = np.empty(m + 1)
    used = np.empty(m + 1, dtype=np.bool_)
    for i in range(1, n + 1):
        owner[0] = i
        j0 = 0
        minv[:] = math.inf
        used[:] = False
        while True:
            used[j0] = True
            i0 = owner[j0]
            delta = math.inf
            j1 = 0
            for j in range(1, m + 1):
                if not used[j]:
                    cur = cost[i0 - 1, j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j] = cur
                        way[j] = j0
                    if minv[j] < delta:
                        delta = minv[j]
                        j1 = j
            for j in range(m + 1):
                if used[j]:
                    u[owner[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if owner[j0] == 0:
                break
        while j0 != 0:                             # augment along the tree
            j1 = way[j0]
            owner[j0] = owner[j1]
            j0 = j1
    out = np.full(n, -1, dtype=np.int64)
    for j in range(1, m + 1):
        if owner[j] != 0:
            out[owner[j] - 1] = j - 1
    return out


@njit(cache=True)
def _match_one(pos, centers, gate):  # pragma: no cover - compiled
    """:func:`radarslam.metrics.landmarks.match` of one scan: vehicle of each landmark, -1 none."""
    n, V = pos.shape[0], centers.shape[0]
    out = np.full(n, -1, dtype=np.int64)
    if n == 0 or V == 0:
        return out
    d = np.empty((n, V))
    for i in range(n):
        for j in range(V):
            dx = pos[i, 0] - centers[j, 0]
            dy = pos[i, 1] - centers[j, 1]
            d[i, j] = math.sqrt(dx * dx + dy * dy)
    cost = np.where(d <= gate, d, BIG)
    if n <= V:
        cols = _assign(cost)
        for i in range(n):
            if d[i, cols[i]] <= gate:
                out[i] = cols[i]
    else:
        rows = _assign(cost.T.copy())
        for j in range(V):
            if d[rows[j], j] <= gate:
                out[rows[j]] = j
    return out


@njit(cache=True)
def match_scans(pos, offsets, centers, vehicles, gate):  # pragma: no cover - compiled
    """Every scan's matching: scan ``k``'s landmarks ``pos[offsets[k]:offsets[k + 1]]`` against the
    vehicles ``centers[vehicles[k]]`` (a boolean row per scan). Returns the vehicle index (into
    ``centers``) of every landmark, -1 for none."""
    out = np.full(pos.shape[0], -1, dtype=np.int64)
    for k in range(offsets.shape[0] - 1):
        a, b = offsets[k], offsets[k + 1]
        if b == a:
            continue
        idx = np.flatnonzero(vehicles[k])
        sub = np.empty((idx.shape[0], 2))
        for j in range(idx.shape[0]):
            sub[j] = centers[idx[j]]
        got = _match_one(pos[a:b], sub, gate)
        for i in range(b - a):
            if got[i] >= 0:
                out[a + i] = idx[got[i]]
    return out
