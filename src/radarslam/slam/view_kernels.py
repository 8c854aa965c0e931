"""The partial-view measurement model's arithmetic as kernels (docs/method.md a.12.4-a.12.6).

Plain loops over landmarks on small arrays: the fused engine
(:mod:`radarslam.slam.fused.view`) calls them compiled (:mod:`radarslam.slam._view_compiled`), so that the arithmetic of
``mu``, ``B``, ``S``, the model error, the polar and sensor-frame measurements, the log distance,
the view-corrected centroid and the view walk is written here once. Landmark ``j`` of a state
``x`` sits at ``x[platform + 2 j : platform + 2 j + 2]`` (:mod:`.layout`).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.extent.partial_view import arc_moments
from radarslam.extent.partial_view_jac import arc_xi_rows
from radarslam.extent.view_estimator import arc_rows, exp_sym2, put_arc_row
from radarslam.slam.ekf import batch_noise, rotate_to_sensor

#: ``log((2 pi)^2)`` of the log distance (APSIPA eq. 9).
LOG_2PI2 = math.log((2.0 * math.pi) ** 2)
#: Central-difference step on the log-matrix shape of the model error's ``J = dg/dxi`` (a.12.5) under
#: ``extent.view_jacobian = "central-difference"``; 0 selects the analytic ``J`` (a.12.9).
SHAPE_STEP = 1e-4


def view_rows(x: np.ndarray, shapes: np.ndarray, js: np.ndarray, platform: int):
    """``mu (n, 2)``, ``B (n, 2, 2)`` and ``S (n, 2, 2)`` of the landmarks ``js`` of state ``x``
    seen from its pose, with the shapes ``shapes (N_all, 2, 2)`` (a.12.4;
    :func:`~radarslam.extent.view_estimator.arc_rows`). A kernel."""
    n = js.shape[0]
    cents = np.empty((n, 2))
    sh = np.empty((n, 2, 2))
    for a in range(n):
        i = platform + 2 * js[a]
        cents[a, 0] = x[i]
        cents[a, 1] = x[i + 1]
        sh[a] = shapes[js[a]]
    return arc_rows(x[0], x[1], cents, sh)


def view_xi_rows(x: np.ndarray, shapes: np.ndarray, js: np.ndarray, platform: int):
    """:func:`view_rows` with the mean offset's derivatives over the log-matrix shape: ``mu (n, 2)``,
    ``B (n, 2, 2)``, ``S (n, 2, 2)`` and ``J = dg/dxi (n, 2, 3)`` of the landmarks ``js``, each
    from one quadrature pass over its arc (:func:`~radarslam.extent.partial_view_jac.arc_xi_rows`,
    a.12.9 "SLAM's terms from the same pass"), for :func:`model_error_rows`. A kernel."""
    n = js.shape[0]
    mu = np.empty((n, 2))
    B = np.empty((n, 2, 2))
    S = np.empty((n, 2, 2))
    J = np.empty((n, 2, 3))
    h = np.empty(9)
    Hf = np.empty((5, 3))
    for a in range(n):
        j = js[a]
        i = platform + 2 * j
        px = x[i]
        py = x[i + 1]
        arc_xi_rows(x[0] - px, x[1] - py, shapes[j, 0, 0], shapes[j, 0, 1], shapes[j, 1, 1], h, Hf)
        put_arc_row(mu[a], B[a], S[a], px, py, h[0], h[1], h[5], h[6], h[7], h[8], h[2], h[3], h[4])
        for c in range(3):
            J[a, 0, c] = Hf[0, c]
            J[a, 1, c] = Hf[1, c]
    return mu, B, S, J


def exp_sym2_rows(xi: np.ndarray) -> np.ndarray:
    """``expm`` of the symmetric log-matrices ``xi (N, 3)`` (entries 11, 12, 22): ``(N, 2, 2)``. A kernel."""
    n = xi.shape[0]
    X = np.empty((n, 2, 2))
    for a in range(n):
        X11, X12, X22 = exp_sym2(xi[a, 0], xi[a, 1], xi[a, 2])
        X[a, 0, 0] = X11
        X[a, 0, 1] = X12
        X[a, 1, 0] = X12
        X[a, 1, 1] = X22
    return X


def shape_error_rows(x: np.ndarray, xi: np.ndarray, P_xi: np.ndarray, js: np.ndarray, Qv: np.ndarray,
                     step: float, platform: int) -> np.ndarray:
    """``(n, 2, 2)``: the model error ``Q_v + J P_xi J^T`` of each landmark of ``js`` (a.12.5), with
    ``J = dg/dxi`` of the mean offset over the log-matrix shape ``xi (N_all, 3)`` by central
    differences of ``step``, or analytic (a.12.9) for ``step = 0``; ``P_xi (N_all, 3, 3)`` the
    shapes' covariances. A kernel."""
    n = js.shape[0]
    out = np.empty((n, 2, 2))
    J = np.empty((2, 3))
    h = np.empty(5)
    Hf = np.empty((5, 3))
    for a in range(n):
        j = js[a]
        i = platform + 2 * j
        d0 = x[0] - x[i]
        d1 = x[1] - x[i + 1]
        if step == 0.0:
            X11, X12, X22 = exp_sym2(xi[j, 0], xi[j, 1], xi[j, 2])
            arc_xi_rows(d0, d1, X11, X12, X22, h, Hf)
            for c in range(3):
                J[0, c] = Hf[0, c]
                J[1, c] = Hf[1, c]
        else:
            _central_shape_jacobian(d0, d1, xi[j], step, J)
        _shape_error(J, P_xi[j], Qv, out[a])
    return out


