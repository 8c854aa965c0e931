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


def next_merge(positions: np.ndarray, created: np.ndarray, ids: np.ndarray, distance: float,
               axis_tol: float = math.inf) -> tuple[int, int] | None:
    """The closest eligible pair as ``(keep, drop)`` indices, or None.

    The older landmark (smaller ``created``, then smaller id) survives; the later-created one is
    deleted without fusion (c.9).
    """
    pairs = merge_candidates(positions, distance, axis_tol)
    if not pairs:
        return None
    i, j, _ = pairs[0]
    if (created[j], ids[j]) < (created[i], ids[i]):
        i, j = j, i
    return i, j
