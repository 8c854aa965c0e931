"""The Doppler kernels compiled with numba (:mod:`radarslam.models.doppler_kernels`, compiled as they
are by :func:`radarslam.core.jit.compile_kernels`), and the loops over a stream's scans that the fused
engine's stream (:func:`radarslam.slam.fused.plan._stream_arrays`) calls: one call per stream instead
of one Python call chain per scan (docs/method.md c.10.2-c.10.5).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from radarslam.core.jit import compile_kernels
from radarslam.models import doppler_kernels

_K = compile_kernels(*doppler_kernels.KERNELS)
mounted_dirs = _K["mounted_dirs"]
ego_fit = _K["ego_fit"]
moving_test = _K["moving_test"]
object_stat = _K["object_stat"]
moving_groups = _K["moving_groups"]
classify_scan = _K["classify_scan"]


@njit(cache=True)
def classify_stream(polar, off, doppler, mounting, rng, iterations, threshold, sigma_floor, min_fraction,
                    quantiles, radius):  # pragma: no cover - compiled
    """:func:`~radarslam.models.doppler_kernels.classify_scan` on each scan ``s`` of
    ``polar[off[s]:off[s + 1]]`` (Doppler ``doppler``, the same rows) in order, drawing from ``rng``
    as the per-scan calls do. ``mounting`` ``(x, y, yaw)``; ``quantiles`` ``(q_zero, q_gate, q_one,
    q_two)``. Returns ``(v (S, 2), cov (S, 2, 2), inliers (M,), sigma (S,), stat (S,), at_rest (S,),
    valid (S,), bad (M,), objects (M,), tested (S,))``."""
    S, M = off.shape[0] - 1, polar.shape[0]
    v, cov = np.empty((S, 2)), np.empty((S, 2, 2))
    sigma, stat = np.empty(S), np.empty(S)
    rest, valid, tested = np.zeros(S, np.bool_), np.zeros(S, np.bool_), np.zeros(S, np.bool_)
    inl, bad, objects = np.zeros(M, np.bool_), np.zeros(M, np.bool_), np.zeros(M, np.bool_)
    for s in range(S):
        a, b = off[s], off[s + 1]
        out = classify_scan(polar[a:b], doppler[a:b], mounting[0], mounting[1], mounting[2], rng, iterations,
                            threshold, sigma_floor, min_fraction, quantiles[0], quantiles[1], radius, quantiles[2],
                            quantiles[3])
        v[s], cov[s], sigma[s], stat[s], rest[s], valid[s] = out[0], out[1], out[3], out[4], out[5], out[6]
        inl[a:b], bad[a:b], objects[a:b], tested[s] = out[2], out[7], out[8], out[9]
    return v, cov, inl, sigma, stat, rest, valid, bad, objects, tested


@njit(cache=True)
def fit_stream(polar, off, doppler, mounting, rng, iterations, threshold, sigma_floor, min_fraction,
               q_zero):  # pragma: no cover - compiled
    """:func:`~radarslam.models.doppler_kernels.ego_fit` of each scan ``s`` of ``polar[off[s]:off[s + 1]]``
    (directions from the mounting ``(x, y, yaw)``) in order, drawing from ``rng`` as the per-scan calls
    do (Doppler odometry, c.10.5). Returns ``(v (S, 2), cov (S, 2, 2), inliers (M,), sigma (S,),
    stat (S,), at_rest (S,), valid (S,))``."""
    S, M = off.shape[0] - 1, polar.shape[0]
    v, cov = np.empty((S, 2)), np.empty((S, 2, 2))
    sigma, stat = np.empty(S), np.empty(S)
    rest, valid, inl = np.zeros(S, np.bool_), np.zeros(S, np.bool_), np.zeros(M, np.bool_)
    for s in range(S):
        a, b = off[s], off[s + 1]
        U = mounted_dirs(polar[a:b], mounting[0], mounting[1], mounting[2])
        out = ego_fit(U, doppler[a:b], rng, iterations, threshold, sigma_floor, min_fraction, q_zero)
        v[s], cov[s], inl[a:b], sigma[s], stat[s], rest[s], valid[s] = out
    return v, cov, inl, sigma, stat, rest, valid


# ---------------------------------------------------------------------------------------------
# The rig's Doppler fit over windows (docs/method.md c.12.3-c.12.4): the sums over each window's
# (window, detection) pairs of :class:`radarslam.models._rig_consensus.Pairs`, read straight from the
# rows ``lo[k]:lo[k] + m[k]`` of ``A`` and ``d`` (no pair-by-pair copy), pair after pair in window
# order: the same products and the same sequential sums as numpy's row products and scipy's CSR
# product they replace, so the results are the same to the bit.


@njit(cache=True)
def rig_residual(A, d, lo, m, theta):  # pragma: no cover - compiled
    """``d_j - a_j^T theta_k`` of every pair ``(k, j)``, window after window, ``(sum m,)``, its terms
    summed in the order of the numpy form it replaced, ``d - einsum("ij,ij->i", A[rows], theta[win])``."""
    K, p = theta.shape
    out = np.empty(np.sum(m))
    r = 0
    for k in range(K):
        for j in range(lo[k], lo[k] + m[k]):
            if p == 3:      # numpy's row product (einsum "ij,ij->i") adds the third term to the first
                s = (A[j, 0] * theta[k, 0] + A[j, 2] * theta[k, 2]) + A[j, 1] * theta[k, 1]
            else:
                s = 0.0
                for c in range(p):
                    s += A[j, c] * theta[k, c]
            out[r] = d[j] - s
            r += 1
    return out


@njit(cache=True)
def rig_normal(A, d, lo, m, w, theta, cs, tukey):  # pragma: no cover - compiled
    """``sum w a a^T`` (its upper half in ``np.triu_indices(p)`` order) and ``sum w a d`` over each
    window's pairs, ``(K, q + p)`` with ``q = p (p + 1) / 2``, ``p`` 2 or 3. The weights are ``w``
    (one per pair, pair order) or, with ``tukey``, Tukey's ``(1 - u^2)^2`` (0 where ``|u| >= 1``) of
    ``u = r / cs[k]`` with ``r`` the pair's residual at its window's ``theta`` (:func:`rig_residual`),
    computed on the way (c.12.3 step 4: one IRLS step's sums in one pass)."""
    K, p = lo.shape[0], A.shape[1]
    S = np.zeros((K, 9 if p == 3 else 5))
    r = 0
    for k in range(K):
        s00, s01, s02, s11, s12, s22, g0, g1, g2 = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        for j in range(lo[k], lo[k] + m[k]):
            a0, a1, dj = A[j, 0], A[j, 1], d[j]
            a2 = A[j, 2] if p == 3 else 0.0
            if tukey:
                if p == 3:
                    res = dj - ((a0 * theta[k, 0] + a2 * theta[k, 2]) + a1 * theta[k, 1])
                else:
                    res = dj - (0.0 + a0 * theta[k, 0] + a1 * theta[k, 1])
                u = res / cs[k]
                t2 = 1.0 - u * u
                wr = t2 * t2 if abs(u) < 1.0 else 0.0
            else:
                wr = w[r]
            if p == 3:
                s00 += wr * (a0 * a0)
                s01 += wr * (a0 * a1)
                s02 += wr * (a0 * a2)
                s11 += wr * (a1 * a1)
                s12 += wr * (a1 * a2)
                s22 += wr * (a2 * a2)
                g0 += wr * (a0 * dj)
                g1 += wr * (a1 * dj)
                g2 += wr * (a2 * dj)
            else:
                s00 += wr * (a0 * a0)
                s01 += wr * (a0 * a1)
                s11 += wr * (a1 * a1)
                g0 += wr * (a0 * dj)
                g1 += wr * (a1 * dj)
            r += 1
        if p == 3:
            S[k, 0], S[k, 1], S[k, 2], S[k, 3], S[k, 4], S[k, 5] = s00, s01, s02, s11, s12, s22
            S[k, 6], S[k, 7], S[k, 8] = g0, g1, g2
        else:
            S[k, 0], S[k, 1], S[k, 2], S[k, 3], S[k, 4] = s00, s01, s11, g0, g1
    return S


@njit(cache=True)
def segment_sum(m, w):  # pragma: no cover - compiled
    """``sum w`` over each window's ``m[k]`` consecutive pairs, ``(K,)``."""
    K = m.shape[0]
    out = np.zeros(K)
    r = 0
    for k in range(K):
        s = 0.0
        for _ in range(m[k]):
            s += w[r]
            r += 1
        out[k] = s
    return out
