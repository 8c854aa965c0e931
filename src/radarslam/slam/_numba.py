"""Compiled association loop (``filter.backend = "numba"``, the ``[fast]`` extra).

The same computation as the Python path of :meth:`radarslam.slam.filter.EkfSlam.update` step 4
(nearest landmarks, log distance of :func:`radarslam.slam.ekf.score_landmarks`, Joseph update of
:func:`radarslam.slam.ekf.update`), compiled as one loop over the scan's candidate detections.
The log-distance arithmetic is the Python kernel's scalar functions, compiled; the covariance
update sums in a different order than numpy's matmul, so the two backends agree to rounding
(tested), not bit for bit. A run's backend is part of its configuration.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.slam import ekf

TWO_PI = 2.0 * math.pi

# The log-distance arithmetic is the Python backend's own scalar kernels, compiled.
_innovation_cov_terms = njit(cache=True)(ekf.innovation_cov_terms)
_gaussian_log_distance = njit(cache=True)(ekf.gaussian_log_distance)


@njit(cache=True)
def _wrap_pi(a):
    a = np.fmod(a + math.pi, TWO_PI)
    if a <= 0.0:
        a += TWO_PI
    return a - math.pi


@njit(cache=True)
def _wrap_2pi(a):
    a = np.fmod(a, TWO_PI)
    if a < 0.0:
        a += TWO_PI
    if a >= TWO_PI:
        a = 0.0
    return a


@njit(cache=True)
def _best_landmark(x, P, z0, z1, n_nearest, R, gX, has_gX, d2):  # pragma: no cover - compiled
    """Smallest log distance of detection (z0, z1) over its n_nearest landmarks (ekf.score_landmarks).

    Returns ``(j, D, e0, e1)``; ``j = -1`` when no landmark scores.
    """
    n = x.shape[0]
    N = (n - 3) // 2
    r00, r01, r11 = R[0, 0], R[0, 1], R[1, 1]
    x0, y0, th = x[0], x[1], x[2]
    a = th + z1
    zx = x0 + z0 * math.cos(a)
    zy = y0 + z0 * math.sin(a)
    for j in range(N):
        d2[j] = (x[3 + 2 * j] - zx) ** 2 + (x[4 + 2 * j] - zy) ** 2
    order = np.argsort(d2[:N], kind="mergesort")
    count = min(n_nearest, N)
    pxx, pxy, pxt = P[0, 0], P[0, 1], P[0, 2]
    pyy, pyt, ptt = P[1, 1], P[1, 2], P[2, 2]
    best_j = -1
    best_D = math.inf
    be0 = 0.0
    be1 = 0.0
    for k in range(count):
        j = order[k]
        i = 3 + 2 * j
        cxx = P[i, i] - 2.0 * P[i, 0] + pxx
        cxy = P[i, i + 1] - P[i, 1] - P[i + 1, 0] + pxy
        cyy = P[i + 1, i + 1] - 2.0 * P[i + 1, 1] + pyy
        ctx = P[i, 2] - pxt
        cty = P[i + 1, 2] - pyt
        dx = x[i] - x0
        dy = x[i + 1] - y0
        s00, s01, s11, r = _innovation_cov_terms(cxx, cxy, cyy, ctx, cty, ptt, dx, dy, r00, r01, r11,
                                                 has_gX[j], gX[j, 0, 0], gX[j, 0, 1], gX[j, 1, 1])
        e0 = z0 - r
        e1 = _wrap_pi(z1 - (math.atan2(dy, dx) - th))
        D = _gaussian_log_distance(s00, s01, s11, e0, e1)
        if D < best_D:
            best_j, best_D, be0, be1 = j, D, e0, e1
    return best_j, best_D, be0, be1


@njit(cache=True)
def min_log_distance(x, P, z0, z1, n_nearest, R):  # pragma: no cover - compiled
    """The alpha test's smallest log distance (plain R, c.6); inf without landmarks."""
    N = (x.shape[0] - 3) // 2
    if N == 0:
        return math.inf
    return _best_landmark(x, P, z0, z1, n_nearest, R, np.zeros((N, 2, 2)), np.zeros(N, dtype=np.bool_),
                          np.empty(N))[1]


