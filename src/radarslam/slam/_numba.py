"""The associators' kernels (the classes that run them: :mod:`radarslam.slam.association`; the
fused engine's step 4 calls them too): each scheme as one loop over the scan's candidates. It has no maths of its own: the measurement
Jacobian, the log distance, ``R_eff``, the Joseph update and the angle wraps are the functions of
:mod:`radarslam.slam.ekf` and :mod:`radarslam.core.angles`, compiled here as they are
(:func:`compile_kernels`). Only the loop and the nearest-landmark search are written for numba.
The reference backend runs the same code in the interpreter; both agree with the schemes written in
numpy over :mod:`radarslam.slam.ekf` to rounding (tests/test_components.py, random states and scans).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core import angles
from radarslam.core.jit import compile_kernels
from radarslam.landmarks._compiled import compiled_seen_landmarks
from radarslam.slam import ekf, layout


def joseph_apply_rows(P, W):  # pragma: no cover - compiled
    """The n x n pass of the Joseph update on the rows of ``W (6, n)``: the two columns of ``PHt``,
    of ``K`` and of ``KL``, each contiguous (unit-stride SIMD; 2.2x faster at n = 100 and 1000
    than reading (n, 2) arrays). ``P <- P - (T + T^T) + KL KL^T`` with ``T = K PHt^T``, the same
    operations in the same order as :func:`radarslam.slam.ekf.joseph_apply`; ``T_ij + T_ji`` and
    the ``KL`` term are commutative in i and j, so P stays exactly symmetric."""
    n = P.shape[0]
    p0v, p1v, k0v, k1v, l0v, l1v = W[0], W[1], W[2], W[3], W[4], W[5]
    for i in range(n):
        k0, k1 = k0v[i], k1v[i]
        p0, p1 = p0v[i], p1v[i]
        l0, l1 = l0v[i], l1v[i]
        row = P[i]
        for j in range(n):
            t = (k0 * p0v[j] + k1 * p1v[j]) + (k0v[j] * p0 + k1v[j] * p1)
            row[j] = row[j] - t + (l0 * l0v[j] + l1 * l1v[j])


def joseph_apply_loops(P, K, PHt, KL):  # pragma: no cover - compiled
    """:func:`radarslam.slam.ekf.joseph_apply` as one pass over P with no n x n temporaries (the
    numpy form makes four n x n passes and two n x n allocations): the columns gathered into rows,
    then :func:`joseph_apply_rows`. Agrees with the numpy form to rounding (tests/test_backends.py)."""
    W = np.empty((6, P.shape[0]))
    W[0], W[1] = PHt[:, 0], PHt[:, 1]
    W[2], W[3] = K[:, 0], K[:, 1]
    W[4], W[5] = KL[:, 0], KL[:, 1]
    _joseph_apply_rows(P, W)


def joseph_update_loops(x, P, e, Hs, idx, R):  # pragma: no cover - compiled
    """:func:`radarslam.slam.ekf.joseph_update_inplace` written as loops for numba: the same
    quantities in the same order (``PHt = P[:, idx] Hs^T``, ``S = Hs PHt[idx] + R`` symmetrised,
    ``K = PHt S^-1`` by the adjugate, ``KL`` with the 2 x 2 Cholesky factor, then the pass of
    :func:`joseph_apply_rows`), without the fancy-indexed copy of ``P[:, idx]`` and the small
    matrix products that numba hands to BLAS one call each, and with one work array for the six
    n-vectors: 6 us instead of 13 us at n = 43, and 1.2 ms instead of 3.3 ms at n = 1003. Equal to
    the numpy form to rounding (tests/test_backends.py)."""
    n = P.shape[0]
    W = np.empty((6, n))                       # rows: PHt (2), K (2), KL (2)
    for i in range(n):
        s0 = 0.0
        s1 = 0.0
        for c in range(idx.shape[0]):
            p = P[i, idx[c]]
            s0 += p * Hs[0, c]
            s1 += p * Hs[1, c]
        W[0, i] = s0
        W[1, i] = s1
    s00 = s01 = s10 = s11 = 0.0
    for c in range(idx.shape[0]):
        s00 += Hs[0, c] * W[0, idx[c]]
        s01 += Hs[0, c] * W[1, idx[c]]
        s10 += Hs[1, c] * W[0, idx[c]]
        s11 += Hs[1, c] * W[1, idx[c]]
    a = s00 + R[0, 0]
    b = 0.5 * ((s01 + R[0, 1]) + (s10 + R[1, 0]))
    d = s11 + R[1, 1]
    det = a * d - b * b
    for i in range(n):
        W[2, i] = (W[0, i] * d + W[1, i] * -b) / det
        W[3, i] = (W[0, i] * -b + W[1, i] * a) / det
    for i in range(n):
        x[i] += W[2, i] * e[0] + W[3, i] * e[1]
    x[2] = _wrap_2pi(x[2])
    l00 = math.sqrt(a)
    l10 = b / l00
    l11 = math.sqrt(d - l10 * l10)
    for i in range(n):
        W[4, i] = W[2, i] * l00 + W[3, i] * l10
        W[5, i] = W[3, i] * l11
    _joseph_apply_rows(P, W)
    return (d * e[0] * e[0] - 2.0 * b * e[0] * e[1] + a * e[1] * e[1]) / det


def r_eff_loops(R, Hs, spread):  # pragma: no cover - compiled
    """:func:`radarslam.slam.ekf.r_eff` on scalars: ``R + (H_p spread) H_p^T`` with ``H_p`` the
    last two columns of ``Hs``, each entry summed in the matrix products' order, without the two
    small BLAS calls numba would make."""
    t00 = Hs[0, 3] * spread[0, 0] + Hs[0, 4] * spread[1, 0]
    t01 = Hs[0, 3] * spread[0, 1] + Hs[0, 4] * spread[1, 1]
    t10 = Hs[1, 3] * spread[0, 0] + Hs[1, 4] * spread[1, 0]
    t11 = Hs[1, 3] * spread[0, 1] + Hs[1, 4] * spread[1, 1]
    out = np.empty((2, 2))
    out[0, 0] = R[0, 0] + (t00 * Hs[0, 3] + t01 * Hs[0, 4])
    out[0, 1] = R[0, 1] + (t00 * Hs[1, 3] + t01 * Hs[1, 4])
    out[1, 0] = R[1, 0] + (t10 * Hs[0, 3] + t11 * Hs[0, 4])
    out[1, 1] = R[1, 1] + (t10 * Hs[1, 3] + t11 * Hs[1, 4])
    return out


_K = compile_kernels(angles.wrap_pi_scalar, angles.wrap_2pi_scalar, layout.landmark_index,
                     ekf.innovation_cov_terms, ekf.gaussian_log_distance, ekf.sparse_jacobian, ekf.r_eff,
                     ekf.sensor_xy_measurement, ekf.polar_to_sensor_xy,
                     ekf.rotate_to_sensor, ekf.batch_noise,
                     replace={"joseph_apply_rows": joseph_apply_rows, "joseph_apply": joseph_apply_loops,
                              "joseph_update_inplace": joseph_update_loops, "r_eff": r_eff_loops})
_wrap_pi = _K["wrap_pi_scalar"]
_wrap_2pi = _K["wrap_2pi_scalar"]
_joseph_apply = _K["joseph_apply"]
_joseph_apply_rows = _K["joseph_apply_rows"]
_landmark_index = _K["landmark_index"]
_innovation_cov_terms = _K["innovation_cov_terms"]
_gaussian_log_distance = _K["gaussian_log_distance"]
_sparse_jacobian = _K["sparse_jacobian"]
_r_eff = _K["r_eff"]
_joseph_update_inplace = _K["joseph_update_inplace"]
_sensor_xy_measurement = _K["sensor_xy_measurement"]
_polar_to_sensor_xy = _K["polar_to_sensor_xy"]
_batch_noise = _K["batch_noise"]


@njit(cache=True)
def _smallest(d, N, count):  # pragma: no cover - compiled
    """Positions of the ``count`` smallest of ``d[:N]``, smallest first, ties by position: the first
    ``count`` of ``np.argsort(d[:N], kind="mergesort")`` (stable) by insertion into a sorted list,
    O(N count) instead of a full sort of the map for every detection."""
    best = np.empty(count, dtype=np.int64)
    filled = 0
    for j in range(N):
        v = d[j]
        if filled == count and not v < d[best[count - 1]]:
            continue
        p = filled if filled < count else count - 1
        while p > 0 and d[best[p - 1]] > v:     # strictly greater: an equal earlier one stays first
            if p < count:
                best[p] = best[p - 1]
            p -= 1
        best[p] = j
        if filled < count:
            filled += 1
    return best


@njit(cache=True)
def _best_landmark(x, P, z0, z1, n_nearest, R, gX, has_gX, d2, platform):  # pragma: no cover - compiled
    """Smallest log distance of detection (z0, z1) over its n_nearest landmarks
    (:func:`radarslam.slam.ekf.score_landmarks`). Returns ``(j, D, e0, e1)``; ``j = -1`` if none.
    ``platform``: the size of the state's platform block (:mod:`radarslam.slam.layout`)."""
    N = (x.shape[0] - platform) // 2
    r00, r01, r11 = R[0, 0], R[0, 1], R[1, 1]
    x0, y0, th = x[0], x[1], x[2]
    a = th + z1
    zx = x0 + z0 * math.cos(a)
    zy = y0 + z0 * math.sin(a)
    for j in range(N):
        i = _landmark_index(j, platform)
        d2[j] = (x[i] - zx) ** 2 + (x[i + 1] - zy) ** 2
    count = min(n_nearest, N)
    order = _smallest(d2, N, count)
    pxx, pxy, pxt = P[0, 0], P[0, 1], P[0, 2]
    pyy, pyt, ptt = P[1, 1], P[1, 2], P[2, 2]
    best_j = -1
    best_D = math.inf
    be0 = 0.0
    be1 = 0.0
    for k in range(count):
        j = order[k]
        i = _landmark_index(j, platform)
        cxx = P[i, i] - 2.0 * P[i, 0] + pxx
        cxy = P[i, i + 1] - P[i, 1] - P[i + 1, 0] + pxy
        cyy = P[i + 1, i + 1] - 2.0 * P[i + 1, 1] + pyy
        ctx = P[i, 2] - pxt
        cty = P[i + 1, 2] - pyt
        dx = x[i] - x0
        dy = x[i + 1] - y0
        if dx == 0.0 and dy == 0.0:
            continue  # a landmark at the sensor itself has no bearing (as in ekf.score_landmarks)
        s00, s01, s11, r = _innovation_cov_terms(cxx, cxy, cyy, ctx, cty, ptt, dx, dy, r00, r01, r11,
                                                 has_gX[j], gX[j, 0, 0], gX[j, 0, 1], gX[j, 1, 1])
        e0 = z0 - r
        e1 = _wrap_pi(z1 - (math.atan2(dy, dx) - th))
        D = _gaussian_log_distance(s00, s01, s11, e0, e1)
        if D < best_D:
            best_j, best_D, be0, be1 = j, D, e0, e1
    return best_j, best_D, be0, be1


