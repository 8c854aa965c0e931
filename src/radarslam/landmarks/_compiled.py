"""Clustering, Rule 1 / Rule 2, the M/N windows and the merge pair compiled with numba (``filter.backend = "numba"``; docs/architecture.md "Backends").

The reference is scikit-learn's DBSCAN (:func:`.clustering.dbscan_labels`); these loops give the
same labels for one scan's few dozen detections in a few microseconds instead of ~90 us of
neighbour search and object arrays (tests/test_backends.py compares them with scikit-learn).
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
# landmarks.confirmation and landmarks.merging compiled as they are, for the orchestrator's numba
# backend and the fused engine alike.
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


@njit(cache=True)
def dbscan_labels(points, eps, min_samples):  # pragma: no cover - compiled
    """:func:`radarslam.landmarks.clustering.dbscan_labels` compiled for one scan: the exact pairwise
    eps-neighbourhoods (``sqrt(dx^2 + dy^2) <= eps``, the reference's arithmetic) and scikit-learn's
    expansion order (core points in index order start clusters; a depth-first search labels every
    point it reaches and expands only core points, so a border point joins the first cluster that
    reaches it). Equal to ``sklearn.cluster.DBSCAN(eps, min_samples).fit(points).labels_``
    (tests/test_backends.py)."""
    m = points.shape[0]
    labels = np.full(m, -1, dtype=np.int64)
    if m < min_samples or m == 0:
        return labels
    near = np.zeros((m, m), dtype=np.bool_)
    core = np.zeros(m, dtype=np.bool_)
    for i in range(m):
        c = 0
        for j in range(m):
            dx = points[i, 0] - points[j, 0]
            dy = points[i, 1] - points[j, 1]
            if math.sqrt(dx * dx + dy * dy) <= eps:
                near[i, j] = True
                c += 1
        core[i] = c >= min_samples
    stack = np.empty(m * m + 1, dtype=np.int64)
    label = 0
    for start in range(m):
        if labels[start] != -1 or not core[start]:
            continue
        top = 0
        i = start
        while True:
            if labels[i] == -1:
                labels[i] = label
                if core[i]:
                    for j in range(m):
                        if near[i, j] and labels[j] == -1:
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
