"""The fused engine under the partial view (docs/method.md a.12): its parameters (:class:`ViewParams`,
``FusedParams.pv``, from :func:`view_parameters`) and its steps, each the bookkeeping of the
partial view's parts around the kernels they call (:mod:`radarslam.slam.view_kernels`,
compiled in :mod:`radarslam.slam._view_compiled`; the shape update of
:mod:`radarslam.extent.view_estimator`):

- :func:`view_walk`: the centroids' random walk with the viewing angle (a.12.5), before the prior;
- :func:`view_shapes` and :func:`view_terms`: every landmark's arc-model shape and its ``mu``,
  ``B``, ``S`` (with the model error's ``J = dg/dxi`` from the same pass, a.12.9) at the predicted
  state, computed once for sifting and scoring (both read the same state);
- :func:`view_sift`: a.7.1 about the predicted detection means (``PartialViewEstimator.sift``);
- :func:`view_associate`: the partial-view nearest-neighbour, batch and batch-joint associators
  (``slam.partial_view``), with each landmark's model error and polar terms computed when a
  detection first needs them (the same values, not every landmark's);
- :func:`view_newborn`: a new landmark's shape and view-corrected centroid (a.12.6).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from radarslam.core.jit import compiled_only
from radarslam.extent._compiled import measurement_contour, sift_spreads
from radarslam.landmarks._compiled import compiled_candidates, compiled_seen_landmarks
from radarslam.slam._numba import (_joseph_update_inplace, _polar_to_sensor_xy, _smallest, _wrap_pi, joint_update_loops,
                                   stacked_rows)
from radarslam.slam._view_compiled import (corrected_centroid, exp_sym2, innovation_cov, model_error_rows, polar_row,
                                           polar_rows, sensor_xy_rows, shape_error_one, shape_error_rows, view_batch_noise,
                                           view_log_distance, view_rows, view_walk_rows, view_xi_rows)
from radarslam.slam.fused.tracking import _to_world, associate_and_update, jcbb_and_update, sift
from radarslam.slam.layout import POSE_DIM

#: ``ViewParams.shape_mode``: the arc model's shape (extent.view_shape).
SHAPE_ESTIMATED, SHAPE_RMA, SHAPE_PRIOR = 0, 1, 2
#: Iterations of the view-corrected centroid (slam.partial_view.view_corrected_centroid's default).
CORRECTION_ITERATIONS = 5


class ViewParams(NamedTuple):
    """The partial view's part of :class:`~radarslam.slam.fused.plan.FusedParams` (``cfg.pv``)."""

    on: bool               #: the partial-view model (extent.view_model)
    walk: float            #: extent.view_walk_m2_per_rad
    with_cov: bool         #: extent.view_shape_uncertainty with the estimated shape (J P_xi J^T)
    init_correct: bool     #: extent.view_init_correct with landmarks.init = "cluster" (a.12.6)
    shape_mode: int        #: extent.view_shape: SHAPE_ESTIMATED, SHAPE_RMA, SHAPE_PRIOR
    spread_only: bool      #: extent.view_shape_data == "spread"
    qv2: float             #: extent.view_model_error_m ** 2
    rel: float             #: extent.view_spread_rel_error
    Qv: np.ndarray         #: (2, 2) the model-error covariance
    xi0: np.ndarray        #: (3,) the newborn shape's log matrix
    P0: np.ndarray         #: (3, 3) its covariance
    Q: np.ndarray          #: (3, 3) the shape's random walk per scan
    X0: np.ndarray         #: (2, 2) the prior shape
    shape_step: float      #: central-difference step of the shape's Jacobians, 0 for analytic (extent.view_jacobian)


def view_parameters(slam) -> ViewParams:
    """The :class:`ViewParams` of ``slam`` (off, with zeros, under the full view)."""
    from radarslam.extent.view_estimator import log_matrix_to_X

    ec = slam.config.extent
    if getattr(slam, "view", None) is None:
        z3 = np.zeros(3)
        return ViewParams(False, 0.0, False, False, SHAPE_ESTIMATED, False, 0.0, 0.0, np.zeros((2, 2)), z3,
                          np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((2, 2)), 0.0)
    ext = slam.extent
    mode = {"estimated": SHAPE_ESTIMATED, "rma": SHAPE_RMA, "prior": SHAPE_PRIOR}[ec.view_shape]
    return ViewParams(True, float(ec.view_walk_m2_per_rad), bool(ec.view_shape_uncertainty) and mode == SHAPE_ESTIMATED,
                      bool(ec.view_init_correct) and slam.config.landmarks.init == "cluster", mode,
                      bool(ext.spread_only), float(ext.qv2), float(ext.rel),
                      np.ascontiguousarray(slam.view, dtype=float), np.ascontiguousarray(ext.xi0, dtype=float),
                      np.ascontiguousarray(ext.P0, dtype=float), np.ascontiguousarray(ext.Q, dtype=float),
                      np.ascontiguousarray(log_matrix_to_X(ext.xi0), dtype=float), float(ext.shape_step))