@njit(cache=True)
def min_log_distance(x, P, z0, z1, n_nearest, R, platform):  # pragma: no cover - compiled
    """The alpha test's smallest log distance (plain R, c.6); inf without landmarks."""
    N = (x.shape[0] - platform) // 2
    if N == 0:
        return math.inf
    return _best_landmark(x, P, z0, z1, n_nearest, R, np.zeros((N, 2, 2)), np.zeros(N, dtype=np.bool_),
                          np.empty(N), platform)[1]


@njit(cache=True)
def associate_scan(x, P, polar, cand, R, gX, has_gX, n_nearest, beta, platform, xlin):  # pragma: no cover - compiled
    """Sequential association + EKF updates of the detections ``polar[cand]``, in place on ``x``, ``P``
    (a state whose platform block has ``platform`` entries, :mod:`radarslam.slam.layout`). The
    measurement Jacobians are evaluated at ``x`` or, under first-estimates Jacobians (c.2.1), at
    ``xlin`` (:meth:`~radarslam.slam.state.SlamState.linearisation_all`; empty for the standard ones).

    Returns ``(x, P, out, nis)``: the updated state (the same arrays), the landmark associated to
    each candidate (-1 where none) and the NIS of each update.
    """
    N = (x.shape[0] - platform) // 2
    out = np.full(cand.shape[0], -1)
    nis = np.empty(cand.shape[0])
    n_up = 0
    if N == 0:
        return x, P, out, nis[:0]
    d2 = np.empty(N)
    for c in range(cand.shape[0]):
        z0 = polar[cand[c], 0]
        z1 = polar[cand[c], 1]
        best_j, best_D, be0, be1 = _best_landmark(x, P, z0, z1, n_nearest, R, gX, has_gX, d2, platform)
        if best_j < 0 or not best_D < beta:
            continue
        out[c] = best_j
        Hs, idx = _sparse_jacobian(xlin if xlin.shape[0] else x, best_j, platform)
        Rj = _r_eff(R, Hs, gX[best_j]) if has_gX[best_j] else R
        q = _joseph_update_inplace(x, P, np.array([be0, be1]), Hs, idx, Rj)
        nis[n_up] = q
        n_up += 1
    return x, P, out, nis[:n_up]


