"""The fused engine's extent step (docs/method.md a.8 step 6): the extent step over array-held
states (:mod:`radarslam.extent.rows`, the functions the built-in estimators' own methods call
too), compiled, on the engine's landmark record: buffering and the EFA initialisation (a.3), then
per scan the random-matrix prediction and update with the EFA baseline (a.4, a.5, Decision 5) or
MEM-EKF* (a.10), the visible-arc widths (a.9) and the partial view's shapes (a.12.7). ``cfg`` is
the engine's :class:`~radarslam.slam.fused.plan.FusedParams`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.jit import compiled_only
from radarslam.extent._compiled import (arc_widths_rows, buffer_need, initialise_rows, mem_ekf_initialise_rows,
                                        detections, mem_ekf_rows, rma_efa_rows, scan_w_entries, sliding_efa_rows,
                                        view_rows)
from radarslam.slam.fused.storage import _blocks, add_arc, with_buffer


@compiled_only
def _arc_widths(polar, lm, N, old, aoff, arow, arcs, n_arcs, cfg):  # pragma: no cover - compiled
    """The visible-arc part (a.9): each landmark's width of this scan
    (:func:`radarslam.extent.visible_arc.arc_widths_rows`), kept in its list when finite.
    Returns ``(arcs, n_arcs)``."""
    d = np.empty(N)
    beam = np.empty(N)
    arc_widths_rows(polar, N, old, aoff, arow, cfg.beam_step, d, beam)
    for j in range(N):
        if math.isfinite(d[j]):
            arcs = add_arc(arcs, n_arcs, lm, j, d[j], beam[j])
            n_arcs += 1
    return arcs, n_arcs


@compiled_only
def _scan_ws(polar, N, old, aoff, arow, pose, pose_cov, R, mode):  # pragma: no cover - compiled
    """Each landmark's scan ``W`` (N, 2, 2) under ``extent.w_mode`` other than the largest trace (h.3;
    :func:`radarslam.extent.measurement.scan_w_entries` of its associated detections; zeros for none)."""
    W = np.zeros((N, 2, 2))
    for j in range(N):
        if aoff[old[j] + 1] > aoff[old[j]]:
            w00, w01, w11 = scan_w_entries(pose, pose_cov, detections(polar, aoff, arow, old[j]), R, mode)
            W[j, 0, 0], W[j, 0, 1], W[j, 1, 0], W[j, 1, 1] = w00, w01, w01, w11
    return W


@njit(cache=True, inline="always")
def extent_step(x, P, polar, xy, lm, N, old, aoff, arow, prior, dt, arcs, n_arcs, noise, cfg, view):  # pragma: no cover - compiled
    """Step 6: the extent step (a.3-a.5) with the detections ``xy`` in the world frame of the
    updated pose, about the posterior centroids (``cfg.posterior``) or the prior ones (``prior``,
    by the rows before the removal, ``old``); with ``cfg.mem`` MEM-EKF* (a.10) instead of the
    random-matrix step; with ``cfg.arc`` the visible-arc widths (a.9); under the partial view
    (``view``: ``cfg.pv.on``, the engine's compile-time flag, engine.Family) the shapes of a.12.7 after it.
    Returns ``(lm, arcs, n_arcs)`` (buffers may grow)."""
    if not cfg.track or N == 0:
        return lm, arcs, n_arcs
    pos_prior, cov_prior = prior
    if cfg.posterior:
        cents, ccovs = _blocks(x, P, cfg.platform)
    else:
        cents = np.empty((N, 2))
        ccovs = np.empty((N, 2, 2))
        for j in range(N):
            cents[j] = pos_prior[old[j]]
            ccovs[j] = cov_prior[old[j]]
    pose, pose_cov = x[:3].copy(), P[:3, :3].copy()
    w_given = cfg.w_mode != 0                                   # h.3: another W than the largest trace's
    W = _scan_ws(polar, N, old, aoff, arow, pose, pose_cov, noise.R_ext, cfg.w_mode) if w_given else np.zeros((0, 2, 2))
    ready = np.empty(N, dtype=np.bool_)
    for j in range(N):
        ready[j] = lm.einit[j]
    born = np.zeros(N, dtype=np.int64)
    lm = with_buffer(lm, buffer_need(lm, ready, N, old, aoff))
    initialise_rows(lm, ready, born, N, old, aoff, arow, xy, cfg.n_init, cfg.gamma, cfg.alpha0)        # a.3
    per_scan = cfg.efa_window == 0                                                                     # Decision 5
    if cfg.mem:                                                                                        # a.10
        mem_ekf_initialise_rows(lm, born, N, noise.Cp0)
        mem_ekf_rows(lm, ready, N, old, aoff, arow, polar, xy, cents, ccovs, pose, pose_cov, noise.R_ext, W, w_given,
                     dt, cfg.mem_q_theta, cfg.mem_q_axis, cfg.mem_noise, cfg.gamma, cfg.upper, per_scan)
    else:                                                                                              # a.4-a.5
        rma_efa_rows(lm, ready, N, old, aoff, arow, polar, xy, cents, ccovs, pose, pose_cov, noise.R_ext, W, w_given,
                     dt, cfg.tau, cfg.gamma, cfg.eig_floor, cfg.upper, per_scan)
    if not per_scan:                                                     # the EFA of the last efa_window detections
        lm = with_buffer(lm, cfg.efa_window)
        sliding_efa_rows(lm, ready, born, N, old, aoff, arow, polar, xy, pose, pose_cov, noise.R_ext, W, w_given,
                         cfg.efa_window, cfg.gamma, cfg.upper)
    if cfg.arc:                                                                                        # a.9
        arcs, n_arcs = _arc_widths(polar, lm, N, old, aoff, arow, arcs, n_arcs, cfg)
    if view:                                                                                           # a.12.7
        v = cfg.pv
        view_rows(lm, N, old, aoff, arow, polar, xy, cents, ccovs, pose, noise.R_ext, v.Q, v.qv2, v.rel, v.spread_only,
                  v.shape_step)
    return lm, arcs, n_arcs
