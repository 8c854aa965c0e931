"""Landmark merging (docs/method.md c.9)."""

from __future__ import annotations

import math

import numpy as np


#: Up to this many landmarks the candidate pairs come from all pairwise distances, beyond from a kd-tree.
DENSE_MAX = 64


def merge_candidates(positions: np.ndarray, distance: float, axis_tol: float = math.inf) -> list[tuple[int, int, float]]:
    """Pairs ``(i, j, d)`` with ``i < j``, ``d < distance`` and ``|dx| <= axis_tol or |dy| <= axis_tol``,
    sorted by increasing ``d``."""
    n = positions.shape[0]
    if n < 2 or not distance > 0:
        return []
    # Only pairs within ``distance``, in the row-major order of the upper triangle so that equal
    # distances keep that order: all pairs for a small map (one n x n pass, ~10 us), a kd-tree
    # beyond (O(n log n) instead of n (n - 1) / 2 pairs).
    if n <= DENSE_MAX:
        d = positions[:, None, :] - positions[None, :, :]
        ii, jj = np.nonzero(np.triu(np.hypot(d[..., 0], d[..., 1]) < distance, 1))
    else:
        from scipy.spatial import cKDTree

        pairs = cKDTree(positions).query_pairs(distance, output_type="ndarray")
        pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))] if pairs.size else pairs.reshape(0, 2)
        ii, jj = pairs[:, 0], pairs[:, 1]
    if not ii.size:
        return []
    diff = positions[ii] - positions[jj]
    dd = np.hypot(diff[:, 0], diff[:, 1])
    ok = dd < distance
    if math.isfinite(axis_tol):
        ok &= (np.abs(diff[:, 0]) <= axis_tol) | (np.abs(diff[:, 1]) <= axis_tol)
    ii, jj, dd = ii[ok], jj[ok], dd[ok]
    order = np.argsort(dd, kind="stable")
    return [(int(ii[o]), int(jj[o]), float(dd[o])) for o in order]


def closest_pair(positions, created, ids, distance, axis_tol):
    """The closest eligible pair of landmarks (c.9) as ``(keep, drop)`` indices, ``(-1, -1)`` for
    none; a kernel (``core.jit``): the fused engine's merge step compiles it as it is.

    Eligible: ``d < distance`` and, with a finite ``axis_tol``, ``|dx| <= axis_tol or |dy| <=
    axis_tol``; the first of equal distances in the row-major order of the upper triangle. The
    older landmark (smaller ``created``, then smaller id) survives; the later-created one is deleted
    without fusion."""
    n = positions.shape[0]
    bi, bj, bd = -1, -1, math.inf
    if not distance > 0:
        return -1, -1
    for i in range(n):
        for j in range(i + 1, n):
            dx = positions[i, 0] - positions[j, 0]
            dy = positions[i, 1] - positions[j, 1]
            if not (abs(dx) < distance and abs(dy) < distance):
                continue            # hypot(dx, dy) >= max(|dx|, |dy|): out of reach, exactly
            dd = np.hypot(dx, dy)
            if not dd < distance:
                continue
            if math.isfinite(axis_tol) and not (abs(dx) <= axis_tol or abs(dy) <= axis_tol):
                continue
            if dd < bd:
                bi, bj, bd = i, j, dd
    if bi < 0:
        return -1, -1
    if created[bj] < created[bi] or (created[bj] == created[bi] and ids[bj] < ids[bi]):
        bi, bj = bj, bi
    return bi, bj


