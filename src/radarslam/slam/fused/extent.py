"""The fused engine's extent step (docs/method.md a.8 step 6): buffering and the EFA
initialisation (a.3), then per scan the random-matrix prediction and update with the EFA baseline
(a.4, a.5, Decision 5), the visible-arc widths (a.9) or MEM-EKF* (a.10). One compiled function,
:func:`extent_step`, the bookkeeping between the estimators' own kernels, compiled as they are;
``cfg`` is the engine's :class:`~radarslam.slam.fused.plan.FusedParams`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.jit import compile_kernels
from radarslam.extent import mem_ekf_kernels
from radarslam.extent._compiled import _fit_entries, _max_trace_w_entries, buffer_need, initialise_rows, rma_efa_rows
from radarslam.extent.ellipse import _ellipse_to_matrix
from radarslam.slam.fused.storage import _arc_width_diameter, _blocks, add_arc, with_buffer
from radarslam.slam.fused.view import view_shape_step

# MEM-EKF*'s kernels (docs/method.md a.10), compiled as they are.
_MEM = compile_kernels(*mem_ekf_kernels.KERNELS, _ellipse_to_matrix)
_initial_shape = _MEM["initial_shape"]
_mem_ekf_predict_cov = _MEM["mem_ekf_predict_cov"]
_detection_cov_entries = _MEM["detection_cov_entries"]
_mem_ekf_scan_entries = _MEM["mem_ekf_scan_entries"]
_shape_matrix = _MEM["_ellipse_to_matrix"]
AXIS_FLOOR = mem_ekf_kernels.AXIS_FLOOR

#: ``FusedParams.mem_noise``: what each detection's noise holds besides the shape (extent.mem_ekf_noise).
MEM_SENSOR, MEM_NO_CENTROID, MEM_FULL = 0, 1, 2


@njit(cache=True, inline="always")
def _initialise(lm, N, old, aoff, arow, xy, Cp0, cfg):  # pragma: no cover - compiled
    """a.3 for the landmarks whose extent is not initialised (extent.rows.initialise_rows, the
    buffers grown first); with ``cfg.mem`` the MEM-EKF* shape of a fit made now, of covariance
    ``Cp0`` (a.10), ``X`` its matrix. Returns ``(lm, ready)``: the record (its buffers may grow)
    and which landmarks were initialised before this scan."""
    ready = np.empty(N, dtype=np.bool_)
    for j in range(N):
        ready[j] = lm.einit[j]
    born = np.zeros(N, dtype=np.int64)
    lm = with_buffer(lm, buffer_need(lm, ready, N, old, aoff))
    initialise_rows(lm, ready, born, N, old, aoff, arow, xy, cfg.n_init, cfg.gamma, cfg.alpha0)
    if cfg.mem:
        for j in range(N):
            if born[j] > 0:
                th, l1, l2 = _initial_shape(lm.X[j, 0, 0], lm.X[j, 0, 1], lm.X[j, 1, 1])
                lm.shape[j, 0], lm.shape[j, 1], lm.shape[j, 2] = th, l1, l2
                lm.Cs[j] = Cp0
                lm.X[j] = _shape_matrix(l1, l2, th)
    return lm, ready


@njit(cache=True)
def _mem_ekf_ready(x, P, polar, xy, lm, ready, old, aoff, arow, cents, ccovs, R_ext, dt, cfg):  # pragma: no cover - compiled
    """a.10 for the landmarks ``ready`` (shape initialised), as
    :meth:`~radarslam.extent.mem_ekf.MemEkfEstimator.step`: the shape covariance grown over ``dt``,
    the scan's detections one by one (each with its ``W(i)``, of the sensor noise alone or with the
    pose's, and the centroid's covariance under ``cfg.mem_noise``), ``X`` the new shape's matrix,
    and the EFA baseline of the scan (Decision 5), in place. Not inlined into ``run_stream``: a
    function of its own compiled once, which kept the engine's cold compilation shorter."""
    p = P[:3, :3].copy()
    pc = np.zeros((3, 3)) if cfg.mem_noise == MEM_SENSOR else p
    z2 = np.zeros((2, 2))
    for l in range(ready.shape[0]):
        j = ready[l]
        if dt > 0.0:
            lm.Cs[j] = _mem_ekf_predict_cov(lm.Cs[j], dt, cfg.mem_q_theta, cfg.mem_q_axis)
        o = old[j]
        na = aoff[o + 1] - aoff[o]
        if na == 0:
            continue
        pol = np.empty((na, 2))
        pts = np.empty((na, 2))
        for a in range(na):
            pol[a] = polar[arow[aoff[o] + a]]
            pts[a] = xy[arow[aoff[o] + a]]
        cvs = _detection_cov_entries(x[2], pc[0, 0], pc[0, 1], pc[0, 2], pc[1, 1], pc[1, 2], pc[2, 2],
                                     R_ext[0, 0], R_ext[0, 1], R_ext[1, 1], pol)
        cm = ccovs[j] if cfg.mem_noise == MEM_FULL else z2
        C = lm.Cs[j]
        s = lm.shape[j]
        th, l1, l2, C[0, 0], C[0, 1], C[0, 2], C[1, 1], C[1, 2], C[2, 2] = _mem_ekf_scan_entries(
            s[0], s[1], s[2], C[0, 0], C[0, 1], C[0, 2], C[1, 1], C[1, 2], C[2, 2], cents[j, 0], cents[j, 1],
            cm[0, 0], cm[0, 1], cm[1, 1], pts, cvs, cfg.gamma, AXIS_FLOOR)
        C[1, 0], C[2, 0], C[2, 1] = C[0, 1], C[0, 2], C[1, 2]
        s[0], s[1], s[2] = th, l1, l2
        lm.X[j] = _shape_matrix(l1, l2, th)
        w00, w01, w11 = 0.0, 0.0, 0.0
        if not cfg.upper:
            w00, w01, w11 = _max_trace_w_entries(x[2], p[0, 0], p[0, 1], p[0, 2], p[1, 1], p[1, 2], p[2, 2],
                                                 R_ext[0, 0], R_ext[0, 1], R_ext[1, 1], pol)
        ok, _, _, e11, e12, e22 = _fit_entries(pts, cfg.upper, w00, w01, w11, cfg.gamma)
        if ok:
            lm.Xefa[j, 0, 0], lm.Xefa[j, 0, 1], lm.Xefa[j, 1, 0], lm.Xefa[j, 1, 1] = e11, e12, e12, e22


