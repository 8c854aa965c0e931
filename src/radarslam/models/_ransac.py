"""RANSAC on one scan's Doppler (docs/method.md c.10.2), compiled with numba: minimal sets drawn
from a ``numpy.random.Generator`` (numba's draws share the generator's state and equal numpy's),
the consensus, and the least squares on it refined once. :mod:`radarslam.models.doppler_kernels`
builds the fit on it; :func:`radarslam.models.doppler.fit_ego_velocity` calls that.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _solve_small(A, b, dim):  # pragma: no cover - compiled
    """``A x = b`` for ``dim`` 2 or 3 by Cramer's rule; ``ok`` False when (nearly) singular."""
    x = np.zeros(dim)
    if dim == 2:
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        if abs(det) < 1e-9:
            return x, False
        x[0] = (b[0] * A[1, 1] - A[0, 1] * b[1]) / det
        x[1] = (A[0, 0] * b[1] - b[0] * A[1, 0]) / det
        return x, True
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    if abs(det) < 1e-9:
        return x, False
    inv = np.empty((3, 3))
    inv[0, 0], inv[1, 0], inv[2, 0] = c00, c01, c02
    inv[0, 1] = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
    inv[1, 1] = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
    inv[2, 1] = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
    inv[0, 2] = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
    inv[1, 2] = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
    inv[2, 2] = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    for i in range(3):
        x[i] = (inv[i, 0] * b[0] + inv[i, 1] * b[1] + inv[i, 2] * b[2]) / det
    return x, True


@njit(cache=True)
def _least_squares(U, d, mask, dim):  # pragma: no cover - compiled
    """``v`` minimising ``sum_I (d + U v)^2`` over ``mask``, ``(U_I^T U_I)`` and the RSS (c.10.2)."""
    N = np.zeros((dim, dim))
    g = np.zeros(dim)
    for i in range(U.shape[0]):
        if mask[i]:
            for a in range(dim):
                g[a] -= U[i, a] * d[i]
                for b in range(dim):
                    N[a, b] += U[i, a] * U[i, b]
    v, ok = _solve_small(N, g, dim)
    rss = 0.0
    for i in range(U.shape[0]):
        if mask[i]:
            r = d[i]
            for a in range(dim):
                r += U[i, a] * v[a]
            rss += r * r
    return v, N, rss, ok


@njit(cache=True)
def _consensus(U, d, v, threshold, dim, mask):  # pragma: no cover - compiled
    """Mark ``|d + U v| <= threshold`` in ``mask``; the count and the inliers' squared residuals."""
    cnt = 0
    sq = 0.0
    for i in range(U.shape[0]):
        r = d[i]
        for a in range(dim):
            r += U[i, a] * v[a]
        if abs(r) <= threshold:
            mask[i] = True
            cnt += 1
            sq += r * r
        else:
            mask[i] = False
    return cnt, sq


@njit(cache=True)
def ransac_kernel(U, d, rng, iterations, threshold):  # pragma: no cover - compiled
    """RANSAC over ``iterations`` minimal sets drawn from ``rng``, then least squares on the best
    consensus refined once (c.10.2). Returns ``(v (dim,), N = U_I^T U_I (dim, dim), rss, mask (n,),
    ok)``."""
    n, dim = U.shape
    best = np.zeros(n, dtype=np.bool_)
    mask = np.zeros(n, dtype=np.bool_)
    best_cnt, best_sq = -1, np.inf
    A = np.empty((dim, dim))
    b = np.empty(dim)
    idx = np.empty(dim, dtype=np.int64)
    if n < dim:
        return np.zeros(dim), np.zeros((dim, dim)), 0.0, best, False
    for _ in range(iterations):
        for a in range(dim):          # distinct, uniform: draw among the n - a left, step over the taken
            j = rng.integers(0, n - a)
            for c in range(a):        # idx[:a] is kept sorted
                if j >= idx[c]:
                    j += 1
            q = a                     # insert j in order
            while q > 0 and idx[q - 1] > j:
                idx[q] = idx[q - 1]
                q -= 1
            idx[q] = j
        for a in range(dim):
            b[a] = -d[idx[a]]
            for c in range(dim):
                A[a, c] = U[idx[a], c]
        v, ok = _solve_small(A, b, dim)
        if not ok:
            continue
        cnt, sq = _consensus(U, d, v, threshold, dim, mask)
        if cnt > best_cnt or (cnt == best_cnt and sq < best_sq):
            best_cnt, best_sq = cnt, sq
            best[:] = mask
    if best_cnt < dim:
        return np.zeros(dim), np.zeros((dim, dim)), 0.0, best, False
    v, N, rss, ok = _least_squares(U, d, best, dim)
    if ok:                            # one refinement: the consensus of the least-squares fit
        cnt, _ = _consensus(U, d, v, threshold, dim, mask)
        if cnt >= dim + 1:
            v2, N2, rss2, ok2 = _least_squares(U, d, mask, dim)
            if ok2:
                return v2, N2, rss2, mask.copy(), True
    return v, N, rss, best, ok