@compiled_only
def view_walk(x, P, lm, N, cfg):  # pragma: no cover - compiled
    """a.12.5's walk of the centroids with the viewing angle, in place on ``P``, and each
    landmark's bearing kept for the next scan (none under a zero walk)."""
    if cfg.pv.walk > 0.0 and N > 0:
        lm.vangle[:N] = view_walk_rows(x, P, lm.vangle[:N].copy(), cfg.pv.walk, cfg.platform)


@compiled_only
def view_shapes(lm, N, cfg):  # pragma: no cover - compiled
    """``(N, 2, 2)``: the arc model's shape of every landmark (``PartialViewEstimator.view_shapes``):
    its estimate ``expm(xi)``, its RMA (the prior before it has one) or the prior."""
    v = cfg.pv
    X = np.empty((N, 2, 2))
    for j in range(N):
        if v.shape_mode == SHAPE_ESTIMATED:
            X11, X12, X22 = exp_sym2(lm.xi[j, 0], lm.xi[j, 1], lm.xi[j, 2])
            X[j, 0, 0], X[j, 0, 1], X[j, 1, 0], X[j, 1, 1] = X11, X12, X12, X22
        elif v.shape_mode == SHAPE_RMA and lm.einit[j]:
            X[j] = lm.X[j]
        else:
            X[j] = v.X0
    return X


@compiled_only
def _analytic_cov(pv):  # pragma: no cover - compiled
    """True when the model error takes the shape's uncertainty with the analytic ``J`` (a.12.9);
    ``pv`` the :class:`ViewParams`."""
    return pv.with_cov and pv.shape_step == 0.0


@compiled_only
def view_terms(x, shapes, N, cfg):  # pragma: no cover - compiled
    """``(mu, B, S, J)`` of every landmark at the state ``x`` (a.12.4), with the model error's
    ``J = dg/dxi (N, 2, 3)`` from the same pass under :func:`_analytic_cov` (else ``(0, 2, 3)``)."""
    if _analytic_cov(cfg.pv):
        return view_xi_rows(x, shapes, np.arange(N), cfg.platform)
    mu, B, S = view_rows(x, shapes, np.arange(N), cfg.platform)
    return mu, B, S, np.empty((0, 2, 3))


@compiled_only
def view_sift(x, P, polar, N, prior, terms, noise, cfg):  # pragma: no cover - compiled
    """Step 3 under the partial view (a.7.1, a.12.5): with ``cfg.contour`` the measurement contour
    of every landmark about its predicted detection mean, with the arc's spread plus ``Q_v`` and
    the mean's covariance ``B P_pp B^T``; else within ``cfg.sift_radius`` of a centroid."""
    pos_prior, cov_prior = prior
    xy = _to_world(x, polar)
    m = polar.shape[0]
    if N == 0 or m == 0:
        return np.zeros(m, dtype=np.bool_)
    has = np.full(N, cfg.contour)
    inside = np.zeros((1, 1), dtype=np.bool_)
    if cfg.contour:
        mu, B, S, _ = terms
        spread, cov = sift_spreads(B, S, cov_prior, cfg.pv.Qv)
        inside = measurement_contour(xy, polar, x[2], P[:3, :3].copy(), noise.R_ext, mu, spread, cov, cfg.gate)
    return compiled_candidates(xy, pos_prior, cfg.sift_radius * cfg.sift_radius, inside, has)   # c.3's decision


@njit(cache=True, inline="always")
def sift_step(x, P, polar, lm, N, prior, noise, cfg, view):  # pragma: no cover - compiled
    """Step 3 (:func:`~radarslam.slam.fused.tracking.sift`, or :func:`view_sift` under the partial
    view, ``view``: ``cfg.pv.on``, the engine's compile-time flag, engine.Family). Returns ``(cand,
    shapes, terms)``: the shapes and ``(mu, B, S)`` of every landmark at the predicted state under
    the partial view (empty otherwise), which association reads too."""
    if view:
        shapes = view_shapes(lm, N, cfg)
        terms = view_terms(x, shapes, N, cfg)
        return view_sift(x, P, polar, N, prior, terms, noise, cfg), shapes, terms
    e2 = np.empty((0, 2, 2))
    return sift(x, P, polar, lm, N, prior, noise, cfg), e2, (np.empty((0, 2)), e2, e2, np.empty((0, 2, 3)))


