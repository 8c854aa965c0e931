"""The fused engine's steps that track the landmarks it has (docs/method.md a.8 steps 1-5): predict
(c.2), sift (c.3, a.7.1), associate and update (c.4, a.7.2-a.7.3), the M/N windows and removal
(c.5); step 6, the extent step, is in :mod:`.extent`. One compiled function per step, each the
bookkeeping between the compiled kernels the numba backend uses; ``cfg`` is the engine's
:class:`~radarslam.slam.fused.plan.FusedParams`.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.angles import wrap_2pi_scalar
from radarslam.core.jit import compile_kernels, compiled_only
from radarslam.extent._compiled import abt_plus_cdt, literal_inside, measurement_contour, small_matmul
from radarslam.extent._compiled import buffered_scatter as _buffered_scatter
from radarslam.landmarks._compiled import compiled_by_landmark, compiled_candidates, compiled_in_view as _in_view
from radarslam.landmarks._compiled import compiled_mn_windows as _mn_windows
from radarslam.models.ackermann import ackermann_jacobians, ackermann_step, centre_speed
from radarslam.models.body_velocity import body_velocity_increment, body_velocity_jacobians, body_velocity_step
from radarslam.models.motion import unicycle_jacobians, unicycle_step
from radarslam.models.radar import polar_to_xy
from radarslam.slam import ekf
from radarslam.slam.bias import turn_noise as _turn_noise_kernel
from radarslam.slam._jcbb_numba import jcbb_associate_scan
from radarslam.slam._numba import (
    associate_scan,
    batch_associate_scan,
    joint_batch_associate_scan,
)
from radarslam.slam.state_loops import pose_cross_rows, write_platform_rows
from radarslam.slam.layout import POSE_DIM
from radarslam.slam.fused.storage import _drop_state_rows, _grow_rows, _grown_maps, compact_landmarks, write_map_row

# The reference's own kernels, compiled as they are: seed eq. (3), and the motion models' steps and
# Jacobians (models.motion, models.ackermann, models.body_velocity).
_to_world = compile_kernels(polar_to_xy)["polar_to_xy"]
_ACK = compile_kernels(centre_speed, wrap_2pi_scalar, ackermann_step, ackermann_jacobians)
_ackermann_step = _ACK["ackermann_step"]
_ackermann_jacobians = _ACK["ackermann_jacobians"]
_UNI = compile_kernels(wrap_2pi_scalar, unicycle_step, unicycle_jacobians)
_unicycle_step = _UNI["unicycle_step"]
_unicycle_jacobians = _UNI["unicycle_jacobians"]
_BV = compile_kernels(wrap_2pi_scalar, body_velocity_increment, body_velocity_step, body_velocity_jacobians)
_body_velocity_step = _BV["body_velocity_step"]
_body_velocity_jacobians = _BV["body_velocity_jacobians"]
_fej_motion_jacobian = compile_kernels(ekf.fej_motion_jacobian)["fej_motion_jacobian"]
#: The heteroscedastic control noise of one sample (c.11.8), compiled as it is.
turn_noise = compile_kernels(_turn_noise_kernel)["turn_noise"]

#: Motion-model codes of ``FusedParams.motion`` (BODY_VELOCITY: the Doppler odometry's predictions, c.10.5).
UNICYCLE, ACKERMANN, BODY_VELOCITY = 0, 1, 2


@njit(cache=True, inline="always")
def _matmul(A, B):  # pragma: no cover - compiled
    """``A @ B`` for small matrices, each entry summed over k in order (core.small_matrices.matmul_into)."""
    return small_matmul(A, B, np.empty((A.shape[0], B.shape[1])))


@njit(cache=True, inline="always")
def _motion(x, u, dt, model, cfg):  # pragma: no cover - compiled
    """The motion model's step and Jacobians at ``x[:3]`` with control ``u``: ``(pose (3,), F_x,
    F_u)``. ``model`` UNICYCLE: APSIPA eq. 5, App. A (models.motion.UnicycleModel); ACKERMANN: the
    kernels of models.ackermann with ``cfg.wheelbase``, ``cfg.encoder_offset``, ``cfg.lever`` and
    ``cfg.sensor_b``; BODY_VELOCITY: models.body_velocity, ``u = [v_x, v_y, omega]`` (c.10.5)."""
    if model == ACKERMANN:
        pose = _ackermann_step(x[0], x[1], x[2], u[0], u[1], dt, cfg.wheelbase, cfg.encoder_offset, cfg.lever,
                               cfg.sensor_b)
        Fx, Fu = _ackermann_jacobians(x[2], u[0], u[1], dt, cfg.wheelbase, cfg.encoder_offset, cfg.lever,
                                      cfg.sensor_b)
        return pose, Fx, Fu
    if model == BODY_VELOCITY:
        pose = _body_velocity_step(x[0], x[1], x[2], u[0], u[1], u[2], dt)
        Fx, Fu = _body_velocity_jacobians(x[2], u[0], u[1], u[2], dt)
        return pose, Fx, Fu
    pose = _unicycle_step(x[0], x[1], x[2], u[0], u[1], dt)
    Fx, Fu = _unicycle_jacobians(x[2], u[0], u[1], dt)
    return pose, Fx, Fu


@njit(cache=True, inline="always")
def predict(x, P, u, dt, U, Q, pose_first, model, cfg):  # pragma: no cover - compiled
    """c.2 with the motion model ``model`` (:func:`_motion`), in place; with ``cfg.fej``
    the pose Jacobian's heading column from ``pose_first``, the first estimate of the current pose
    (the previous prediction), which then becomes the new prediction (c.2.1). Returns False,
    leaving the state as it was, if the prediction is not finite."""
    pose, Fx, Fu = _motion(x, u, dt, model, cfg)
    if cfg.fej:
        Fx = _fej_motion_jacobian(Fx, pose, pose_first)
    pose0, pose1, pose2 = pose[0], pose[1], pose[2]
    T = _matmul(Fx, P[:3, :3])
    FU = _matmul(Fu, U)
    Ppp = abt_plus_cdt(T, Fx, FU, Fu, np.empty((3, 3)))
    ok = math.isfinite(pose0) and math.isfinite(pose1) and math.isfinite(pose2)
    for i in range(3):
        for j in range(3):
            Ppp[i, j] += Q[i, j]
            ok = ok and math.isfinite(Ppp[i, j])
    Ppl, ok_pl = pose_cross_rows(Fx, P)
    if not (ok and ok_pl):
        return False
    x[0], x[1], x[2] = pose0, pose1, pose2
    if cfg.fej:
        pose_first[0], pose_first[1], pose_first[2] = pose0, pose1, pose2
    write_platform_rows(P, Ppp, Ppl)
    return True


@compiled_only
def sift(x, P, polar, lm, N, prior, noise, cfg):  # pragma: no cover - compiled
    """Step 3: the detections that are candidates for association (c.3; a.7.1), at the predicted
    state whose centroids and covariance blocks ``prior`` holds: inside an initialised landmark's
    measurement contour (``cfg.contour``; the literal ``kappa`` ellipse with ``cfg.literal``), else
    within ``cfg.sift_radius`` of a centroid."""
    pos_prior, cov_prior = prior
    m = polar.shape[0]
    xy = _to_world(x, polar)
    if N == 0 or m == 0:
        return np.zeros(m, dtype=np.bool_)
    has = np.zeros(N, dtype=np.bool_)
    if cfg.contour:
        has[:] = lm.einit[:N]
    inside = np.zeros((1, 1), dtype=np.bool_)
    if has.any() and cfg.literal:
        inside = literal_inside(xy, pos_prior, lm.X[:N], has, cfg.kappa * cfg.kappa)
    elif has.any():
        spreads = np.empty((N, 2, 2))
        for j in range(N):
            spreads[j] = cfg.gamma * (lm.X[j] if lm.einit[j] else np.eye(2))
        inside = measurement_contour(xy, polar, x[2], P[:3, :3].copy(), noise.R_ext, pos_prior, spreads,
                                     cov_prior, cfg.gate)
    return compiled_candidates(xy, pos_prior, cfg.sift_radius * cfg.sift_radius, inside, has)


@njit(cache=True, inline="always")
def _linearisation(x, lm, N, pose_first, platform):  # pragma: no cover - compiled
    """The first estimates (c.2.1) as the compiled associators take them (``xlin``,
    SlamState.linearisation_all): ``x`` with the pose ``pose_first`` (the prediction) and every
    landmark at its centroid at birth (the bias states of c.11, which no measurement reads, as they are)."""
    xlin = x.copy()
    xlin[:POSE_DIM] = pose_first
    for j in range(N):
        xlin[platform + 2 * j], xlin[platform + 2 * j + 1] = lm.first[j, 0], lm.first[j, 1]
    return xlin


@njit(cache=True, inline="always")
def _inflation(lm, N, noise, cfg):  # pragma: no cover - compiled
    """Step 4's noise inflation: ``(gX, has)``, the spread of initialised extents (``cfg.inflate``)
    and, before, by ``cfg.pre_spread`` (``extent.pre_init_spread``, a.7.2; 0 none) the prior spread
    (1) or, once 3 are held, the scatter of the buffered detections (2)."""
    gX = np.zeros((N, 2, 2))
    has = np.zeros(N, dtype=np.bool_)
    if cfg.inflate:
        for j in range(N):
            if lm.einit[j]:
                gX[j] = cfg.gamma * lm.X[j]
                has[j] = True
            elif cfg.pre_spread:
                gX[j] = _buffered_scatter(lm.buf[j], lm.nbuf[j]) if cfg.pre_spread == 2 and lm.nbuf[j] >= 3 \
                    else noise.prior_spread
                has[j] = True
    return gX, has


@compiled_only
def associate_and_update(x, P, polar, cidx, lm, N, pose_first, noise, cfg):  # pragma: no cover - compiled
    """Step 4: associate the candidates ``cidx`` and update (c.4, a.7.2-a.7.3) with the
    nearest-neighbour (``cfg.assoc`` 0), batch (1) or batch-joint (2) associator (JCBB:
    :func:`jcbb_and_update`), the noise inflated (:func:`_inflation`); with ``cfg.fej`` the
    Jacobians at the first estimates (c.2.1). Returns ``(x, P, landmark per candidate or -1, NIS
    values)``."""
    if N == 0:
        return x, P, np.full(cidx.shape[0], -1, dtype=np.int64), np.empty(0)
    gX, has = _inflation(lm, N, noise, cfg)
    R = noise.R_assoc                                   # c.11.9: n_c R (R for independent errors)
    xlin = _linearisation(x, lm, N, pose_first, cfg.platform) if cfg.fej else np.empty(0)
    if cfg.assoc == 0:
        return associate_scan(x, P, polar, cidx, R, gX, has, cfg.n_near, cfg.beta, cfg.platform, xlin)
    if cfg.assoc == 1:
        return batch_associate_scan(x, P, polar, cidx, R, gX, has, cfg.n_near, cfg.beta, cfg.platform, xlin,
                                    cfg.offset_k)
    return joint_batch_associate_scan(x, P, polar, cidx, R, gX, has, cfg.n_near, cfg.beta, cfg.platform, xlin,
                                      cfg.offset_k)


@compiled_only
def jcbb_and_update(x, P, polar, cidx, lm, N, noise, cfg):  # pragma: no cover - compiled
    """Step 4 with the JCBB associator (``cfg.assoc`` 3, c.4.1), as :func:`associate_and_update`."""
    if N == 0:
        return x, P, np.full(cidx.shape[0], -1, dtype=np.int64), np.empty(0)
    gX, has = _inflation(lm, N, noise, cfg)
    x, P, out, nis, _ = jcbb_associate_scan(x, P, polar, cidx, noise.R_assoc, gX, has, cfg.platform, cfg.jcbb_eps,
                                            cfg.jcbb_min_samples, cfg.jcbb_prefilter, noise.gates, cfg.jcbb_max_nodes)
    return x, P, out, nis


@compiled_only
def group_associations(out, cidx, N, ids, s, a_rows, n_arows):  # pragma: no cover - compiled
    """The associations of step 4 by landmark, ``assoc[j] = arow[aoff[j]:aoff[j + 1]]``, by the
    kernel landmarks.grouping.by_landmark compiled as it is, and the ``(scan,
    detection, landmark id)`` rows appended to ``a_rows``. Returns
    ``(n_assoc, aoff, arow, a_rows, n_arows)``."""
    aoff, arow = compiled_by_landmark(out, cidx, N)
    for c in range(out.shape[0]):
        if out[c] >= 0:
            a_rows = _grow_rows(a_rows, n_arows + 1)
            a_rows[n_arows, 0] = s
            a_rows[n_arows, 1] = cidx[c]
            a_rows[n_arows, 2] = ids[out[c]]
            n_arows += 1
    n_assoc = arow.shape[0]
    return n_assoc, aoff, arow, a_rows, n_arows


@compiled_only
def remove_unseen(x, P, lm, N, aoff, k, young, sensor_view, retired, n_retired, arcs, cfg):  # pragma: no cover
    """Step 5: age the M/N windows of scan ``k`` and remove the landmarks seen in too few of the
    last ``cfg.removal_window`` scans they were in view (c.5), by the kernel
    landmarks.confirmation.mn_windows compiled as it is, and those ``young`` marks (the Doppler
    gate's, c.10.4.4), in view of the scan's radar (``sensor_view``: its range and half field of
    view, c.13); then retire the survivors farther than ``sqrt(cfg.retire2)`` from the scan's
    radar (c.15, ``cfg.retire2`` 0: never), each written to ``retired`` (a
    :class:`~radarslam.slam.fused.storage.MapRows`, grown if needed) as it leaves the state.
    Returns ``(x, P, N, old, retired, n_retired)``: ``old`` each survivor's position before."""
    view = _in_view(x, cfg.platform, N, sensor_view[0], sensor_view[1])
    hit = np.empty(N, dtype=np.bool_)
    for j in range(N):
        hit[j] = aoff[j + 1] > aoff[j]
    keep = _mn_windows(lm.mbits[:N], lm.rbits[:N], lm.created[:N], hit, view, k, cfg.removal_window,
                       cfg.removal_max)
    n_keep = 0
    for j in range(N):
        if young[j]:
            keep[j] = False
        if keep[j] and cfg.retire2 > 0.0:
            i = cfg.platform + 2 * j
            if (x[i] - x[0]) ** 2 + (x[i + 1] - x[1]) ** 2 > cfg.retire2:
                keep[j] = False
                retired = _grown_maps(retired, n_retired + 1)
                write_map_row(retired, n_retired, j, x, P, lm, arcs, cfg)
                n_retired += 1
        if keep[j]:
            n_keep += 1
    if n_keep < N:
        x, P = _drop_state_rows(x, P, keep)
    old = compact_landmarks(lm, keep)
    return x, P, n_keep, old, retired, n_retired