@njit(cache=True)
def _batch_scores(x, P, polar, cand, R, gX, has_gX, n_nearest, beta, platform):  # pragma: no cover - compiled
    """The landmark of each candidate (-1 for none), all scored at the state ``x``, ``P``
    (:meth:`radarslam.slam.association.BatchAssociator.scores`); at least one landmark."""
    N = (x.shape[0] - platform) // 2
    out = np.full(cand.shape[0], -1)
    d2 = np.empty(N)
    for c in range(cand.shape[0]):
        best_j, best_D, be0, be1 = _best_landmark(x, P, polar[cand[c], 0], polar[cand[c], 1], n_nearest, R, gX,
                                                  has_gX, d2, platform)
        if best_j >= 0 and best_D < beta:
            out[c] = best_j
    return out


@njit(cache=True)
def batch_associate_scan(x, P, polar, cand, R, gX, has_gX, n_nearest, beta, platform, xlin, offset_k=0.0):  # pragma: no cover
    """The per-landmark batch update (:class:`radarslam.slam.association.BatchAssociator`): score
    every candidate at the prior state, then one update per landmark with the mean of its
    detections (its Jacobian at ``xlin`` under first-estimates Jacobians, c.2.1; ``offset_k`` the
    part in view's offset, c.17). Returns ``(x, P, out, nis)``."""
    N = (x.shape[0] - platform) // 2
    nis = np.empty(N)
    if N == 0:
        return x, P, np.full(cand.shape[0], -1), nis[:0]
    out = _batch_scores(x, P, polar, cand, R, gX, has_gX, n_nearest, beta, platform)
    n_up = 0
    for j in range(N):
        rows = cand[out == j]
        if rows.shape[0] == 0:
            continue
        pts, R_xy = _polar_to_sensor_xy(polar[rows], R)
        m = rows.shape[0]
        zbar = np.empty(2)
        zbar[0] = pts[:, 0].mean()
        zbar[1] = pts[:, 1].mean()
        noise = _batch_noise(x[2], np.ascontiguousarray(gX[j]), has_gX[j], R_xy, m, offset_k)
        h, Hs, idx = _sensor_xy_measurement(x, j, platform)
        if xlin.shape[0]:                           # first-estimates Jacobian (c.2.1), h at the estimate
            Hs = _sensor_xy_measurement(xlin, j, platform)[1]
        q = _joseph_update_inplace(x, P, zbar - h, Hs, idx, noise)
        nis[n_up] = q
        n_up += 1
    return x, P, out, nis[:n_up]