@njit(cache=True, inline="always")
def associate_step(x, P, polar, cidx, lm, N, pose_first, shapes, terms, noise, cfg, view, jcbb):  # pragma: no cover - compiled
    """Step 4 (:func:`~radarslam.slam.fused.tracking.associate_and_update`, with ``jcbb``
    :func:`~radarslam.slam.fused.tracking.jcbb_and_update`, or :func:`view_associate` under the
    partial view, ``view``; both the engine's compile-time flags, engine.Family). Returns ``(x, P,
    landmark per candidate or -1, NIS values)``."""
    if view:
        return view_associate(x, P, polar, cidx, lm, N, shapes, terms, noise, cfg)
    if jcbb:
        return jcbb_and_update(x, P, polar, cidx, lm, N, noise, cfg)
    return associate_and_update(x, P, polar, cidx, lm, N, pose_first, noise, cfg)


class _Scores(NamedTuple):
    """Per landmark at one state: the polar terms (``Rj`` with the model error ``Q`` once ``have``),
    the innovation covariance ``Sn`` (once ``have``)."""

    h: np.ndarray          #: (N, 2)
    Hs: np.ndarray         #: (N, 2, 5)
    Rj: np.ndarray         #: (N, 2, 2)
    ok: np.ndarray         #: (N,) bool
    Q: np.ndarray          #: (N, 2, 2)
    Sn: np.ndarray         #: (N, 2, 2)
    have: np.ndarray       #: (N,) bool


@compiled_only
def _scores(x, terms, N, R, cfg):  # pragma: no cover - compiled
    """The polar terms of every landmark with the model error ``Q_v`` (``h``, ``Hs`` and ``ok``
    do not depend on it; :func:`_complete` adds the shape's part to ``Rj`` where it is needed)."""
    mu, B, S, _ = terms
    Q = np.empty((N, 2, 2))
    for j in range(N):
        Q[j] = cfg.pv.Qv
    h, Hs, Rj, ok = polar_rows(x, mu, B, S, R, Q)
    return _Scores(h, Hs, Rj, ok, Q, np.empty((N, 2, 2)), np.zeros(N, dtype=np.bool_))


@njit(cache=True, inline="always")
def _block_row(j, r, platform):  # pragma: no cover - compiled
    """The state row of entry ``r`` of landmark ``j``'s block ``(x, y, theta, p_j)``, the landmarks
    after a platform block of ``platform`` entries (the pose, then any bias states: slam/layout.py)."""
    return r if r < POSE_DIM else platform + 2 * j + r - POSE_DIM


@compiled_only
def _block_index(j, platform):  # pragma: no cover - compiled
    """The rows ``(x, y, theta, p_j)`` of landmark ``j`` in the state (:func:`_block_row`)."""
    idx = np.empty(5, dtype=np.int64)
    for r in range(5):
        idx[r] = _block_row(j, r, platform)
    return idx


@compiled_only
def _complete(x, P, xi, Pxi, js, terms, R, sc, pv, platform):  # pragma: no cover - compiled
    """The model error (with the shape's uncertainty ``Pxi`` of the shapes ``xi``, ``pv.with_cov``),
    ``Rj`` and ``Sn`` of the landmarks ``js`` not yet done, in ``sc`` (the model errors, polar terms and log distances of them by the kernels of
    slam/view_kernels.py). Called per detection: it takes the arrays it reads, not the landmark and configuration
    records, whose every array a call would count a reference to."""
    todo = np.empty(js.shape[0], dtype=np.int64)
    n = 0
    for a in range(js.shape[0]):
        j = js[a]
        if not sc.have[j]:
            sc.have[j] = True
            todo[n] = j
            n += 1
    if n == 0:
        return
    mu, B, S, J = terms
    Qcd = np.empty((0, 2, 2))                            # the central-difference model errors, when asked
    if pv.with_cov and not _analytic_cov(pv):
        Qcd = shape_error_rows(x, xi, Pxi, todo[:n], pv.Qv, pv.shape_step, platform)
    h1 = np.empty(2)                                     # polar_row's h and Hs: sc has them already
    Hs1 = np.empty((2, 5))
    Pb = np.empty((5, 5))
    for a in range(n):
        j = todo[a]
        if pv.with_cov:                                  # one row of model_error_rows and polar_rows
            if _analytic_cov(pv):
                shape_error_one(J[j], Pxi[j], pv.Qv, sc.Q[j])
            else:
                sc.Q[j] = Qcd[a]
            polar_row(x, mu[j, 0], mu[j, 1], B[j], S[j], sc.Q[j], R, h1, Hs1, sc.Rj[j])
        for r in range(5):                               # P on the block (_block_index), gathered
            for c in range(5):
                Pb[r, c] = P[_block_row(j, r, platform), _block_row(j, c, platform)]
        sc.Sn[j] = innovation_cov(sc.Hs[j], Pb, sc.Rj[j])