def model_error_rows(J: np.ndarray, P_xi: np.ndarray, js: np.ndarray, Qv: np.ndarray) -> np.ndarray:
    """``(n, 2, 2)``: :func:`shape_error_rows` of the landmarks ``js`` with their analytic
    ``J = dg/dxi (n, 2, 3)`` already at hand (:func:`view_xi_rows`). A kernel."""
    n = js.shape[0]
    out = np.empty((n, 2, 2))
    for a in range(n):
        _shape_error(J[a], P_xi[js[a]], Qv, out[a])
    return out


def _shape_error(J: np.ndarray, P: np.ndarray, Qv: np.ndarray, out: np.ndarray) -> None:
    """``out (2, 2) = Q_v + J P J^T`` of one landmark, in place (a.12.5). A kernel."""
    for r in range(2):
        t0 = J[r, 0] * P[0, 0] + J[r, 1] * P[1, 0] + J[r, 2] * P[2, 0]
        t1 = J[r, 0] * P[0, 1] + J[r, 1] * P[1, 1] + J[r, 2] * P[2, 1]
        t2 = J[r, 0] * P[0, 2] + J[r, 1] * P[1, 2] + J[r, 2] * P[2, 2]
        for s in range(2):
            out[r, s] = Qv[r, s] + (t0 * J[s, 0] + t1 * J[s, 1] + t2 * J[s, 2])


def _central_shape_jacobian(d0: float, d1: float, xi: np.ndarray, step: float, J: np.ndarray) -> None:
    """``J (2, 3) = dg/dxi`` of the mean offset seen along ``d`` by central differences of ``step``
    on the log-matrix shape ``xi (3,)``, in place. A kernel."""
    up = np.empty(3)
    dn = np.empty(3)
    for c in range(3):
        for b in range(3):
            up[b] = xi[b]
            dn[b] = xi[b]
        up[c] = xi[c] + step
        dn[c] = xi[c] - step
        p11, p12, p22 = exp_sym2(up[0], up[1], up[2])
        gp = arc_moments(d0, d1, p11, p12, p22)
        m11, m12, m22 = exp_sym2(dn[0], dn[1], dn[2])
        gm = arc_moments(d0, d1, m11, m12, m22)
        J[0, c] = (gp[0] - gm[0]) / (2.0 * step)
        J[1, c] = (gp[1] - gm[1]) / (2.0 * step)


def polar_rows(x: np.ndarray, mu: np.ndarray, B: np.ndarray, S: np.ndarray, R: np.ndarray, Q: np.ndarray):
    """Per landmark, the polar measurement of one detection (a.12.5): ``h (n, 2)``, ``Hs (n, 2, 5)``
    over ``(x, y, theta, p_x, p_y)``, ``R_j = R + Hp (S + Q) Hp^T`` ``(n, 2, 2)`` with the model
    errors ``Q (n, 2, 2)``, and ``ok (n,)``, False where ``mu`` sits on the sensor
    (:func:`polar_row` of each). A kernel."""
    n = mu.shape[0]
    h = np.empty((n, 2))
    Hs = np.zeros((n, 2, 5))
    Rj = np.empty((n, 2, 2))
    ok = np.empty(n, dtype=np.bool_)
    for a in range(n):
        ok[a] = polar_row(x, mu[a, 0], mu[a, 1], B[a], S[a], Q[a], R, h[a], Hs[a], Rj[a])
    return h, Hs, Rj, ok


