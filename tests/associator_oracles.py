"""The associators of slam/association.py written a second way, in numpy over the functions of
slam/ekf.py, as test oracles for the one kernel each scheme has (slam/_numba.py)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.slam import ekf
from radarslam.slam.layout import POSE_DIM


def nearest_landmarks(xs: list[float], s, count: int, platform: int = POSE_DIM) -> list[int]:
    """Positions of the ``count`` landmarks Euclidean-nearest to detection ``s`` seen from the pose
    of ``xs`` (the state as a list), nearest first, ties by position."""
    a = xs[2] + s[1]
    zx, zy = xs[0] + s[0] * math.cos(a), xs[1] + s[0] * math.sin(a)
    d2 = [(lx - zx) ** 2 + (ly - zy) ** 2 for lx, ly in zip(xs[platform::2], xs[platform + 1::2])]
    return sorted(range(len(d2)), key=d2.__getitem__)[:count]


def best_match(state, s, count, R, spreads=None):
    """The landmark of smallest log distance among the ``count`` nearest, with its update terms:
    ``(j, D, e, Hs, idx, R_j)``; ``j = -1`` and ``D = inf`` without one."""
    if not state.n_landmarks:
        return (-1, math.inf, None, None, None, None)
    xs, p = state.x.tolist(), state.platform_dim
    js = nearest_landmarks(xs, s, count, p)
    gX = None
    if spreads is not None and spreads.has.any():
        gX = [spreads.gX[j].tolist() if spreads.has[j] else None for j in js]
    j, D, e = ekf.score_landmarks(state.x, state.P, s, js, R, gX, xs, p)
    if j < 0:
        return (-1, math.inf, None, None, None, None)
    Hs, idx = ekf.sparse_jacobian(state.linearisation(j), j, p)
    Rj = ekf.r_eff(R, Hs, spreads.gX[j]) if spreads is not None and spreads.has[j] else R
    return (j, D, np.array(e), Hs, idx, Rj)


def sequential(state, polar, candidates, R, spreads, beta, n_nearest):
    """The nearest-neighbour scheme: each candidate in turn, updated at once below ``beta``."""
    out, nis = np.full(candidates.shape[0], -1, dtype=int), []
    for c, i in enumerate(candidates.tolist()):
        j, D, e, Hs, idx, Rj = best_match(state, polar[i], n_nearest, R, spreads)
        if j >= 0 and D < beta:
            nis.append(ekf.joseph_update_inplace(state.x, state.P, e, Hs, idx, Rj))
            out[c] = j
    return out, np.array(nis)


def scores(state, polar, candidates, R, spreads, beta, n_nearest):
    """The landmark of each candidate (-1 for none), all scored at the current state."""
    out = np.full(candidates.shape[0], -1, dtype=int)
    for c, i in enumerate(candidates.tolist()):
        j, D = best_match(state, polar[i], n_nearest, R, spreads)[:2]
        if j >= 0 and D < beta:
            out[c] = j
    return out


def _landmark_rows(state, polar, candidates, out, R, spreads, j):
    dets = candidates[out == j]
    pts, R_xy = ekf.polar_to_sensor_xy(polar[dets], R)
    noise = ekf.batch_noise(state.x[2], spreads.gX[j], spreads.has[j], R_xy, dets.size, spreads.offset_k)
    h, Hs, idx = ekf.sensor_xy_measurement(state.x, j, state.platform_dim)
    if state.lin_pose is not None:
        Hs = ekf.sensor_xy_measurement(state.linearisation(j), j, state.platform_dim)[1]
    return pts.mean(axis=0) - h, Hs, idx, noise


def batch(state, polar, candidates, R, spreads, beta, n_nearest):
    """One Joseph update per landmark with the mean of its detections, landmarks ascending."""
    out = scores(state, polar, candidates, R, spreads, beta, n_nearest)
    nis = [ekf.joseph_update_inplace(state.x, state.P, *_landmark_rows(state, polar, candidates, out, R, spreads, j))
           for j in np.unique(out[out >= 0]).tolist()]
    return out, np.array(nis)


def joint_batch(state, polar, candidates, R, spreads, beta, n_nearest):
    """Every landmark's mean detection stacked into one dense update."""
    out = scores(state, polar, candidates, R, spreads, beta, n_nearest)
    seen = np.unique(out[out >= 0]).tolist()
    if not seen:
        return out, np.empty(0)
    n, L = state.x.shape[0], len(seen)
    e, H, Rb = np.empty(2 * L), np.zeros((2 * L, n)), np.zeros((2 * L, 2 * L))
    for a, j in enumerate(seen):
        ea, Hs, idx, noise = _landmark_rows(state, polar, candidates, out, R, spreads, j)
        e[2 * a:2 * a + 2], H[2 * a:2 * a + 2, idx], Rb[2 * a:2 * a + 2, 2 * a:2 * a + 2] = ea, Hs, noise
    return out, ekf.joint_update_inplace(state.x, state.P, e, H, Rb)