@compiled_only
def _nearest_best(x, P, xi, Pxi, z0, z1, d2, N, count, terms, R, sc, pv, platform):  # pragma: no cover - compiled
    """The landmark of smallest log distance among the ``count`` nearest by ``d2`` (ties by
    position, the first minimum; ``inf`` where ``d2`` or ``Sn`` rule it out): ``(j, D)``."""
    near = _smallest(d2, N, count)
    have, ok, h, Sn = sc.have, sc.ok, sc.h, sc.Sn     # once: each record access counts a reference
    for k in range(count):
        if not have[near[k]]:
            _complete(x, P, xi, Pxi, near, terms, R, sc, pv, platform)
            break
    best_j = near[0]
    best_D = math.inf
    for k in range(count):
        j = near[k]
        D = math.inf
        if d2[j] < math.inf and ok[j]:
            D = view_log_distance(z0, z1, h[j, 0], h[j, 1], Sn[j])
        if k == 0 or D < best_D:
            best_j, best_D = j, D
    return best_j, best_D


@compiled_only
def _view_nn(x, P, polar, cidx, lm, N, shapes, terms, R, cfg):  # pragma: no cover - compiled
    """``PartialViewNearestNeighbour``: each candidate against its ``cfg.n_near`` landmarks nearest
    by their predicted means, updated at once when below ``cfg.beta`` (the terms recomputed then)."""
    out = np.full(cidx.shape[0], -1, dtype=np.int64)
    nis = np.empty(cidx.shape[0])
    n_up = 0
    sc = _scores(x, terms, N, R, cfg)
    d2 = np.empty(N)
    count = min(cfg.n_near, N)
    for c in range(cidx.shape[0]):
        i = cidx[c]
        mu = terms[0]
        a = x[2] + polar[i, 1]
        zw0 = x[0] + polar[i, 0] * math.cos(a)
        zw1 = x[1] + polar[i, 0] * math.sin(a)
        for j in range(N):
            d2[j] = (mu[j, 0] - zw0) ** 2 + (mu[j, 1] - zw1) ** 2
        j, D = _nearest_best(x, P, lm.xi, lm.Pxi, polar[i, 0], polar[i, 1], d2.copy(), N, count, terms, R, sc,
                             cfg.pv, cfg.platform)
        if D < cfg.beta:
            e = np.array([polar[i, 0] - sc.h[j, 0], _wrap_pi(polar[i, 1] - sc.h[j, 1])])
            nis[n_up] = _joseph_update_inplace(x, P, e, sc.Hs[j].copy(), _block_index(j, cfg.platform), sc.Rj[j].copy())
            n_up += 1
            out[c] = j
            terms = view_terms(x, shapes, N, cfg)
            sc = _scores(x, terms, N, R, cfg)
    return x, P, out, nis[:n_up]


@compiled_only
def _view_scores(x, P, polar, cidx, lm, N, terms, R, sc, cfg):  # pragma: no cover - compiled
    """``PartialViewBatch.scores``: the landmark of each candidate (-1 for none), all scored at
    the state ``x``, ``P`` against their ``cfg.n_near`` landmarks nearest by the predicted means
    (landmarks whose mean sits on the sensor excluded)."""
    out = np.full(cidx.shape[0], -1, dtype=np.int64)
    mu = terms[0]
    ok, xi, Pxi, pv = sc.ok, lm.xi, lm.Pxi, cfg.pv
    d2 = np.empty(N)
    count = min(cfg.n_near, N)
    for c in range(cidx.shape[0]):
        i = cidx[c]
        th = x[2] + polar[i, 1]
        zw0 = x[0] + polar[i, 0] * math.cos(th)
        zw1 = x[1] + polar[i, 0] * math.sin(th)
        for j in range(N):
            d2[j] = (zw0 - mu[j, 0]) ** 2 + (zw1 - mu[j, 1]) ** 2 if ok[j] else math.inf
        j, D = _nearest_best(x, P, xi, Pxi, polar[i, 0], polar[i, 1], d2, N, count, terms, R, sc, pv, cfg.platform)
        if D < cfg.beta:
            out[c] = j
    return out