@njit(cache=True, inline="always")
def _arc_widths(polar, lm, N, old, aoff, arow, arcs, n_arcs, cfg):  # pragma: no cover - compiled
    """The visible-arc estimator's part of step 6 (a.9): each landmark's width of this scan from
    its associated detections, kept when they are consecutive beams. Returns ``(arcs, n_arcs)``."""
    for j in range(N):
        o = old[j]
        na = aoff[o + 1] - aoff[o]
        if na == 0:
            continue
        mine = np.empty((na, 2))
        r_min = math.inf
        for a in range(na):
            mine[a] = polar[arow[aoff[o] + a]]
            r_min = min(r_min, mine[a, 0])
        d = _arc_width_diameter(mine, cfg.beam_step)
        if math.isfinite(d):
            arcs = add_arc(arcs, n_arcs, lm, j, d, r_min * cfg.beam_step)
            n_arcs += 1
    return arcs, n_arcs


@njit(cache=True, inline="always")
def extent_step(x, P, polar, xy, lm, N, old, aoff, arow, prior, dt, arcs, n_arcs, noise, cfg):  # pragma: no cover - compiled
    """Step 6: the extent step (a.3-a.5) with the detections ``xy`` in the world frame of the
    updated pose, about the posterior centroids (``cfg.posterior``) or the prior ones (``prior``,
    by the rows before the removal, ``old``); with ``cfg.arc`` the visible-arc widths (a.9), with
    ``cfg.mem`` MEM-EKF* (a.10) instead of the random-matrix step; under the partial view
    (``cfg.pv.on``) the shapes of a.12.7 after it.
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
    lm, ready = _initialise(lm, N, old, aoff, arow, xy, noise.Cp0, cfg)
    if cfg.mem:
        n_ready = 0
        for j in range(N):
            n_ready += ready[j]
        which = np.empty(n_ready, dtype=np.int64)
        r_i = 0
        for j in range(N):
            if ready[j]:
                which[r_i] = j
                r_i += 1
        if n_ready > 0:
            _mem_ekf_ready(x, P, polar, xy, lm, which, old, aoff, arow, cents, ccovs, noise.R_ext, dt, cfg)
    else:
        rma_efa_rows(lm, ready, N, old, aoff, arow, polar, xy, cents, ccovs, x[:3], P[:3, :3], noise.R_ext,
                     np.zeros((0, 2, 2)), False, dt, cfg.tau, cfg.gamma, cfg.eig_floor, cfg.upper, True)
    if cfg.arc:
        arcs, n_arcs = _arc_widths(polar, lm, N, old, aoff, arow, arcs, n_arcs, cfg)
    if cfg.pv.on:                                      # the partial-view shapes (a.12.7)
        view_shape_step(x, polar, xy, lm, N, old, aoff, arow, cents, ccovs, noise, cfg)
    return lm, arcs, n_arcs
