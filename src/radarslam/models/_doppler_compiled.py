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
