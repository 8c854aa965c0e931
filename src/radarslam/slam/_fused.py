"""The fused engine: a whole event stream through EKF-SLAM in one compiled call (``filter.fused``).

:class:`~radarslam.slam.filter.EkfSlam` runs docs/method.md a.8 as a dozen Python calls per scan,
each cheap, together ~0.4 ms a scan: the orchestration, not the arithmetic, is the cost of a
car-park trial. For the built-in components (unicycle motion, range-azimuth radar, the
nearest-neighbour, batch or batch-joint associator, the RMA/EFA estimator, DBSCAN) this module runs the same
steps over the whole stream inside numba, with the landmark records held in arrays (ids, creation
scans, M/N windows, extent states and their buffers) instead of Python objects, and records what
:func:`radarslam.experiments.single.run_filter` records after every scan.

It has no maths of its own. Every step calls the compiled kernels the numba backend uses
(:mod:`radarslam.slam._numba` for association and the Joseph update, :mod:`radarslam.extent._compiled`
for the contour test, the RM step and the EFA, :mod:`radarslam.landmarks._compiled` for DBSCAN);
what is written here is the bookkeeping between them, in the orchestrator's order: predict (c.2);
sift (c.3, a.7.1); associate and update (c.4, a.7.2-a.7.3); M/N windows and removal (c.5); extent
step (a.3-a.5); cluster (c.6); alpha test; Rule 1 / Rule 2 and augmentation (c.7-c.8); merge
(c.9). The orchestrator remains the reference and the place for other components:
:func:`plan` says which configurations this engine covers and why not, and
``tests/test_fused.py`` checks that both give the same associations, landmark ids and states (to
rounding) on whole runs.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, objmode

from radarslam.core.jit import compile_kernels
from radarslam.extent._compiled import _fit_entries, measurement_contour, rma_efa_step
from radarslam.landmarks._compiled import dbscan_centres, dbscan_labels
from radarslam.models.radar import inverse_jacobians, polar_to_xy
from radarslam.slam import ekf
from radarslam.slam._numba import (
    _polar_to_sensor_xy,
    _wrap_2pi,
    _wrap_pi,
    associate_scan,
    batch_associate_scan,
    joint_batch_associate_scan,
    min_log_distance,
)

# The reference's own kernels, compiled as they are: seed eq. (3) and the augmentation (c.8).
_K = compile_kernels(polar_to_xy, inverse_jacobians, ekf.augment, ekf.augment_point)
_to_world = _K["polar_to_xy"]
_augment = _K["augment"]
_augment_point = _K["augment_point"]

# Integer parameters (``ip``), by position.
I_ASSOC, I_N_NEAR, I_N_NEW, I_MIN_SAMPLES, I_CONFIRM_PTS, I_CONFIRM_WIN, I_CONFIRM_HITS = 0, 1, 2, 3, 4, 5, 6
I_REMOVAL_WIN, I_REMOVAL_MAX, I_MERGE_MAX, I_INIT_CLUSTER, I_TRACK, I_CONTOUR, I_INFLATE = 7, 8, 9, 10, 11, 12, 13
I_PRE_PRIOR, I_N_INIT, I_POSTERIOR, I_UPPER, I_SPREAD_AT_BIRTH, I_LITERAL, I_TIMING = 14, 15, 16, 17, 18, 19, 20
N_IP = 21
# Float parameters (``fp``), by position.
F_BETA, F_ALPHA, F_SIFT_R, F_EPS, F_TENT_GATE, F_MERGE_D, F_MERGE_AXIS, F_MAX_RANGE = 0, 1, 2, 3, 4, 5, 6, 7
F_HALF_FOV, F_GATE, F_GAMMA, F_ALPHA0, F_TAU, F_EIG_FLOOR, F_KAPPA = 8, 9, 10, 11, 12, 13, 14
N_FP = 15

#: Status codes of :func:`run_stream`: what made the state non-finite, at which event.
OK, BAD_PREDICTION, BAD_SCAN = 0, 1, 2


# ---------------------------------------------------------------------------------------- storage
@njit(cache=True)
def _grow_rows(a, n):  # pragma: no cover - compiled
    """``a`` with room for at least ``n`` rows along its first axis (doubling), contents kept."""
    if a.shape[0] >= n:
        return a
    cap = max(n, 2 * a.shape[0])
    shape = (cap,) + a.shape[1:]
    b = np.empty(shape, dtype=a.dtype)
    b[:a.shape[0]] = a
    return b


@njit(cache=True)
def _grow_buffer(buf, n):  # pragma: no cover - compiled
    """The detection buffers ``(L, B, 2)`` with room for ``n`` points per landmark."""
    if buf.shape[1] >= n:
        return buf
    b = np.empty((buf.shape[0], max(n, 2 * buf.shape[1]), 2))
    b[:, :buf.shape[1]] = buf
    return b


@njit(cache=True)
def _drop_state_rows(x, P, keep):  # pragma: no cover - compiled
    """``x`` and ``P`` without the landmarks whose ``keep`` is False (ekf.remove_landmarks)."""
    N = keep.shape[0]
    rows = np.empty(3 + 2 * N, dtype=np.int64)
    n = 0
    for i in range(3):
        rows[n] = i
        n += 1
    for j in range(N):
        if keep[j]:
            rows[n] = 3 + 2 * j
            rows[n + 1] = 4 + 2 * j
            n += 2
    x_new = np.empty(n)
    P_new = np.empty((n, n))
    for a in range(n):
        x_new[a] = x[rows[a]]
        for b in range(n):
            P_new[a, b] = P[rows[a], rows[b]]
    return x_new, P_new


# ---------------------------------------------------------------------------------------- EKF steps
@njit(cache=True)
def _matmul(A, B):  # pragma: no cover - compiled
    """``A @ B`` for small matrices, each entry summed over k in order."""
    C = np.zeros((A.shape[0], B.shape[1]))
    for i in range(A.shape[0]):
        for j in range(B.shape[1]):
            acc = 0.0
            for k in range(A.shape[1]):
                acc += A[i, k] * B[k, j]
            C[i, j] = acc
    return C


@njit(cache=True)
def _predict(x, P, v, psi, dt, U, Q):  # pragma: no cover - compiled
    """c.2 with the unicycle model (APSIPA eq. 5, App. A; models.motion.UnicycleModel), in place.
    Returns False, leaving the state as it was, if the prediction is not finite."""
    th = x[2]
    a = th + 0.5 * dt * psi
    A, B = math.sin(a), math.cos(a)
    Fx = np.array([[1.0, 0.0, -dt * v * A], [0.0, 1.0, dt * v * B], [0.0, 0.0, 1.0]])
    Fu = np.array([[dt * B, -0.5 * dt * dt * v * A], [dt * A, 0.5 * dt * dt * v * B], [0.0, dt]])
    pose0 = x[0] + v * dt * math.cos(a)
    pose1 = x[1] + v * dt * math.sin(a)
    pose2 = _wrap_2pi(th + psi * dt)
    T = _matmul(Fx, P[:3, :3])
    FU = _matmul(Fu, U)
    Ppp = np.empty((3, 3))
    ok = math.isfinite(pose0) and math.isfinite(pose1) and math.isfinite(pose2)
    for i in range(3):
        for j in range(3):
            s1 = 0.0
            for k in range(3):
                s1 += T[i, k] * Fx[j, k]
            s2 = 0.0
            for k in range(2):
                s2 += FU[i, k] * Fu[j, k]
            Ppp[i, j] = s1 + s2 + Q[i, j]
            ok = ok and math.isfinite(Ppp[i, j])
    n = x.shape[0]
    Ppl = np.empty((3, n - 3))
    for i in range(3):
        for j in range(3, n):
            s = 0.0
            for k in range(3):
                s += Fx[i, k] * P[k, j]
            Ppl[i, j - 3] = s
            ok = ok and math.isfinite(s)
    if not ok:
        return False
    x[0], x[1], x[2] = pose0, pose1, pose2
    for i in range(3):
        for j in range(3):
            P[i, j] = Ppp[i, j]
        for j in range(3, n):
            P[i, j] = Ppl[i, j - 3]
            P[j, i] = Ppl[i, j - 3]
    return True


@njit(cache=True)
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


@njit(cache=True)
def _blocks(x, P):  # pragma: no cover - compiled
    """Landmark centroids ``(N, 2)`` and their 2 x 2 covariance blocks ``(N, 2, 2)``."""
    N = (x.shape[0] - 3) // 2
    pos = np.empty((N, 2))
    cov = np.empty((N, 2, 2))
    for j in range(N):
        i = 3 + 2 * j
        pos[j, 0] = x[i]
        pos[j, 1] = x[i + 1]
        cov[j, 0, 0] = P[i, i]
        cov[j, 0, 1] = P[i, i + 1]
        cov[j, 1, 0] = P[i, i + 1]
        cov[j, 1, 1] = P[i + 1, i + 1]
    return pos, cov


@njit(cache=True)
def _popcount(v):  # pragma: no cover - compiled
    c = 0
    while v:
        c += v & 1
        v >>= 1
    return c


@njit(cache=True)
def _all_finite(x, P):  # pragma: no cover - compiled
    for i in range(x.shape[0]):
        if not math.isfinite(x[i]):
            return False
    for i in range(P.shape[0]):
        for j in range(P.shape[1]):
            if not math.isfinite(P[i, j]):
                return False
    return True


# ---------------------------------------------------------------------------------------- the stream
@njit(cache=True)
def run_stream(kinds, odo, odo_dt, scan_off, polar_all, scan_k, x0, P0, R, R_ext, U, Q, prior_spread, ip, fp):  # pragma: no cover - compiled
    """Run the event stream ``kinds`` (0 odometry, 1 scan, in order) through the filter.

    Odometry ``e`` is ``odo[e] = [v, psi]`` over ``odo_dt[e]``; scan ``s`` has the detections
    ``polar_all[scan_off[s]:scan_off[s + 1]]`` and the index ``scan_k[s]``. ``ip`` and ``fp`` are the
    parameters by the ``I_*`` and ``F_*`` positions. Returns a tuple: status ``(code, event)``;
    per scan the pose ``(S, 3)``, its covariance ``(S, 3, 3)``, detections, associated detections,
    landmarks, NIS sum and count; the maps after every scan as rows ``map_off[s]:map_off[s + 1]``
    of ids, centroids, covariances, RMA and EFA extents (NaN where not initialised) and creation
    scans; the per-scan associations as ``(scan, detection, landmark id)`` rows; and, with
    ``ip[I_TIMING]``, the wall time of each scan with the predictions before it (else zeros).
    """
    S = scan_off.shape[0] - 1
    x = x0.copy()
    P = P0.copy()
    R_plain = R
    gamma = fp[F_GAMMA]
    # landmark records in state order
    L0 = 16
    ids = np.empty(L0, dtype=np.int64)
    created = np.empty(L0, dtype=np.int64)
    mbits = np.empty(L0, dtype=np.int64)
    rbits = np.empty(L0, dtype=np.int64)
    einit = np.zeros(L0, dtype=np.bool_)
    X = np.zeros((L0, 2, 2))
    alpha = np.zeros(L0)
    Xefa = np.zeros((L0, 2, 2))
    nbuf = np.zeros(L0, dtype=np.int64)
    m_max = 1
    for s in range(S):
        m_max = max(m_max, scan_off[s + 1] - scan_off[s])
    buf = np.zeros((L0, ip[I_N_INIT] + m_max + 1, 2))
    N = 0
    next_id = 0
    # tentatives (Rule 2)
    tc = np.empty((16, 2))
    tcount = np.empty(16, dtype=np.int64)
    twin = np.empty(16, dtype=np.int64)
    tnpts = np.empty(16, dtype=np.int64)
    T = 0
    # outputs
    poses = np.empty((S, 3))
    pcovs = np.empty((S, 3, 3))
    n_det = np.zeros(S, dtype=np.int64)
    n_ass = np.zeros(S, dtype=np.int64)
    n_lm = np.zeros(S, dtype=np.int64)
    nis_sum = np.zeros(S)
    nis_cnt = np.zeros(S, dtype=np.int64)
    map_off = np.zeros(S + 1, dtype=np.int64)
    cap = 64
    m_ids = np.empty(cap, dtype=np.int64)
    m_pos = np.empty((cap, 2))
    m_cov = np.empty((cap, 2, 2))
    m_rma = np.empty((cap, 2, 2))
    m_efa = np.empty((cap, 2, 2))
    m_created = np.empty(cap, dtype=np.int64)
    a_rows = np.empty((64, 3), dtype=np.int64)
    n_arows = 0
    status = np.zeros(2, dtype=np.int64)
    seconds = np.zeros(S)                 # per scan, with ip[I_TIMING]: wall time since the previous scan's end
    t_last = 0.0
    if ip[I_TIMING] == 1:
        with objmode(t0="float64"):
            t0 = time.perf_counter()
        t_last = t0

    dt_since = 0.0
    e_odo = 0
    s = 0
    for ev in range(kinds.shape[0]):
        if kinds[ev] == 0:
            if not _predict(x, P, odo[e_odo, 0], odo[e_odo, 1], odo_dt[e_odo], U, Q):
                status[0], status[1] = BAD_PREDICTION, ev
                break
            dt_since += odo_dt[e_odo]
            e_odo += 1
            continue
        # ------------------------------------------------------------ one scan (a.8 steps 2-10)
        polar = polar_all[scan_off[s]:scan_off[s + 1]]
        m = polar.shape[0]
        k = scan_k[s]
        dt = dt_since if s > 0 else 0.0
        dt_since = 0.0
        # prior (Decision 3)
        pos_prior, cov_prior = _blocks(x, P)
        # 3: sifting at the predicted state
        xy = _to_world(x, polar)
        cand = np.zeros(m, dtype=np.bool_)
        if N > 0 and m > 0:
            use_contour = False
            if ip[I_CONTOUR] == 1:
                for j in range(N):
                    if einit[j]:
                        use_contour = True
            inside = np.zeros((m, N), dtype=np.bool_)
            if use_contour and ip[I_LITERAL] == 1:
                kk = fp[F_KAPPA] * fp[F_KAPPA]
                for j in range(N):
                    if not einit[j]:
                        continue
                    det = X[j, 0, 0] * X[j, 1, 1] - X[j, 0, 1] * X[j, 1, 0]
                    i00, i01, i10, i11 = X[j, 1, 1] / det, -X[j, 0, 1] / det, -X[j, 1, 0] / det, X[j, 0, 0] / det
                    for i in range(m):
                        d0 = xy[i, 0] - pos_prior[j, 0]
                        d1 = xy[i, 1] - pos_prior[j, 1]
                        inside[i, j] = d0 * (i00 * d0 + i01 * d1) + d1 * (i10 * d0 + i11 * d1) <= kk
            elif use_contour:
                spreads = np.empty((N, 2, 2))
                for j in range(N):
                    if einit[j]:
                        spreads[j] = gamma * X[j]
                    else:
                        spreads[j] = gamma * np.eye(2)
                inside = measurement_contour(xy, polar, x[2], P[:3, :3].copy(), R_ext, pos_prior, spreads,
                                             cov_prior, fp[F_GATE])
            r2 = fp[F_SIFT_R] * fp[F_SIFT_R]
            for i in range(m):
                for j in range(N):
                    if use_contour and einit[j]:
                        hit = inside[i, j]
                    else:
                        d0 = xy[i, 0] - pos_prior[j, 0]
                        d1 = xy[i, 1] - pos_prior[j, 1]
                        hit = d0 * d0 + d1 * d1 < r2
                    if hit:
                        cand[i] = True
                        break
        cidx = np.flatnonzero(cand)
        # 4: association and updates
        out = np.full(cidx.shape[0], -1, dtype=np.int64)
        nis = np.empty(0)
        if N > 0:
            gX = np.zeros((N, 2, 2))
            has = np.zeros(N, dtype=np.bool_)
            if ip[I_INFLATE] == 1:
                for j in range(N):
                    if einit[j]:
                        gX[j] = gamma * X[j]
                        has[j] = True
                    elif ip[I_PRE_PRIOR] == 1:
                        gX[j] = prior_spread
                        has[j] = True
            if ip[I_ASSOC] == 0:
                x, P, out, nis = associate_scan(x, P, polar, cidx, R, gX, has, ip[I_N_NEAR], fp[F_BETA])
            elif ip[I_ASSOC] == 1:
                x, P, out, nis = batch_associate_scan(x, P, polar, cidx, R, gX, has, ip[I_N_NEAR], fp[F_BETA])
            else:
                x, P, out, nis = joint_batch_associate_scan(x, P, polar, cidx, R, gX, has, ip[I_N_NEAR],
                                                            fp[F_BETA])
        n_assoc = 0
        cnt = np.zeros(N + 1, dtype=np.int64)
        for c in range(out.shape[0]):
            if out[c] >= 0:
                n_assoc += 1
                cnt[out[c] + 1] += 1
                a_rows = _grow_rows(a_rows, n_arows + 1)
                a_rows[n_arows, 0] = s
                a_rows[n_arows, 1] = cidx[c]
                a_rows[n_arows, 2] = ids[out[c]]
                n_arows += 1
        aoff = np.cumsum(cnt)            # assoc[j] = arow[aoff[j]:aoff[j + 1]], ascending detections
        arow = np.empty(n_assoc, dtype=np.int64)
        fill = aoff[:-1].copy()
        for c in range(out.shape[0]):
            j = out[c]
            if j >= 0:
                arow[fill[j]] = cidx[c]
                fill[j] += 1
        # 5: M/N windows and removal (c.5)
        Wr = ip[I_REMOVAL_WIN]
        mask = (1 << Wr) - 1
        keep = np.ones(N, dtype=np.bool_)
        n_keep = 0
        for j in range(N):
            i = 3 + 2 * j
            dx = x[i] - x[0]
            dy = x[i + 1] - x[1]
            view = math.hypot(dx, dy) <= fp[F_MAX_RANGE]
            if fp[F_HALF_FOV] < math.pi:
                view = view and abs(_wrap_pi(math.atan2(dy, dx) - x[2])) <= fp[F_HALF_FOV]
            h = aoff[j + 1] > aoff[j]
            mbits[j] = ((mbits[j] << 1) | (1 if h else 0)) & mask
            rbits[j] = ((rbits[j] << 1) | (1 if (h or view) else 0)) & mask
            if (k - Wr + 1 >= created[j] and _popcount(rbits[j]) == Wr
                    and _popcount(mbits[j]) <= ip[I_REMOVAL_MAX]):
                keep[j] = False
            else:
                n_keep += 1
        old = np.empty(n_keep, dtype=np.int64)  # surviving landmark -> its position before removal
        if n_keep < N:
            x, P = _drop_state_rows(x, P, keep)
            q = 0
            for j in range(N):
                if keep[j]:
                    old[q] = j
                    ids[q], created[q], mbits[q], rbits[q] = ids[j], created[j], mbits[j], rbits[j]
                    einit[q], X[q], alpha[q], Xefa[q] = einit[j], X[j], alpha[j], Xefa[j]
                    nbuf[q] = nbuf[j]
                    buf[q] = buf[j]
                    q += 1
            N = n_keep
        else:
            for j in range(N):
                old[j] = j
        # 6: the extent step (a.3-a.5), detections in the world frame of the updated pose
        xy = _to_world(x, polar)
        if ip[I_TRACK] == 1 and N > 0:
            if ip[I_POSTERIOR] == 1:
                cents, ccovs = _blocks(x, P)
            else:
                cents = np.empty((N, 2))
                ccovs = np.empty((N, 2, 2))
                for j in range(N):
                    cents[j] = pos_prior[old[j]]
                    ccovs[j] = cov_prior[old[j]]
            n_ready = 0
            n_rows = 0
            for j in range(N):
                o = old[j]
                if einit[j]:
                    n_ready += 1
                    n_rows += aoff[o + 1] - aoff[o]
            ready = np.empty(n_ready, dtype=np.int64)
            r_i = 0
            for j in range(N):
                o = old[j]
                if einit[j]:
                    ready[r_i] = j
                    r_i += 1
                    continue
                # a.3: buffer, then the EFA (upper bound) once more than n_init are held
                na = aoff[o + 1] - aoff[o]
                buf = _grow_buffer(buf, nbuf[j] + na)
                for a in range(na):
                    buf[j, nbuf[j] + a, 0] = xy[arow[aoff[o] + a], 0]
                    buf[j, nbuf[j] + a, 1] = xy[arow[aoff[o] + a], 1]
                nbuf[j] += na
                if nbuf[j] <= ip[I_N_INIT]:
                    continue
                data = buf[j, :nbuf[j]].copy()
                ok, _, _, e11, e12, e22 = _fit_entries(data, True, 0.0, 0.0, 0.0, gamma)
                if ok:
                    einit[j] = True
                    X[j, 0, 0], X[j, 0, 1], X[j, 1, 0], X[j, 1, 1] = e11, e12, e12, e22
                    alpha[j] = fp[F_ALPHA0]
                    Xefa[j] = X[j]
                    nbuf[j] = 0
                else:
                    keep_n = ip[I_N_INIT]
                    buf[j, :keep_n] = data[nbuf[j] - keep_n:]
                    nbuf[j] = keep_n
            if n_ready > 0:
                offsets = np.zeros(n_ready + 1, dtype=np.int64)
                rpol = np.empty((n_rows, 2))
                rpts = np.empty((n_rows, 2))
                q = 0
                for l in range(n_ready):
                    o = old[ready[l]]
                    for a in range(aoff[o], aoff[o + 1]):
                        rpol[q] = polar[arow[a]]
                        rpts[q] = xy[arow[a]]
                        q += 1
                    offsets[l + 1] = q
                Xr = np.empty((n_ready, 2, 2))
                ar = np.empty(n_ready)
                cr = np.empty((n_ready, 2))
                Cr = np.empty((n_ready, 2, 2))
                for l in range(n_ready):
                    Xr[l] = X[ready[l]]
                    ar[l] = alpha[ready[l]]
                    cr[l] = cents[ready[l]]
                    Cr[l] = ccovs[ready[l]]
                X_new, a_new, efa, efa_ok = rma_efa_step(Xr, ar, cr, Cr, offsets, rpol, rpts, x[:3].copy(),
                                                         P[:3, :3].copy(), R_ext, dt, fp[F_TAU], gamma,
                                                         fp[F_EIG_FLOOR], ip[I_UPPER] == 1)
                for l in range(n_ready):
                    j = ready[l]
                    X[j] = X_new[l]
                    alpha[j] = a_new[l]
                    if efa_ok[l]:
                        Xefa[j] = efa[l]
        # 7: DBSCAN of the detections no landmark claimed, then the alpha test
        n_rest = m - cidx.shape[0]
        nc = 0
        cl_centre = np.empty(0, dtype=np.int64)
        cl_size = np.empty(0, dtype=np.int64)
        labels = np.empty(0, dtype=np.int64)
        rest = np.flatnonzero(~cand)
        if n_rest >= ip[I_MIN_SAMPLES]:
            pts_rest = np.empty((n_rest, 2))
            rng_rest = np.empty(n_rest)
            for a in range(n_rest):
                pts_rest[a] = xy[rest[a]]
                rng_rest[a] = polar[rest[a], 0]
            labels = dbscan_labels(pts_rest, fp[F_EPS], ip[I_MIN_SAMPLES])
            centres = dbscan_centres(rng_rest, labels)
            nc = centres.shape[0]
            cl_centre = np.empty(nc, dtype=np.int64)
            cl_size = np.zeros(nc, dtype=np.int64)
            for a in range(n_rest):
                if labels[a] >= 0:
                    cl_size[labels[a]] += 1
            for c in range(nc):
                cl_centre[c] = rest[centres[c]]
        fresh = np.empty(nc, dtype=np.int64)          # clusters that pass the alpha test, in order
        nf = 0
        for c in range(nc):
            i = cl_centre[c]
            if min_log_distance(x, P, polar[i, 0], polar[i, 1], ip[I_N_NEW], R_plain) > fp[F_ALPHA]:
                fresh[nf] = c
                nf += 1
        # 8: Rule 2 (matched tentatives) then Rule 1 (c.7)
        confirmed = np.empty(nf, dtype=np.int64)
        n_conf = 0
        matched_c = np.zeros(nf, dtype=np.bool_)
        consumed = np.zeros(T, dtype=np.bool_)
        if T > 0 and nf > 0:
            d = np.empty(T * nf)
            for t in range(T):
                for f in range(nf):
                    i = cl_centre[fresh[f]]
                    d0 = tc[t, 0] - xy[i, 0]
                    d1 = tc[t, 1] - xy[i, 1]
                    d[t * nf + f] = math.sqrt(d0 * d0 + d1 * d1)
            matched_t = np.zeros(T, dtype=np.bool_)
            for flat in np.argsort(d, kind="mergesort"):
                if d[flat] >= fp[F_TENT_GATE]:
                    break
                t, f = flat // nf, flat % nf
                if matched_t[t] or matched_c[f]:
                    continue
                matched_t[t] = True
                matched_c[f] = True
                i = cl_centre[fresh[f]]
                tcount[t] += 1
                tc[t, 0], tc[t, 1] = xy[i, 0], xy[i, 1]
                tnpts[t] = cl_size[fresh[f]]
                if tcount[t] >= ip[I_CONFIRM_HITS] or tnpts[t] >= ip[I_CONFIRM_PTS]:
                    confirmed[n_conf] = fresh[f]
                    n_conf += 1
                    consumed[t] = True
        Mw, Nh = ip[I_CONFIRM_WIN], ip[I_CONFIRM_HITS]
        T_new = 0
        for t in range(T):
            if consumed[t]:
                continue
            twin[t] += 1
            if twin[t] >= Mw or tcount[t] + Mw - twin[t] < Nh:
                continue
            tc[T_new], tcount[T_new], twin[T_new], tnpts[T_new] = tc[t], tcount[t], twin[t], tnpts[t]
            T_new += 1
        T = T_new
        for f in range(nf):
            if matched_c[f]:
                continue
            c = fresh[f]
            if cl_size[c] >= ip[I_CONFIRM_PTS]:
                confirmed[n_conf] = c
                n_conf += 1
            else:
                tc = _grow_rows(tc, T + 1)
                tcount = _grow_rows(tcount, T + 1)
                twin = _grow_rows(twin, T + 1)
                tnpts = _grow_rows(tnpts, T + 1)
                i = cl_centre[c]
                tc[T, 0], tc[T, 1] = xy[i, 0], xy[i, 1]
                tcount[T], twin[T], tnpts[T] = 1, 1, cl_size[c]
                T += 1
        # 9: augmentation (c.8)
        for a in range(n_conf):
            c = confirmed[a]
            if ip[I_INIT_CLUSTER] == 1:
                members = np.empty((cl_size[c], 2))
                q = 0
                for b in range(n_rest):
                    if labels[b] == c:
                        members[q] = polar[rest[b]]
                        q += 1
                x, P = _augment_mean(x, P, members, R_plain, prior_spread, ip[I_SPREAD_AT_BIRTH] == 1)
            else:
                i = cl_centre[c]
                x, P = _augment(x, P, polar[i].copy(), R_plain)
            if N + 1 > ids.shape[0]:
                ids = _grow_rows(ids, N + 1)
                created = _grow_rows(created, N + 1)
                mbits = _grow_rows(mbits, N + 1)
                rbits = _grow_rows(rbits, N + 1)
                einit = _grow_rows(einit, N + 1)
                X = _grow_rows(X, N + 1)
                alpha = _grow_rows(alpha, N + 1)
                Xefa = _grow_rows(Xefa, N + 1)
                nbuf = _grow_rows(nbuf, N + 1)
                buf = _grow_rows(buf, N + 1)
            ids[N], created[N], mbits[N], rbits[N] = next_id, k, 1, 1
            einit[N], alpha[N], nbuf[N] = False, 0.0, 0
            next_id += 1
            N += 1
        # 10: merging (c.9): repeatedly drop the later-created landmark of the closest eligible pair
        n_merged = 0
        while N >= 2 and (ip[I_MERGE_MAX] == 0 or n_merged < ip[I_MERGE_MAX]):
            if not fp[F_MERGE_D] > 0:
                break
            bi, bj, bd = -1, -1, math.inf
            for i in range(N):
                for j in range(i + 1, N):
                    dx = x[3 + 2 * i] - x[3 + 2 * j]
                    dy = x[4 + 2 * i] - x[4 + 2 * j]
                    if not (abs(dx) < fp[F_MERGE_D] and abs(dy) < fp[F_MERGE_D]):
                        continue            # hypot(dx, dy) >= max(|dx|, |dy|): out of reach, exactly
                    dd = math.hypot(dx, dy)
                    if not dd < fp[F_MERGE_D]:
                        continue
                    if math.isfinite(fp[F_MERGE_AXIS]) and not (abs(dx) <= fp[F_MERGE_AXIS] or abs(dy) <= fp[F_MERGE_AXIS]):
                        continue
                    if dd < bd:
                        bi, bj, bd = i, j, dd
            if bi < 0:
                break
            if created[bj] < created[bi] or (created[bj] == created[bi] and ids[bj] < ids[bi]):
                bi, bj = bj, bi
            # the survivor keeps its extent, takes the other's if it has none, or pools the buffers
            if not einit[bi] and einit[bj]:
                einit[bi], X[bi], alpha[bi], Xefa[bi], nbuf[bi] = True, X[bj], alpha[bj], Xefa[bj], nbuf[bj]
                buf[bi] = buf[bj]
            elif not einit[bi] and not einit[bj]:
                buf = _grow_buffer(buf, nbuf[bi] + nbuf[bj])
                buf[bi, nbuf[bi]:nbuf[bi] + nbuf[bj]] = buf[bj, :nbuf[bj]]
                nbuf[bi] += nbuf[bj]
            keepm = np.ones(N, dtype=np.bool_)
            keepm[bj] = False
            x, P = _drop_state_rows(x, P, keepm)
            for j in range(bj, N - 1):
                ids[j], created[j], mbits[j], rbits[j] = ids[j + 1], created[j + 1], mbits[j + 1], rbits[j + 1]
                einit[j], X[j], alpha[j], Xefa[j] = einit[j + 1], X[j + 1], alpha[j + 1], Xefa[j + 1]
                nbuf[j] = nbuf[j + 1]
                buf[j] = buf[j + 1]
            N -= 1
            n_merged += 1
        if not _all_finite(x, P):
            status[0], status[1] = BAD_SCAN, ev
            break
        # the record after the scan (run_filter)
        poses[s] = x[:3]
        pcovs[s] = P[:3, :3]
        n_det[s] = m
        n_ass[s] = n_assoc
        n_lm[s] = N
        nis_sum[s] = nis.sum()
        nis_cnt[s] = nis.shape[0]
        base = map_off[s]
        map_off[s + 1] = base + N
        if base + N > m_ids.shape[0]:
            m_ids = _grow_rows(m_ids, base + N)
            m_pos = _grow_rows(m_pos, base + N)
            m_cov = _grow_rows(m_cov, base + N)
            m_rma = _grow_rows(m_rma, base + N)
            m_efa = _grow_rows(m_efa, base + N)
            m_created = _grow_rows(m_created, base + N)
        for j in range(N):
            i = 3 + 2 * j
            r = base + j
            m_ids[r] = ids[j]
            m_created[r] = created[j]
            m_pos[r, 0], m_pos[r, 1] = x[i], x[i + 1]
            m_cov[r, 0, 0], m_cov[r, 0, 1] = P[i, i], P[i, i + 1]
            m_cov[r, 1, 0], m_cov[r, 1, 1] = P[i, i + 1], P[i + 1, i + 1]
            if einit[j]:
                m_rma[r] = X[j]
                m_efa[r] = Xefa[j]
            else:
                m_rma[r] = np.nan
                m_efa[r] = np.nan
        if ip[I_TIMING] == 1:
            with objmode(t1="float64"):
                t1 = time.perf_counter()
            seconds[s] = t1 - t_last
            t_last = t1
        s += 1
    T_rows = map_off[s]
    return (status, s, poses[:s], pcovs[:s], n_det[:s], n_ass[:s], n_lm[:s], nis_sum[:s], nis_cnt[:s],
            map_off[:s + 1], m_ids[:T_rows], m_pos[:T_rows], m_cov[:T_rows], m_rma[:T_rows], m_efa[:T_rows],
            m_created[:T_rows], a_rows[:n_arows], seconds[:s])


# ---------------------------------------------------------------------------------------- Python side
def why_not(slam, events=None) -> str | None:
    """Why :func:`run` cannot stand in for ``slam`` (an :class:`~radarslam.slam.filter.EkfSlam`
    that has processed nothing yet) on ``events``, or None when it can: the configuration's
    components must be the built-in ones this engine reproduces, and no scan may hold more than
    ``landmarks.clustering.DENSE_MAX`` detections (the compiled DBSCAN builds an m x m
    neighbourhood; the orchestrator hands such scans to scikit-learn's)."""
    from radarslam.extent.estimator import RmaEfaEstimator
    from radarslam.models.motion import UnicycleModel
    from radarslam.models.radar import RangeAzimuthModel
    from radarslam.slam._numba import (CompiledBatchAssociator, CompiledJointBatchAssociator,
                                       CompiledNearestNeighbourAssociator)

    f, ec = slam.config.filter, slam.config.extent
    checks = (
        (f.fused, "filter.fused is false"),
        (f.backend == "numba", f"filter.backend is {f.backend!r}"),
        (f.jacobians == "standard", "filter.jacobians 'fej' (first-estimates Jacobians, docs/method.md c.2.1)"),
        (getattr(slam, "view", None) is None, "the partial-view model (docs/method.md a.12)"),
        (not f.doppler_gate, "filter.doppler_gate (the Doppler gate, docs/method.md c.10.4)"),
        (type(slam.model) is UnicycleModel, f"motion model {type(slam.model).__name__}"),
        (type(slam.measurement) is RangeAzimuthModel, f"measurement model {type(slam.measurement).__name__}"),
        (type(slam.associator) in (CompiledNearestNeighbourAssociator, CompiledBatchAssociator,
                                   CompiledJointBatchAssociator),
         f"associator {type(slam.associator).__name__}"),
        (type(slam.extent) is RmaEfaEstimator, f"extent estimator {type(slam.extent).__name__}"),
        (ec.efa_mode == "per_scan", f"extent.efa_mode {ec.efa_mode!r}"),
        (ec.w_mode == "max_trace", f"extent.w_mode {ec.w_mode!r}"),
        (ec.pre_init_spread in ("none", "prior"), f"extent.pre_init_spread {ec.pre_init_spread!r}"),
        (slam.state.n_landmarks == 0 and slam._scans == 0, "the filter has already processed a scan"),
    )
    for ok, reason in checks:
        if not ok:
            return reason
    if events is not None:
        from radarslam.core.types import Scan
        from radarslam.landmarks.clustering import DENSE_MAX

        big = max((np.shape(e.polar)[0] for e in events if isinstance(e, Scan) and np.ndim(e.polar) == 2), default=0)
        if big > DENSE_MAX:
            return f"a scan of {big} detections (the fused engine clusters up to {DENSE_MAX})"
    return None


def _parameters(slam):
    """``(ip, fp)`` of :func:`run_stream` from ``slam``'s configuration and components."""
    lc, ec, f = slam.config.landmarks, slam.config.extent, slam.config.filter
    from radarslam.slam._numba import CompiledBatchAssociator, CompiledJointBatchAssociator

    ip = np.zeros(N_IP, dtype=np.int64)
    in_slam = bool(ec.use_in_slam)
    ip[I_ASSOC] = {CompiledBatchAssociator: 1, CompiledJointBatchAssociator: 2}.get(type(slam.associator), 0)
    ip[I_N_NEAR], ip[I_N_NEW] = slam.associator.n_nearest, slam.associator.n_nearest_new
    ip[I_MIN_SAMPLES] = lc.cluster_min_samples
    ip[I_CONFIRM_PTS], ip[I_CONFIRM_WIN], ip[I_CONFIRM_HITS] = lc.confirm_points, lc.confirm_window, lc.confirm_hits
    ip[I_REMOVAL_WIN], ip[I_REMOVAL_MAX] = lc.removal_window, lc.removal_max_hits
    ip[I_MERGE_MAX] = lc.merge_max_per_scan
    ip[I_INIT_CLUSTER] = int(lc.init == "cluster")
    ip[I_TRACK] = int(bool(ec.track))
    ip[I_CONTOUR] = int(in_slam and bool(ec.contour_sifting))
    ip[I_INFLATE] = int(in_slam and bool(ec.inflate_noise))
    ip[I_PRE_PRIOR] = int(ec.pre_init_spread == "prior")
    ip[I_N_INIT] = ec.n_init
    ip[I_POSTERIOR] = int(bool(ec.use_posterior_landmark))
    ip[I_UPPER] = int(not ec.efa_noise_correct)
    ip[I_SPREAD_AT_BIRTH] = int(slam.extent.initial_spread() is not None)
    ip[I_LITERAL] = int(ec.sifting_mode == "literal")
    fp = np.zeros(N_FP)
    fp[F_BETA], fp[F_ALPHA] = slam.associator.beta, lc.alpha
    fp[F_SIFT_R], fp[F_EPS], fp[F_TENT_GATE] = lc.sift_radius_m, lc.cluster_eps_m, lc.tentative_gate_m
    fp[F_MERGE_D], fp[F_MERGE_AXIS] = lc.merge_distance_m, lc.merge_axis_tol_m
    fp[F_MAX_RANGE], fp[F_HALF_FOV] = f.max_range_m, math.radians(f.field_of_view_deg) / 2.0
    fp[F_GATE], fp[F_GAMMA] = slam.extent.gate, ec.spread_factor
    fp[F_ALPHA0], fp[F_TAU], fp[F_EIG_FLOOR], fp[F_KAPPA] = ec.alpha0, ec.tau_s, ec.eig_floor_m2, ec.kappa
    return ip, fp


def _stream_arrays(events, fast: bool = True):
    """The event stream as arrays, each event checked as :meth:`EkfSlam.predict` and
    :meth:`EkfSlam.update` check it (the same one-line errors, the first bad event's).

    ``fast``: a scan whose detections are already a float ``(m, 2)`` array is checked with all the
    others at once at the end (finite, ranges >= 0); if anything is wrong, the stream is checked
    again event by event, so that the error is the one the orchestrator raises first."""
    from radarslam.core.errors import InputError

    if not fast:
        return _stream_arrays_checked(events, False)
    try:
        out = _stream_arrays_checked(events, True)
    except InputError:
        return _stream_arrays_checked(events, False)
    polar = out[4]
    if not (np.isfinite(polar).all() and (polar[:, 0] >= 0).all()):
        return _stream_arrays_checked(events, False)
    return out


def _stream_arrays_checked(events, defer_polar: bool):
    from radarslam.core.errors import InputError
    from radarslam.core.types import Odometry, Scan
    from radarslam.core.validation import as_array
    from radarslam.slam.filter import _number, _scan_polar

    kinds, odo, odo_dt, polars, scan_k, scan_t, last_t = [], [], [], [], [], [], None
    for ev in events:
        if isinstance(ev, Odometry):
            u = ev.control
            if not (type(u) is np.ndarray and u.dtype == np.float64 and u.shape == (2,)
                    and math.isfinite(u[0]) and math.isfinite(u[1])):
                u = as_array("odometry.control", u, (2,))
            dt = _number(ev.dt, "odometry.dt")
            if not dt > 0:
                raise InputError(f"odometry.dt: expected a finite value > 0, got {ev.dt!r}")
            kinds.append(0)
            odo.append(u)
            odo_dt.append(dt)
        elif isinstance(ev, Scan):
            polar = ev.polar
            if not (defer_polar and type(polar) is np.ndarray and polar.dtype == np.float64 and polar.ndim == 2
                    and polar.shape[1] == 2):
                polar = _scan_polar(ev)
            t = _number(ev.t, "scan.t")
            if last_t is not None and t < last_t:
                raise InputError(f"scan.t: expected scan times that do not go backwards, got {t!r} after "
                                 f"{last_t!r} (scan {ev.index})")
            last_t = t
            kinds.append(1)
            polars.append(polar)
            scan_k.append(int(ev.index))
            scan_t.append(ev.t)
        else:
            raise InputError(f"event: expected Odometry or Scan, got {type(ev).__name__}")
    off = np.zeros(len(polars) + 1, dtype=np.int64)
    off[1:] = np.cumsum([p.shape[0] for p in polars])
    return (np.array(kinds, dtype=np.int64), np.array(odo, dtype=float).reshape(-1, 2), np.array(odo_dt, dtype=float),
            off, (np.concatenate(polars) if polars else np.empty((0, 2))).reshape(-1, 2), np.array(scan_k, dtype=np.int64),
            scan_t)


def run(slam, events, timing: bool = False):
    """Run ``events`` through the fused engine with ``slam``'s configuration and components
    (:func:`why_not` of both must be None). Returns ``(record, associations)``: the arrays of
    :func:`run_stream` by name, and the ``(scan, detection, landmark id)`` rows. ``timing`` adds
    ``"seconds"``: each scan's wall time with the predictions before it (``benchmarks/bench_scaling.py``).

    Raises
    ------
    InputError
        As :class:`EkfSlam` would, for a bad event or an event that makes the state non-finite.
    """
    from radarslam.core.errors import InputError

    kinds, odo, odo_dt, off, polar, scan_k, scan_t = _stream_arrays(events)
    ip, fp = _parameters(slam)
    ip[I_TIMING] = int(bool(timing))
    st = slam.state
    ext = slam.extent
    prior_spread = ext.prior_spread if ext.initial_spread() is not None or ip[I_PRE_PRIOR] else np.zeros((2, 2))
    res = run_stream(kinds, odo, odo_dt, off, polar, scan_k, st.x, st.P, slam.R, ext.R_extent, slam.U, slam.Q,
                     np.ascontiguousarray(prior_spread, dtype=float), ip, fp)
    status, n_scans = res[0], int(res[1])
    if status[0] != OK:
        ev = events[int(status[1])]
        if status[0] == BAD_PREDICTION:
            what = f"odometry at t={ev.t!r} (control {np.asarray(ev.control, dtype=float).tolist()}, dt {float(ev.dt)!r})"
        else:
            what = f"scan {ev.index} (t={ev.t!r}, {off[n_scans + 1] - off[n_scans]} detections)"
        raise InputError(f"{what}: expected an input that keeps the state finite, got one that makes it non-finite")
    names = ("poses", "pose_covs", "n_detections", "n_associated", "n_landmarks", "nis_sum", "nis_count",
             "map_offsets", "ids", "positions", "covs", "rma", "efa", "created")
    out = dict(zip(names, res[2:16]))
    if timing:
        out["seconds"] = res[17]
    return out, res[16]
