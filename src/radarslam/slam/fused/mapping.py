"""The fused engine's steps that make and merge landmarks (docs/method.md a.8 steps 7-10): cluster
the detections no landmark claimed (c.6), the alpha test, Rule 2 / Rule 1 (c.7), augmentation
(c.8) and merging (c.9). One compiled function per step; ``cfg`` is the engine's
:class:`~radarslam.slam.fused.plan.FusedParams`.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.jit import compile_kernels, compiled_only
from radarslam.extent._compiled import merge_rows
from radarslam.landmarks._compiled import compiled_add_record
from radarslam.landmarks._compiled import compiled_closest_pair as _closest_pair
from radarslam.landmarks._compiled import compiled_rule12 as _rule12
from radarslam.landmarks._compiled import dbscan_centres, dbscan_labels
from radarslam.landmarks.confirmation import Tentatives
from radarslam.models.radar import inverse_jacobians, polar_to_xy
from radarslam.slam import ekf
from radarslam.slam._numba import _polar_to_sensor_xy, min_log_distance
from radarslam.slam.fused.view import view_newborn
from radarslam.slam.fused.storage import (
    Clusters,
    _drop_state_rows,
    compact_landmarks,
    grow_landmarks,
    records,
    pool_arcs,
    with_buffer,
)

# The reference's own kernels, compiled as they are: the augmentation (c.8).
_K = compile_kernels(polar_to_xy, inverse_jacobians, ekf.augment, ekf.augment_point)
_augment = _K["augment"]
_augment_point = _K["augment_point"]


@compiled_only
def cluster(xy, polar, cand, cfg):  # pragma: no cover - compiled
    """Step 7: DBSCAN of the detections no landmark claimed (c.6), as :class:`Clusters`."""
    rest = np.flatnonzero(~cand)
    n_rest = rest.shape[0]
    if n_rest < cfg.min_samples:
        return Clusters(rest, np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64))
    pts_rest = np.empty((n_rest, 2))
    rng_rest = np.empty(n_rest)
    for a in range(n_rest):
        pts_rest[a] = xy[rest[a]]
        rng_rest[a] = polar[rest[a], 0]
    labels = dbscan_labels(pts_rest, cfg.eps, cfg.min_samples)
    centres = dbscan_centres(rng_rest, labels)
    nc = centres.shape[0]
    cl_centre = np.empty(nc, dtype=np.int64)
    cl_size = np.zeros(nc, dtype=np.int64)
    for a in range(n_rest):
        if labels[a] >= 0:
            cl_size[labels[a]] += 1
    for c in range(nc):
        cl_centre[c] = rest[centres[c]]
    return Clusters(rest, labels, cl_centre, cl_size)


@compiled_only
def alpha_test(x, P, polar, clusters, noise, cfg):  # pragma: no cover - compiled
    """Step 7: the clusters whose centre is farther than ``cfg.alpha`` (minimum log-distance to
    the ``cfg.n_new`` nearest landmarks) from every landmark, in order."""
    cl_centre = clusters.centre
    nc = cl_centre.shape[0]
    fresh = np.empty(nc, dtype=np.int64)
    nf = 0
    for c in range(nc):
        i = cl_centre[c]
        if min_log_distance(x, P, polar[i, 0], polar[i, 1], cfg.n_new, noise.R, cfg.platform) > cfg.alpha:
            fresh[nf] = c
            nf += 1
    return fresh[:nf]


@compiled_only
def confirm(tent, fresh, clusters, xy, cfg):  # pragma: no cover - compiled
    """Step 8: Rule 2 then Rule 1 (c.7) of the fresh clusters, the kernel
    landmarks.confirmation.rule12 compiled as it is. Returns ``(confirmed clusters, tent)``."""
    nf = fresh.shape[0]
    cc = np.empty((nf, 2))
    cs = np.empty(nf, dtype=np.int64)
    for f in range(nf):
        i = clusters.centre[fresh[f]]
        cc[f, 0], cc[f, 1] = xy[i, 0], xy[i, 1]
        cs[f] = clusters.size[fresh[f]]
    conf, centre, count, window, npts = _rule12(tent.centre, tent.count, tent.window, tent.npts, cc, cs,
                                                cfg.tentative_gate, cfg.confirm_points, cfg.confirm_window,
                                                cfg.confirm_hits)
    confirmed = np.empty(conf.shape[0], dtype=np.int64)
    for a in range(conf.shape[0]):
        confirmed[a] = fresh[conf[a]]
    return confirmed, Tentatives(centre, count, window, npts)


@compiled_only
def _augment_mean(x, P, polar, R, spread, has_spread):  # pragma: no cover - compiled
    """ekf.augment_mean: a landmark at the mean of detections ``polar``, with the mean's noise and
    the prior spread (c.8, [PROP])."""
    pts, R_xy = _polar_to_sensor_xy(polar, R)
    z0 = pts[:, 0].mean()
    z1 = pts[:, 1].mean()
    c, s = math.cos(x[2]), math.sin(x[2])
    rot = np.array([[c, -s], [s, c]])
    p0 = x[0] + (rot[0, 0] * z0 + rot[0, 1] * z1)
    p1 = x[1] + (rot[1, 0] * z0 + rot[1, 1] * z1)
    Gx = np.array([[1.0, 0.0, x[1] - p1], [0.0, 1.0, p0 - x[0]]])
    C = rot @ (R_xy / polar.shape[0]) @ np.ascontiguousarray(rot.T)
    if has_spread:
        C = C + spread
    return _augment_point(x, P, np.array([p0, p1]), Gx, C)


@compiled_only
def augment(x, P, lm, N, next_id, confirmed, clusters, polar, k, noise, cfg):  # pragma: no cover - compiled
    """Step 9: a landmark per confirmed cluster (c.8), created at scan ``k``, at the mean of its
    detections (``cfg.init_cluster``) or at its centre detection. Returns ``(x, P, lm, N, next_id)``."""
    rest, labels, cl_centre, cl_size = clusters
    for a in range(confirmed.shape[0]):
        c = confirmed[a]
        if cfg.init_cluster:
            members = np.empty((cl_size[c], 2))
            q = 0
            for b in range(rest.shape[0]):
                if labels[b] == c:
                    members[q] = polar[rest[b]]
                    q += 1
            x, P = _augment_mean(x, P, members, noise.R, noise.prior_spread, cfg.spread_at_birth)
        else:
            i = cl_centre[c]
            x, P = _augment(x, P, polar[i].copy(), noise.R)
        lm = grow_landmarks(lm, N + 1)
        # in place (the rows were grown above), with its first estimate (c.2.1)
        compiled_add_record(records(lm), N, next_id, k, x[-2], x[-1])
        lm.einit[N], lm.alpha[N], lm.nbuf[N] = False, 0.0, 0
        lm.narc[N], lm.arc_head[N], lm.arc_tail[N] = 0, -1, -1
        view_newborn(x, lm, N, cfg)                          # the partial view's shape (a.12.6)
        next_id += 1
        N += 1
    return x, P, lm, N, next_id


@compiled_only
def merge(x, P, lm, N, arcs, cfg):  # pragma: no cover - compiled
    """Step 10: merging (c.9): repeatedly drop the later-created landmark of the closest eligible
    pair (at most ``cfg.merge_max`` a scan, 0 for no limit); the survivor pools the other's
    visible-arc widths after its own. Returns ``(x, P, lm, N, pairs)``: ``pairs`` the ``(kept id,
    dropped id)`` of each merge, in order."""
    n_merged = 0
    pairs = np.empty((max(N - 1, 0), 2), dtype=np.int64)
    while N >= 2 and (cfg.merge_max == 0 or n_merged < cfg.merge_max):
        if not cfg.merge_distance > 0:
            break
        pos = np.empty((N, 2))
        for j in range(N):
            pos[j, 0], pos[j, 1] = x[cfg.platform + 2 * j], x[cfg.platform + 1 + 2 * j]
        bi, bj = _closest_pair(pos, lm.created[:N], lm.ids[:N], cfg.merge_distance, cfg.merge_axis_tol)
        if bi < 0:
            break
        pairs[n_merged, 0], pairs[n_merged, 1] = lm.ids[bi], lm.ids[bj]
        lm = with_buffer(lm, lm.nbuf[bi] + lm.nbuf[bj])
        merge_rows(lm, bi, bj, cfg.pv.on)                 # the extents (extent.rows.merge_rows)
        pool_arcs(arcs, lm, bi, bj)
        keepm = np.ones(N, dtype=np.bool_)
        keepm[bj] = False
        x, P = _drop_state_rows(x, P, keepm)
        compact_landmarks(lm, keepm)
        N -= 1
        n_merged += 1
    return x, P, lm, N, pairs[:n_merged]
