"""Whole-state loops of the engine's steps (slam/fused/): the finiteness check, the prediction's
cross-covariance rows and their write-back (c.2, c.11.2), and the removal of landmarks' rows. They
live outside ``slam/fused/`` so that the engine's steps form (slam/fused/engine.py ``form``) keeps them
compiled instead of running O(n^2) loops in Python; the compiled engine inlines the first three."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

@njit(cache=True, inline="always")
def all_finite(x, P):  # pragma: no cover - compiled
    """True when every entry of the mean ``x`` and the covariance ``P`` is finite."""
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return False
    for i in range(P.shape[0]):
        for j in range(P.shape[1]):
            if not math.isfinite(P[i, j]):
                return False
    return True


@njit(cache=True, inline="always")
def pose_cross_rows(Fx, P):  # pragma: no cover - compiled
    """``F_x P[:3, 3:]``, the predicted pose's cross-covariance with the rest of the state (c.2),
    ``(3, n - 3)``, and whether every entry is finite."""
    n = P.shape[0]
    Ppl = np.empty((3, n - 3))
    ok = True
    for i in range(3):
        for j in range(3, n):
            s = 0.0
            for k in range(3):
                s += Fx[i, k] * P[k, j]
            Ppl[i, j - 3] = s
            ok = ok and math.isfinite(s)
    return Ppl, ok


@njit(cache=True, inline="always")
def write_platform_rows(P, Pss, Psl):  # pragma: no cover - compiled
    """Write a predicted platform block ``Pss (p, p)`` and its cross-covariance with the landmarks
    ``Psl (p, n - p)`` into ``P``, in place and symmetric (c.2, c.11.2)."""
    p, n = Pss.shape[0], P.shape[0]
    for i in range(p):
        for j in range(p):
            P[i, j] = Pss[i, j]
        for j in range(p, n):
            P[i, j] = Psl[i, j - p]
            P[j, i] = Psl[i, j - p]


@njit(cache=True)
def drop_state_rows(x, P, keep):  # pragma: no cover - compiled
    """``x`` and ``P`` without the landmarks whose ``keep`` is False (ekf.remove_landmarks); the
    platform block is what precedes the ``keep.shape[0]`` landmarks."""
    N = keep.shape[0]
    p = x.shape[0] - 2 * N
    rows = np.empty(p + 2 * N, dtype=np.int64)
    n = 0
    for i in range(p):
        rows[n] = i
        n += 1
    for j in range(N):
        if keep[j]:
            rows[n] = p + 2 * j
            rows[n + 1] = p + 1 + 2 * j
            n += 2
    x_new = np.empty(n)
    P_new = np.empty((n, n))
    for a in range(n):
        x_new[a] = x[rows[a]]
        for b in range(n):
            P_new[a, b] = P[rows[a], rows[b]]
    return x_new, P_new