#: Columns of P per block of the rank-q downdate in :func:`joint_update_loops` (B^T's block stays in L1).
_COLUMN_BLOCK = 128
#: Tile of the mirroring pass of :func:`joint_update_loops`.
_TILE = 32


@njit(cache=True)
def stacked_rows(L):  # pragma: no cover - compiled
    """``(e (2L,), Hs (L, 2, 5), idx (L, 5), Rb (L, 2, 2))`` to fill for :func:`joint_update_loops`."""
    return np.empty(2 * L), np.empty((L, 2, 5)), np.empty((L, 5), dtype=np.int64), np.empty((L, 2, 2))


@njit(cache=True)
def joint_update_loops(x, P, e, Hs, idx, Rb):  # pragma: no cover - compiled
    """:func:`radarslam.slam.ekf.joint_update_inplace` on the sparse blocks: landmark ``a``'s two
    rows of H are ``Hs[a] (2, 5)`` on the columns ``idx[a]``, its noise ``Rb[a] (2, 2)``. ``P H^T``
    reads 5 columns per landmark; the q x q Cholesky and triangular solves are loops; ``P <- P - B B^T``
    is one pass over P's upper triangle in column blocks (the products ``B[r, i] B[c, i]`` four
    at a time), then mirrored tile by tile, so P stays exactly symmetric at half the arithmetic. Returns the pairwise sums of the whitened innovation squared."""
    n = P.shape[0]
    L = Hs.shape[0]
    q = 2 * L
    PHt = np.empty((n, q))
    for r in range(n):
        for a in range(L):
            for t in range(2):
                acc = 0.0
                for c in range(5):
                    acc += P[r, idx[a, c]] * Hs[a, t, c]
                PHt[r, 2 * a + t] = acc
    S = np.empty((q, q))
    for a in range(L):
        for t in range(2):
            for col in range(q):
                acc = 0.0
                for c in range(5):
                    acc += Hs[a, t, c] * PHt[idx[a, c], col]
                S[2 * a + t, col] = acc
    for a in range(L):
        for t in range(2):
            for u in range(2):
                S[2 * a + t, 2 * a + u] += Rb[a, t, u]
    for i in range(q):
        for j in range(i + 1, q):
            v = 0.5 * (S[i, j] + S[j, i])
            S[i, j] = v
            S[j, i] = v
    Lc = np.zeros((q, q))                                  # S = Lc Lc^T
    for j in range(q):
        acc = S[j, j]
        for k in range(j):
            acc -= Lc[j, k] * Lc[j, k]
        Lc[j, j] = math.sqrt(acc)
        for i in range(j + 1, q):
            acc = S[i, j]
            for k in range(j):
                acc -= Lc[i, k] * Lc[j, k]
            Lc[i, j] = acc / Lc[j, j]
    Bt = np.empty((q, n))                                  # (P H^T L^-T)^T, rows contiguous
    b = np.empty(q)
    for r in range(n):
        for i in range(q):
            acc = PHt[r, i]
            for k in range(i):
                acc -= Lc[i, k] * b[k]
            b[i] = acc / Lc[i, i]
            Bt[i, r] = b[i]
    w = np.empty(q)
    for i in range(q):
        acc = e[i]
        for k in range(i):
            acc -= Lc[i, k] * w[k]
        w[i] = acc / Lc[i, i]
    for r in range(n):
        acc = 0.0
        for i in range(q):
            acc += Bt[i, r] * w[i]
        x[r] += acc
    x[2] = _wrap_2pi(x[2])
    # P <- P - B B^T on the upper triangle, column block by column block, then mirrored
    for c0 in range(0, n, _COLUMN_BLOCK):
        c1 = min(n, c0 + _COLUMN_BLOCK)
        blk = np.ascontiguousarray(Bt[:, c0:c1])           # the block's columns of B^T, indexed from 0
        for r in range(c1):
            first = r - c0 if r > c0 else 0                 # row r from column max(r, c0)
            row = P[r, c0 + first:c1]
            width = row.shape[0]
            i = 0
            while i + 4 <= q:                              # four terms per pass over the row block
                a0, a1, a2, a3 = Bt[i, r], Bt[i + 1, r], Bt[i + 2, r], Bt[i + 3, r]
                b0, b1, b2, b3 = blk[i, first:], blk[i + 1, first:], blk[i + 2, first:], blk[i + 3, first:]
                for c in range(width):
                    row[c] -= ((a0 * b0[c] + a1 * b1[c]) + (a2 * b2[c] + a3 * b3[c]))
                i += 4
            while i < q:
                a0 = Bt[i, r]
                b0 = blk[i, first:]
                for c in range(width):
                    row[c] -= a0 * b0[c]
                i += 1
    for r0 in range(0, n, _TILE):                          # lower triangle <- upper, tile by tile
        r1 = min(n, r0 + _TILE)
        for c0 in range(r0, n, _TILE):
            c1 = min(n, c0 + _TILE)
            for r in range(r0, r1):
                for c in range(max(c0, r + 1), c1):
                    P[c, r] = P[r, c]
    nis = np.empty(L)
    for a in range(L):
        nis[a] = w[2 * a] * w[2 * a] + w[2 * a + 1] * w[2 * a + 1]
    return nis


