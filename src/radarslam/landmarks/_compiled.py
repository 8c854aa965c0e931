"""Clustering, Rule 1 / Rule 2, the M/N windows and the merge pair compiled with numba (``filter.backend = "numba"``; docs/architecture.md "Backends").

The reference is scikit-learn's DBSCAN (:func:`.clustering.dbscan_labels`); these loops give the
same labels, for one scan's few dozen detections in a few microseconds instead of ~90 us of
neighbour search and object arrays, and for a scan of thousands through a grid of cells
(tests/test_backends.py compares them with scikit-learn).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.jit import compile_kernels
from radarslam.core.angles import wrap_pi_scalar
from radarslam.landmarks.confirmation import in_view, mn_windows, popcount, push_bit, rule12, should_remove
from radarslam.landmarks.merging import closest_pair
from radarslam.landmarks.sifting import candidates
from radarslam.landmarks.grouping import by_landmark, seen_landmarks
from radarslam.landmarks import records
from radarslam.core.arrays import grown, grown_inner

# Sifting's decision, the associations by landmark, Rule 1 / Rule 2, the M/N windows and the merge pair (c.3, c.4, c.7, c.5, c.9): the kernels of
# landmarks.confirmation and landmarks.merging compiled as they are, for the fused engine.
_K = compile_kernels(popcount, push_bit, should_remove, mn_windows, rule12, closest_pair, candidates, by_landmark,
                     seen_landmarks, wrap_pi_scalar, in_view, grown, grown_inner, *records.KERNELS)
# The landmark records' growth, birth and removal (landmarks.records), for the fused engine.
compiled_with_room = _K["with_room"]
#: core.arrays.grown compiled: the fused engine's arrays grow by the records' rule.
compiled_grown = _K["grown"]
compiled_grown_inner = _K["grown_inner"]
compiled_add_record = _K["add_record"]
compiled_compact_records = _K["compact_records"]
compiled_seen_landmarks = _K["seen_landmarks"]
compiled_by_landmark = _K["by_landmark"]
compiled_candidates = _K["candidates"]
compiled_mn_windows = _K["mn_windows"]
compiled_in_view = _K["in_view"]
compiled_rule12 = _K["rule12"]
compiled_closest_pair = _K["closest_pair"]


#: A grid cell's side over ``eps``: just above 1, so that two points within ``eps`` of each other lie
#: in neighbouring cells whatever the rounding of ``(x - x0) / side`` (its relative error, ~1e-16
#: times the number of cells across the scan, stays far below the margin).
CELL_MARGIN = 1.0 + 1e-6
#: The most cells along one axis; a scan wider than this many ``eps`` gets larger cells (still exact).
MAX_CELLS = 1 << 20
#: Up to this many points the neighbourhoods come from every pair (a few dozen detections: 5 us
#: against 19 us through the grid for 40); above it from the grid (memory and time with the
#: neighbours, not ``m^2``). Both give the same ``(off, idx)``.
PAIRWISE_MAX = 256


@njit(cache=True)
def _cells(points, eps):  # pragma: no cover - compiled
    """Each point's grid cell ``(cx, cy)`` (int64) for cells of side :data:`CELL_MARGIN` ``eps`` (at
    least the scan's span over :data:`MAX_CELLS`), and the rows of the grid ``ny`` (with room for a
    cell's neighbours, so that ``cx * ny + cy`` names one cell)."""
    m = points.shape[0]
    x0, y0, x1, y1 = points[0, 0], points[0, 1], points[0, 0], points[0, 1]
    for i in range(m):
        x0, x1 = min(x0, points[i, 0]), max(x1, points[i, 0])
        y0, y1 = min(y0, points[i, 1]), max(y1, points[i, 1])
    side = max(eps * CELL_MARGIN, max(x1 - x0, y1 - y0) / MAX_CELLS)
    if not side > 0.0:
        side = 1.0                                     # eps = 0 and one point: any cell
    cx = np.empty(m, dtype=np.int64)
    cy = np.empty(m, dtype=np.int64)
    for i in range(m):
        cx[i] = np.int64(math.floor((points[i, 0] - x0) / side))
        cy[i] = np.int64(math.floor((points[i, 1] - y0) / side))
    return cx, cy, cy.max() + 3