def polar_row(x: np.ndarray, m0: float, m1: float, B: np.ndarray, S: np.ndarray, Q: np.ndarray, R: np.ndarray,
              h: np.ndarray, Hs: np.ndarray, Rj: np.ndarray) -> bool:
    """:func:`polar_rows` of one landmark with the mean ``(m0, m1)``, ``B``, ``S`` and ``Q (2, 2)``,
    into ``h (2,)``, ``Hs (2, 5)`` (whose other entries are left as they are: zeros from
    :func:`polar_rows`) and ``Rj (2, 2)``; returns ``ok``. A kernel."""
    d0 = m0 - x[0]
    d1 = m1 - x[1]
    r2 = d0 * d0 + d1 * d1
    ok = r2 > 1e-12
    if not ok:
        r2 = 1.0
    r = math.sqrt(r2)
    H00 = d0 / r
    H01 = d1 / r
    H10 = -d1 / r2
    H11 = d0 / r2
    for c in range(2):
        hb0 = H00 * B[0, c] + H01 * B[1, c]
        hb1 = H10 * B[0, c] + H11 * B[1, c]
        Hs[0, c] = -hb0
        Hs[1, c] = -hb1
        Hs[0, 3 + c] = hb0
        Hs[1, 3 + c] = hb1
    Hs[1, 2] = -1.0
    h[0] = r
    h[1] = math.atan2(d1, d0) - x[2]
    c00 = S[0, 0] + Q[0, 0]
    c01 = S[0, 1] + Q[0, 1]
    c10 = S[1, 0] + Q[1, 0]
    c11 = S[1, 1] + Q[1, 1]
    t00 = H00 * c00 + H01 * c10
    t01 = H00 * c01 + H01 * c11
    t10 = H10 * c00 + H11 * c10
    t11 = H10 * c01 + H11 * c11
    Rj[0, 0] = R[0, 0] + (t00 * H00 + t01 * H01)
    Rj[0, 1] = R[0, 1] + (t00 * H10 + t01 * H11)
    Rj[1, 0] = R[1, 0] + (t10 * H00 + t11 * H01)
    Rj[1, 1] = R[1, 1] + (t10 * H10 + t11 * H11)
    return ok


def sensor_xy_rows(x: np.ndarray, mu: np.ndarray, B: np.ndarray):
    """Per landmark, the sensor-frame Cartesian measurement of the batch update (a.12.5):
    ``h = Rot(-theta)(mu - t)`` ``(n, 2)`` and ``Hs (n, 2, 5)`` over ``(x, y, theta, p_x, p_y)``. A kernel."""
    c = math.cos(x[2])
    s = math.sin(x[2])
    n = mu.shape[0]
    h = np.empty((n, 2))
    Hs = np.zeros((n, 2, 5))
    for a in range(n):
        d0 = mu[a, 0] - x[0]
        d1 = mu[a, 1] - x[1]
        h[a, 0] = d0 * c + d1 * s
        h[a, 1] = d0 * -s + d1 * c
        for k in range(2):
            rb0 = c * B[a, 0, k] + s * B[a, 1, k]
            rb1 = -s * B[a, 0, k] + c * B[a, 1, k]
            Hs[a, 0, k] = -rb0
            Hs[a, 1, k] = -rb1
            Hs[a, 0, 3 + k] = rb0
            Hs[a, 1, 3 + k] = rb1
        Hs[a, 0, 2] = h[a, 1]
        Hs[a, 1, 2] = -h[a, 0]
    return h, Hs