@njit(cache=True)
def joint_batch_associate_scan(x, P, polar, cand, R, gX, has_gX, n_nearest, beta, platform, xlin, offset_k=0.0):  # pragma: no cover
    """:class:`radarslam.slam.association.JointBatchAssociator`: the batch scoring, then every
    landmark seen in one stacked update at the prior state (the Jacobians at ``xlin`` under
    first-estimates Jacobians, c.2.1; ``offset_k`` the part in view's offset, c.17). Returns
    ``(x, P, out, nis)``."""
    N = (x.shape[0] - platform) // 2
    if N == 0:
        return x, P, np.full(cand.shape[0], -1), np.empty(0)
    out = _batch_scores(x, P, polar, cand, R, gX, has_gX, n_nearest, beta, platform)
    js = compiled_seen_landmarks(out, N)
    L = js.shape[0]
    if L == 0:
        return x, P, out, np.empty(0)
    e, Hs_all, idx_all, Rb = stacked_rows(L)
    for a in range(L):
        j = js[a]
        rows = cand[out == j]
        pts, R_xy = _polar_to_sensor_xy(polar[rows], R)
        h, Hs, idx = _sensor_xy_measurement(x, j, platform)
        if xlin.shape[0]:                           # first-estimates Jacobian (c.2.1)
            Hs = _sensor_xy_measurement(xlin, j, platform)[1]
        e[2 * a] = pts[:, 0].mean() - h[0]
        e[2 * a + 1] = pts[:, 1].mean() - h[1]
        Hs_all[a] = Hs
        idx_all[a] = idx
        Rb[a] = _batch_noise(x[2], np.ascontiguousarray(gX[j]), has_gX[j], R_xy, rows.shape[0], offset_k)
    nis = joint_update_loops(x, P, e, Hs_all, idx_all, Rb)
    return x, P, out, nis