@njit(cache=True)
def _slot(key, size):  # pragma: no cover - compiled
    """The first slot of ``key`` in a table of ``size`` (a power of two) slots (multiplicative hash)."""
    return (key * 2654435761) & (size - 1)


@njit(cache=True)
def _cell_table(key):  # pragma: no cover - compiled
    """The occupied cells of the points' cell keys ``key`` (m,) (each >= 0): an open-addressing table
    ``(slot_key, slot_cell)`` from a key to its cell's number, and each cell's points, ascending,
    ``members[start[c]:start[c + 1]]`` (a counting sort)."""
    m = key.shape[0]
    size = 1
    while size < 2 * m:
        size *= 2
    slot_key = np.full(size, -1, dtype=np.int64)
    slot_cell = np.empty(size, dtype=np.int64)
    cell_of = np.empty(m, dtype=np.int64)
    n_cells = 0
    for i in range(m):
        h = _slot(key[i], size)
        while slot_key[h] != -1 and slot_key[h] != key[i]:
            h = (h + 1) & (size - 1)
        if slot_key[h] == -1:
            slot_key[h] = key[i]
            slot_cell[h] = n_cells
            n_cells += 1
        cell_of[i] = slot_cell[h]
    start = np.zeros(n_cells + 1, dtype=np.int64)
    for i in range(m):
        start[cell_of[i] + 1] += 1
    for c in range(n_cells):
        start[c + 1] += start[c]
    fill = start[:n_cells].copy()
    members = np.empty(m, dtype=np.int64)
    for i in range(m):
        members[fill[cell_of[i]]] = i
        fill[cell_of[i]] += 1
    return slot_key, slot_cell, start, members


@njit(cache=True)
def _cell_of(slot_key, slot_cell, key):  # pragma: no cover - compiled
    """The number of the cell of ``key`` in :func:`_cell_table`'s table, -1 when no point is in it."""
    size = slot_key.shape[0]
    h = _slot(key, size)
    while slot_key[h] != -1:
        if slot_key[h] == key:
            return slot_cell[h]
        h = (h + 1) & (size - 1)
    return -1


@njit(cache=True)
def _neighbour_pass(points, eps, cx, cy, ny, table, off, idx, fill):  # pragma: no cover - compiled
    """One pass over every point's 3 x 3 cells: its neighbours within ``eps`` (the exact test
    ``sqrt(dx^2 + dy^2) <= eps``, itself included) counted into ``off[i + 1]``, or with ``fill``
    written to ``idx`` from ``off[i]`` in ascending order (an insertion sort: a few dozen each)."""
    slot_key, slot_cell, start, members = table
    for i in range(points.shape[0]):
        n = 0
        for ddx in range(-1, 2):
            for ddy in range(-1, 2):
                c = _cell_of(slot_key, slot_cell, (cx[i] + ddx) * ny + (cy[i] + ddy))
                if c < 0:
                    continue
                for t in range(start[c], start[c + 1]):
                    j = members[t]
                    dx = points[i, 0] - points[j, 0]
                    dy = points[i, 1] - points[j, 1]
                    if math.sqrt(dx * dx + dy * dy) <= eps:
                        if fill:
                            a = off[i] + n
                            while a > off[i] and idx[a - 1] > j:
                                idx[a] = idx[a - 1]
                                a -= 1
                            idx[a] = j
                        n += 1
        if not fill:
            off[i + 1] = n