def _times_transpose(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``A B^T`` ``(2, n)`` of ``A (2, 5)`` and ``B (n, 5)``. A kernel."""
    n = B.shape[0]
    out = np.empty((2, n))
    for r in range(2):
        for c in range(n):
            acc = 0.0
            for k in range(5):
                acc += A[r, k] * B[c, k]
            out[r, c] = acc
    return out


def innovation_cov(Hs: np.ndarray, Pb: np.ndarray, Rj: np.ndarray) -> np.ndarray:
    """``Hs Pb Hs^T + R_j`` ``(2, 2)`` of one landmark: ``Hs (2, 5)``, ``Pb (5, 5)`` the covariance
    of ``(x, y, theta, p_x, p_y)``. A kernel."""
    return _times_transpose(_times_transpose(Hs, Pb.T), Hs) + Rj


def view_log_distance(z0: float, z1: float, h0: float, h1: float, Sn: np.ndarray) -> float:
    """APSIPA eq. (9) of the detection ``(z0, z1)`` against the prediction ``(h0, h1)`` with the
    innovation covariance ``Sn (2, 2)``; ``inf`` where ``Sn`` is not positive definite (c.4). A kernel."""
    det = Sn[0, 0] * Sn[1, 1] - Sn[0, 1] * Sn[1, 0]
    if not (det > 0.0 and Sn[0, 0] > 0.0):
        return math.inf
    e0 = z0 - h0
    e1 = (z1 - h1 + math.pi) % (2.0 * math.pi) - math.pi
    q = (Sn[1, 1] * e0 * e0 - 2.0 * Sn[0, 1] * e0 * e1 + Sn[0, 0] * e1 * e1) / det
    return 0.5 * q + 0.5 * (LOG_2PI2 + math.log(det))


def log_distance_rows(z: np.ndarray, h: np.ndarray, Hs: np.ndarray, Pb: np.ndarray, Rj: np.ndarray) -> np.ndarray:
    """:func:`view_log_distance` of every detection ``z (C, 2)`` against every landmark with
    ``h``, ``Hs``, ``Rj`` and the covariance blocks ``Pb (N, 5, 5)``: ``D (C, N)``. A kernel."""
    C, N = z.shape[0], h.shape[0]
    D = np.empty((C, N))
    for n in range(N):
        Sn = innovation_cov(Hs[n], Pb[n], Rj[n])
        for c in range(C):
            D[c, n] = view_log_distance(z[c, 0], z[c, 1], h[n, 0], h[n, 1], Sn)
    return D


def view_batch_noise(theta: float, S: np.ndarray, Q: np.ndarray, R_xy: np.ndarray, m: int) -> np.ndarray:
    """The noise ``(2, 2)`` of the sensor-frame mean of a landmark's ``m`` detections (a.12.5): the
    arc's spread and the sensor's noise shrink with ``m``, the model error ``Q`` does not. A kernel."""
    return batch_noise(theta, S, True, R_xy, m) + rotate_to_sensor(theta, Q)


def corrected_centroid(m0: float, m1: float, t0: float, t1: float, X: np.ndarray, iterations: int):
    """``(p0, p1)``: the fixed point of ``p = mean - g(t - p, X)`` (a.12.6) after ``iterations``
    steps from ``p = mean``. A kernel."""
    p0 = m0
    p1 = m1
    for _ in range(iterations):
        r = arc_moments(t0 - p0, t1 - p1, X[0, 0], X[0, 1], X[1, 1])
        p0 = m0 - r[0]
        p1 = m1 - r[1]
    return p0, p1


def view_walk_rows(x: np.ndarray, P: np.ndarray, last: np.ndarray, q: float, platform: int) -> np.ndarray:
    """The centroids' random walk with the viewing angle (a.12.5), in place on ``P``:
    ``P_pp += q |delta phi| I`` for the change of each landmark's bearing to the sensor since
    ``last`` (NaN: no previous bearing, no walk). Returns this scan's bearings ``(N,)``. A kernel."""
    N = (x.shape[0] - platform) // 2
    phi = np.empty(N)
    for j in range(N):
        i = platform + 2 * j
        phi[j] = math.atan2(x[1] - x[i + 1], x[0] - x[i])
        step = abs((phi[j] - last[j] + math.pi) % (2.0 * math.pi) - math.pi)
        if step > 0.0:                       # False for NaN
            P[i, i] += q * step
            P[i + 1, i + 1] += q * step
    return phi


#: The kernels of this module (compiled by :mod:`radarslam.slam._view_compiled`).
KERNELS = (view_rows, view_xi_rows, exp_sym2_rows, shape_error_rows, model_error_rows, _shape_error,
           _central_shape_jacobian, polar_rows, polar_row, sensor_xy_rows, _times_transpose, innovation_cov,
           view_log_distance, log_distance_rows, view_batch_noise, corrected_centroid, view_walk_rows)