@njit(cache=True)
def associate_scan(x, P, polar, cand, R, gX, has_gX, n_nearest, beta):  # pragma: no cover - compiled
    """Sequential association + EKF updates of the detections ``polar[cand]`` (in place on x, P).

    ``gX`` (N, 2, 2) holds gamma_z X_j where ``has_gX[j]`` (R_eff, a.7.2). Returns the landmark
    index associated to each candidate, -1 where none.
    """
    n = x.shape[0]
    N = (n - 3) // 2
    out = np.full(cand.shape[0], -1)
    if N == 0:
        return out
    d2 = np.empty(N)
    PHt = np.empty((n, 2))
    K = np.empty((n, 2))
    KL = np.empty((n, 2))
    r00, r01, r11 = R[0, 0], R[0, 1], R[1, 1]
    for c in range(cand.shape[0]):
        z0 = polar[cand[c], 0]
        z1 = polar[cand[c], 1]
        best_j, best_D, be0, be1 = _best_landmark(x, P, z0, z1, n_nearest, R, gX, has_gX, d2)
        x0, y0 = x[0], x[1]
        if best_j < 0 or not best_D < beta:
            continue
        out[c] = best_j
        # EKF update with the sparse Jacobian (ekf.update): Joseph form P - (T + T^T) + (KL)(KL)^T.
        i = 3 + 2 * best_j
        dx = x[i] - x0
        dy = x[i + 1] - y0
        q = dx * dx + dy * dy
        r = math.sqrt(q)
        h0 = (-dx / r, -dy / r, 0.0, dx / r, dy / r)
        h1 = (dy / q, -dx / q, -1.0, -dy / q, dx / q)
        idx = (0, 1, 2, i, i + 1)
        rr00, rr01, rr11 = r00, r01, r11
        if has_gX[best_j]:
            g00, g01, g11 = gX[best_j, 0, 0], gX[best_j, 0, 1], gX[best_j, 1, 1]
            p0, p1, q0, q1 = h0[3], h0[4], h1[3], h1[4]
            rr00 += p0 * (g00 * p0 + g01 * p1) + p1 * (g01 * p0 + g11 * p1)
            rr01 += q0 * (g00 * p0 + g01 * p1) + q1 * (g01 * p0 + g11 * p1)
            rr11 += q0 * (g00 * q0 + g01 * q1) + q1 * (g01 * q0 + g11 * q1)
        for rw in range(n):
            s0 = 0.0
            s1 = 0.0
            for k in range(5):
                p = P[rw, idx[k]]
                s0 += p * h0[k]
                s1 += p * h1[k]
            PHt[rw, 0] = s0
            PHt[rw, 1] = s1
        S00 = rr00
        S01 = rr01
        S11 = rr11
        for k in range(5):
            S00 += h0[k] * PHt[idx[k], 0]
            S01 += h0[k] * PHt[idx[k], 1]
            S11 += h1[k] * PHt[idx[k], 1]
        det = S00 * S11 - S01 * S01
        l00 = math.sqrt(S00)
        l10 = S01 / l00
        l11 = math.sqrt(S11 - l10 * l10)
        for rw in range(n):
            k0 = (PHt[rw, 0] * S11 - PHt[rw, 1] * S01) / det
            k1 = (-PHt[rw, 0] * S01 + PHt[rw, 1] * S00) / det
            K[rw, 0] = k0
            K[rw, 1] = k1
            KL[rw, 0] = k0 * l00 + k1 * l10
            KL[rw, 1] = k1 * l11
        for rw in range(n):
            x[rw] += K[rw, 0] * be0 + K[rw, 1] * be1
        x[2] = _wrap_2pi(x[2])
        for rw in range(n):
            for cl in range(rw, n):
                t = (K[rw, 0] * PHt[cl, 0] + K[rw, 1] * PHt[cl, 1]) + (K[cl, 0] * PHt[rw, 0] + K[cl, 1] * PHt[rw, 1])
                v = P[rw, cl] - t + (KL[rw, 0] * KL[cl, 0] + KL[rw, 1] * KL[cl, 1])
                P[rw, cl] = v
                P[cl, rw] = v
    return out
