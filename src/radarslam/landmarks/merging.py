"""Landmark merging (docs/method.md c.9)."""

from __future__ import annotations

import math

import numpy as np


def merge_candidates(positions: np.ndarray, distance: float, axis_tol: float = math.inf) -> list[tuple[int, int, float]]:
    """Pairs ``(i, j, d)`` with ``i < j``, ``d < distance`` and ``|dx| <= axis_tol or |dy| <= axis_tol``,
    sorted by increasing ``d``."""
    n = positions.shape[0]
    if n < 2:
        return []
    diff = positions[:, None, :] - positions[None, :, :]
    d = np.hypot(diff[..., 0], diff[..., 1])
    ii, jj = np.triu_indices(n, 1)
    dd = d[ii, jj]
    ok = dd < distance
    if math.isfinite(axis_tol):
        ok &= (np.abs(diff[ii, jj, 0]) <= axis_tol) | (np.abs(diff[ii, jj, 1]) <= axis_tol)
    order = np.argsort(dd[ok], kind="stable")
    return [(int(ii[ok][o]), int(jj[ok][o]), float(dd[ok][o])) for o in order]


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
