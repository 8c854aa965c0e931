"""Step 4's associations grouped by landmark (docs/method.md a.8, c.4): one kernel for the
fused engine."""

from __future__ import annotations

import numpy as np


def by_landmark(out: np.ndarray, cidx: np.ndarray, n: int):
    """Step 4's associations grouped by landmark, a kernel: ``out[c]`` is the landmark (or -1) of
    candidate detection ``cidx[c]``; returns ``(aoff (n + 1,), arow)`` with landmark ``j``'s
    detections ``arow[aoff[j]:aoff[j + 1]]`` in ascending candidate order. The fused engine links
    it compiled (:mod:`radarslam.landmarks._compiled`)."""
    cnt = np.zeros(n + 1, dtype=np.int64)
    for c in range(out.shape[0]):
        if out[c] >= 0:
            cnt[out[c] + 1] += 1
    aoff = np.cumsum(cnt)
    arow = np.empty(aoff[n], dtype=np.int64)
    fill = aoff[:-1].copy()
    for c in range(out.shape[0]):
        j = out[c]
        if j >= 0:
            arow[fill[j]] = cidx[c]
            fill[j] += 1
    return aoff, arow


def seen_landmarks(out: np.ndarray, n: int) -> np.ndarray:
    """The landmarks (ascending) that some candidate of ``out`` (landmark or -1) is associated
    with, of ``n``: the stacked updates' rows (a.7.4). A kernel, compiled in :mod:`._compiled`."""
    seen = np.zeros(n, dtype=np.bool_)
    for c in range(out.shape[0]):
        if out[c] >= 0:
            seen[out[c]] = True
    return np.flatnonzero(seen)