@compiled_only
def _batch_rows(x, polar, rows, R, mu, B, S, Q):  # pragma: no cover - compiled
    """One landmark's batch measurement (``_batch_measurements``, a.12.5) from its ``mu``, ``B``,
    ``S`` ``(1, ...)`` and model error ``Q (2, 2)`` at ``x``: ``(e (2,), Hs (2, 5), noise (2, 2))``."""
    h, Hs = sensor_xy_rows(x, mu, B)
    pts, R_xy = _polar_to_sensor_xy(polar[rows], R)
    e = np.empty(2)
    e[0] = pts[:, 0].mean() - h[0, 0]
    e[1] = pts[:, 1].mean() - h[0, 1]
    return e, Hs[0], view_batch_noise(x[2], S[0], Q, R_xy, rows.shape[0])


@compiled_only
def _one_landmark(x, shapes, lm, j, cfg):  # pragma: no cover - compiled
    """Landmark ``j``'s ``mu``, ``B``, ``S`` ``(1, ...)`` and model error ``(2, 2)`` at ``x``
    (``view_model_terms`` of one landmark)."""
    js = np.array([j])
    if _analytic_cov(cfg.pv):
        mu, B, S, J = view_xi_rows(x, shapes, js, cfg.platform)
        return mu, B, S, model_error_rows(J, lm.Pxi, js, cfg.pv.Qv)[0]
    mu, B, S = view_rows(x, shapes, js, cfg.platform)
    if cfg.pv.with_cov:
        return mu, B, S, shape_error_rows(x, lm.xi, lm.Pxi, js, cfg.pv.Qv, cfg.pv.shape_step, cfg.platform)[0]
    return mu, B, S, cfg.pv.Qv.copy()


@compiled_only
def view_associate(x, P, polar, cidx, lm, N, shapes, terms, noise, cfg):  # pragma: no cover - compiled
    """Step 4 under the partial view (a.12.5) with the nearest-neighbour (``cfg.assoc`` 0), batch
    (1) or batch-joint (2) associator of ``slam.partial_view``: the batch forms score every candidate
    at the predicted state, then update each landmark in turn, relinearised (batch), or all at once
    (batch-joint, whose measurements are the scoring state's). Returns ``(x, P, out, nis)``."""
    R = noise.R_assoc
    if N == 0 or cidx.shape[0] == 0:
        return x, P, np.full(cidx.shape[0], -1, dtype=np.int64), np.empty(0)
    if cfg.assoc == 0:
        return _view_nn(x, P, polar, cidx, lm, N, shapes, terms, R, cfg)
    sc = _scores(x, terms, N, R, cfg)
    out = _view_scores(x, P, polar, cidx, lm, N, terms, R, sc, cfg)
    js = compiled_seen_landmarks(out, N)
    L = js.shape[0]
    if L == 0:
        return x, P, out, np.empty(0)
    if cfg.assoc == 1:
        nis = np.empty(L)
        for a in range(L):
            j = js[a]
            mu, B, S, Q = _one_landmark(x, shapes, lm, j, cfg)
            e, Hs, Rb = _batch_rows(x, polar, cidx[out == j], R, mu, B, S, Q)
            nis[a] = _joseph_update_inplace(x, P, e, Hs, _block_index(j, cfg.platform), Rb)
        return x, P, out, nis
    mu_all, B_all, S_all, _ = terms
    e, Hs_all, idx_all, Rb = stacked_rows(L)
    for a in range(L):
        j = js[a]
        ea, Hs_all[a], Rb[a] = _batch_rows(x, polar, cidx[out == j], R, mu_all[j:j + 1], B_all[j:j + 1],
                                           S_all[j:j + 1], sc.Q[j].copy())
        e[2 * a], e[2 * a + 1] = ea[0], ea[1]
        idx_all[a] = _block_index(j, cfg.platform)
    return x, P, out, joint_update_loops(x, P, e, Hs_all, idx_all, Rb)


@compiled_only
def view_newborn(x, lm, n, cfg):  # pragma: no cover - compiled
    """Landmark ``n``, just added as the last of ``x``: the prior shape, no view yet and, with
    ``cfg.pv.init_correct``, its centroid moved so that the prior shape's arc mean seen from the
    sensor is where it was put (a.12.6)."""
    v = cfg.pv
    lm.xi[n] = v.xi0
    lm.Pxi[n] = v.P0
    lm.nview[n] = 0
    lm.vangle[n] = np.nan
    if v.on and v.init_correct:
        x[-2], x[-1] = corrected_centroid(x[-2], x[-1], x[0], x[1], v.X0, CORRECTION_ITERATIONS)