@njit(cache=True)
def _pairwise(points, eps):  # pragma: no cover - compiled
    """:func:`neighbourhoods` by testing every pair (:data:`PAIRWISE_MAX`)."""
    m = points.shape[0]
    near = np.zeros((m, m), dtype=np.bool_)
    off = np.zeros(m + 1, dtype=np.int64)
    for i in range(m):
        n = 0
        for j in range(m):
            dx = points[i, 0] - points[j, 0]
            dy = points[i, 1] - points[j, 1]
            if math.sqrt(dx * dx + dy * dy) <= eps:
                near[i, j] = True
                n += 1
        off[i + 1] = off[i] + n
    idx = np.empty(off[m], dtype=np.int64)
    t = 0
    for i in range(m):
        for j in range(m):
            if near[i, j]:
                idx[t] = j
                t += 1
    return off, idx


@njit(cache=True)
def neighbourhoods(points, eps):  # pragma: no cover - compiled
    """Every point's eps-neighbourhood ``(off, idx)``: point ``i``'s neighbours (itself included) are
    ``idx[off[i]:off[i + 1]]``, ascending, as scikit-learn's radius search sorts them. Up to
    :data:`PAIRWISE_MAX` points from every pair; above, through a grid of cells just wider than
    ``eps``, so that memory and time grow with the neighbours, not with ``m^2``, and a scan of any
    size clusters."""
    m = points.shape[0]
    if m <= PAIRWISE_MAX:
        return _pairwise(points, eps)
    cx, cy, ny = _cells(points, eps)
    table = _cell_table(cx * ny + cy)
    off = np.zeros(m + 1, dtype=np.int64)
    fill = m < 0                     # a bool, not a literal: one compiled pass for both calls
    _neighbour_pass(points, eps, cx, cy, ny, table, off, off, fill)
    for i in range(m):
        off[i + 1] += off[i]
    idx = np.empty(off[m], dtype=np.int64)
    _neighbour_pass(points, eps, cx, cy, ny, table, off, idx, not fill)
    return off, idx


@njit(cache=True)
def dbscan_labels(points, eps, min_samples):  # pragma: no cover - compiled
    """:func:`radarslam.landmarks.clustering.dbscan_labels` compiled for one scan of any size: the
    exact eps-neighbourhoods (``sqrt(dx^2 + dy^2) <= eps``, the reference's arithmetic, by
    :func:`neighbourhoods`) and scikit-learn's expansion order (core points in index order start
    clusters; a depth-first search labels every point it reaches and expands only core points, so a
    border point joins the first cluster that reaches it). Equal to
    ``sklearn.cluster.DBSCAN(eps, min_samples).fit(points).labels_`` (tests/test_backends.py)."""
    m = points.shape[0]
    labels = np.full(m, -1, dtype=np.int64)
    if m < min_samples or m == 0:
        return labels
    off, idx = neighbourhoods(points, eps)
    stack = np.empty(idx.shape[0] + 1, dtype=np.int64)   # each neighbour is pushed at most once
    label = 0
    for start in range(m):
        if labels[start] != -1 or off[start + 1] - off[start] < min_samples:
            continue
        top = 0
        i = start
        while True:
            if labels[i] == -1:
                labels[i] = label
                if off[i + 1] - off[i] >= min_samples:
                    for t in range(off[i], off[i + 1]):
                        j = idx[t]
                        if labels[j] == -1:
                            stack[top] = j
                            top += 1
            if top == 0:
                break
            top -= 1
            i = stack[top]
        label += 1
    return labels


@njit(cache=True)
def dbscan_centres(ranges, labels):  # pragma: no cover - compiled
    """The row of each cluster's centre, the member of smallest range, first on ties (h.13; as
    ``np.argmin`` in :func:`radarslam.landmarks.clustering.clusters_of`); clusters in label order."""
    n = labels.max() + 1 if labels.shape[0] else 0
    best = np.full(max(n, 0), -1, dtype=np.int64)
    for i in range(labels.shape[0]):
        lab = labels[i]
        if lab >= 0 and (best[lab] < 0 or ranges[i] < ranges[best[lab]]):
            best[lab] = i
    return best
