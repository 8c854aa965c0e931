"""JCBB's scan kernel (``landmarks.associator = "jcbb"``; docs/method.md c.4.1): one call per scan,
which the fused engine's step 4 and :class:`radarslam.slam.jcbb.JcbbAssociator` make
(:func:`jcbb_associate_scan`): the observations (DBSCAN of the candidates in the sensor frame,
clusters in label order then the noise points), the individual gate against the
``n_prefilter`` Euclidean-nearest landmarks (candidates by ``D^2`` then landmark), the search order
(fewest candidates first, ties by observation), the joint covariance, the branch and bound
(:func:`radarslam.slam.jcbb_search.jcbb_search`), and the batch updates (landmarks ascending). Its
kernels are :mod:`radarslam.slam.ekf`'s (the batch measurement and noise, the Joseph update) and the
compiled DBSCAN (:mod:`radarslam.landmarks._compiled`). Under ``filter.backend = "python"`` the same
code runs in the interpreter (tests/test_jcbb.py checks it against brute-force oracle problems).

The joint gates ``chi2.ppf(p, 2 k)`` come in as an array (:func:`joint_gates`): scipy is not
compiled.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.jit import compile_kernels
from radarslam.landmarks._compiled import dbscan_labels
from radarslam.slam._numba import (
    _batch_noise,
    _joseph_update_inplace,
    _polar_to_sensor_xy,
    _sensor_xy_measurement,
    _smallest,
)
from radarslam.slam.jcbb_search import _can_beat, close_block, extend_loops, jcbb_search


def joint_gates(probability: float, depth: int) -> np.ndarray:
    """``gates[k] = chi2.ppf(probability, 2 k)`` for ``k = 0 .. depth`` (``gates[0] = 0``): the joint
    gate of ``k`` pairings, :func:`radarslam.slam.jcbb.joint_gate`, for the compiled search."""
    from scipy.stats import chi2

    g = np.zeros(depth + 1)
    g[1:] = chi2.ppf(float(probability), 2 * np.arange(1, depth + 1))
    return g


#: The branch and bound of c.4.1, the kernels of slam/jcbb_search.py compiled as they are.
_J = compile_kernels(close_block, extend_loops, _can_beat, jcbb_search)
jcbb_search = _J["jcbb_search"]


@njit(cache=True)
def _observations(polar, cand, R, eps, min_samples):  # pragma: no cover - compiled
    """The observations of ``polar[cand]`` (c.4.1 step 1, DBSCAN in the sensor frame): each one's members
    (positions in ``cand``) as ``members[moff[o]:moff[o + 1]]``, its sensor-frame mean ``zbar (n, 2)``
    and mean detection noise ``R_xy (n, 2, 2)``."""
    sub = np.empty((cand.shape[0], 2))
    for a in range(cand.shape[0]):
        sub[a] = polar[cand[a]]
    pts, _ = _polar_to_sensor_xy(sub, R)
    labels = dbscan_labels(pts, eps, min_samples)
    n_cl = labels.max() + 1 if labels.shape[0] else 0
    n_noise = 0
    for a in range(labels.shape[0]):
        if labels[a] < 0:
            n_noise += 1
    n = n_cl + n_noise
    members = np.empty(labels.shape[0], dtype=np.int64)
    moff = np.zeros(n + 1, dtype=np.int64)
    q = 0
    for o in range(n_cl):                                     # clusters in label order
        for a in range(labels.shape[0]):
            if labels[a] == o:
                members[q] = a
                q += 1
        moff[o + 1] = q
    o = n_cl
    for a in range(labels.shape[0]):                          # then each noise point alone
        if labels[a] < 0:
            members[q] = a
            q += 1
            o += 1
            moff[o] = q
    zbar = np.empty((n, 2))
    R_xy = np.empty((n, 2, 2))
    for o in range(n):
        rows = members[moff[o]:moff[o + 1]]
        p, Rm = _polar_to_sensor_xy(sub[rows], R)
        R_xy[o] = Rm
        zbar[o, 0] = p[:, 0].mean()
        zbar[o, 1] = p[:, 1].mean()
    return members, moff, zbar, R_xy


@njit(cache=True)
def _candidate_pairs(x, P, zbar, R_xy, moff, gX, has_gX, platform, n_prefilter, gate1):  # pragma: no cover
    """c.4.1 step 2, against each observation's ``n_prefilter`` nearest landmarks: the individually compatible
    pairings, as rows ``(observation, landmark, D^2, nu (2,), Hs (2, 5), idx (5,), noise (2, 2))``
    grouped by observation (``coff``) and within one by ``D^2`` then landmark."""
    n, N = zbar.shape[0], (x.shape[0] - platform) // 2
    c, s = math.cos(x[2]), math.sin(x[2])
    count = min(n_prefilter, N)
    cap = max(1, n * count)
    c_j, c_d2 = np.empty(cap, dtype=np.int64), np.empty(cap)
    c_nu, c_H, c_idx, c_N = np.empty((cap, 2)), np.empty((cap, 2, 5)), np.empty((cap, 5), dtype=np.int64), np.empty((cap, 2, 2))
    coff = np.zeros(n + 1, dtype=np.int64)
    d = np.empty(N)
    q = 0
    for o in range(n):
        w0 = x[0] + (c * zbar[o, 0] + -s * zbar[o, 1])            # the world-frame mean
        w1 = x[1] + (s * zbar[o, 0] + c * zbar[o, 1])
        for j in range(N):
            d[j] = (x[platform + 2 * j] - w0) ** 2 + (x[platform + 2 * j + 1] - w1) ** 2
        start = q
        for j in _smallest(d, N, count):
            h, Hs, idx = _sensor_xy_measurement(x, j, platform)
            Nn = _batch_noise(x[2], np.ascontiguousarray(gX[j]), has_gX[j], R_xy[o], moff[o + 1] - moff[o])
            S = np.empty((2, 2))
            for t in range(2):
                for u in range(2):
                    acc = 0.0
                    for a in range(5):
                        for b in range(5):
                            acc += Hs[t, a] * P[idx[a], idx[b]] * Hs[u, b]
                    S[t, u] = acc + Nn[t, u]
            e0, e1 = zbar[o, 0] - h[0], zbar[o, 1] - h[1]
            a_, b_, dd = S[0, 0], 0.5 * (S[0, 1] + S[1, 0]), S[1, 1]
            det = a_ * dd - b_ * b_
            if not (a_ > 0.0 and det > 0.0):
                continue
            d2 = (dd * e0 * e0 - 2.0 * b_ * e0 * e1 + a_ * e1 * e1) / det
            if not d2 < gate1:
                continue
            p = q                                              # insert in (D^2, landmark) order
            while p > start and (c_d2[p - 1] > d2 or (c_d2[p - 1] == d2 and c_j[p - 1] > j)):
                c_j[p], c_d2[p], c_nu[p], c_H[p], c_idx[p], c_N[p] = (c_j[p - 1], c_d2[p - 1], c_nu[p - 1],
                                                                      c_H[p - 1], c_idx[p - 1], c_N[p - 1])
                p -= 1
            c_j[p], c_d2[p], c_H[p], c_idx[p], c_N[p] = j, d2, Hs, idx, Nn
            c_nu[p, 0], c_nu[p, 1] = e0, e1
            q += 1
        coff[o + 1] = q
    return coff, c_j[:q], c_nu[:q], c_H[:q], c_idx[:q], c_N[:q]


@njit(cache=True)
def _joint_covariance(rows, c_H, c_idx, c_N, P):  # pragma: no cover - compiled
    """:func:`radarslam.slam.jcbb_search.joint_covariance` of the pairings ``rows`` from their sparse
    Jacobians: ``C = H P H^T + blockdiag(N)``, symmetrised."""
    M = rows.shape[0]
    C = np.empty((2 * M, 2 * M))
    for a in range(M):
        ra = rows[a]
        for b in range(M):
            rb = rows[b]
            for t in range(2):
                for u in range(2):
                    acc = 0.0
                    for p in range(5):
                        for q in range(5):
                            acc += c_H[ra, t, p] * P[c_idx[ra, p], c_idx[rb, q]] * c_H[rb, u, q]
                    C[2 * a + t, 2 * b + u] = acc
        for t in range(2):
            for u in range(2):
                C[2 * a + t, 2 * a + u] += c_N[ra, t, u]
    return 0.5 * (C + C.T)


@njit(cache=True)
def jcbb_associate_scan(x, P, polar, cand, R, gX, has_gX, platform, eps, min_samples, n_prefilter, gates,
                        max_nodes):  # pragma: no cover - compiled
    """JCBB's association of the candidates ``polar[cand]`` (c.4.1), in place
    on ``x``, ``P``: observations, individual gate, search order, joint covariance, branch and bound,
    then one batch update per paired landmark (ascending), each at the state its predecessors left.
    ``gates``: :func:`joint_gates` to at least the number of candidates. Returns ``(x, P, landmark
    per candidate or -1, NIS values, (pair rows, their observations in search order, their
    landmarks, D^2, nodes, exhausted))``."""
    N = (x.shape[0] - platform) // 2
    out = np.full(cand.shape[0], -1, dtype=np.int64)
    none = np.empty(0, dtype=np.int64)
    if N == 0 or cand.shape[0] == 0:
        return x, P, out, np.empty(0), (none, none, none, 0.0, 0, False)
    members, moff, zbar, R_xy = _observations(polar, cand, R, eps, min_samples)
    coff, c_j, c_nu, c_H, c_idx, c_N = _candidate_pairs(x, P, zbar, R_xy, moff, gX, has_gX, platform,
                                                        n_prefilter, gates[1])
    n_cands = coff[1:] - coff[:-1]
    searched = np.flatnonzero(n_cands > 0)
    order = searched[np.argsort(n_cands[searched], kind="mergesort")]   # fewest first, ties by observation
    M = c_j.shape[0]
    rows = np.empty(M, dtype=np.int64)
    obs = np.empty(M, dtype=np.int64)
    q = 0
    for rank in range(order.shape[0]):
        for r in range(coff[order[rank]], coff[order[rank] + 1]):
            rows[q], obs[q] = r, rank
            q += 1
    lm = c_j[rows]
    pairs, d2, nodes, exhausted = none, 0.0, 1, False
    if M:
        C = _joint_covariance(rows, c_H, c_idx, c_N, P)
        pairs, d2, nodes, exhausted = jcbb_search(obs, lm, c_nu[rows], C, order.shape[0], gates, max_nodes)
    nis = np.empty(pairs.shape[0])
    by_lm = pairs[np.argsort(lm[pairs], kind="mergesort")]
    for a in range(by_lm.shape[0]):
        j, o = lm[by_lm[a]], order[obs[by_lm[a]]]
        h, Hs, idx = _sensor_xy_measurement(x, j, platform)
        e = np.empty(2)
        e[0], e[1] = zbar[o, 0] - h[0], zbar[o, 1] - h[1]
        noise = _batch_noise(x[2], np.ascontiguousarray(gX[j]), has_gX[j], R_xy[o], moff[o + 1] - moff[o])
        nis[a] = _joseph_update_inplace(x, P, e, Hs, idx, noise)
        for b in range(moff[o], moff[o + 1]):
            out[members[b]] = j
    return x, P, out, nis, (pairs, obs[pairs], lm[pairs], d2, nodes, exhausted)
