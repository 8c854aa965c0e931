"""The partial-view shape estimator's kernels (docs/method.md a.12.7-a.12.9): the predicted rows of
one scan, their Jacobian, the iterated update, the arcs' rows for sifting; compiled by
:mod:`._compiled` for the fused engine, the class of :mod:`.view_estimator`
calls them."""

from __future__ import annotations

import math

import numpy as np

from radarslam.core import small_matrices
from radarslam.core.small_matrices import abt_plus_cdt_into, cholesky_into, hpht_plus, matmul_into, solve_spd
from radarslam.extent.partial_view import arc_moments
from radarslam.extent.partial_view_jac import arc_xi_rows
from radarslam.extent.rows import detections

#: Gauss-Newton steps of the iterated update.
VIEW_ITERATIONS = 3
#: Central-difference step on the log-matrix entries (``extent.view_jacobian = "central-difference"``).
FD_STEP = 1e-4
#: Chi-square 99% quantiles (2 and 5 dof): a scan whose innovation lies beyond has its noise
#: scaled up by ``d^2 / gate`` (a Huber-type weight), so that one scan of another object's returns,
#: or of returns the arc model cannot produce, does not drag the shape.
GATE_2, GATE_5 = 9.210, 15.086
#: The (row, column) of the spread rows' entries 00, 01, 11 (a.12.7).
_PI = (0, 0, 1)
_PJ = (0, 1, 1)


def exp_sym2(a: float, b: float, c: float):
    """Entries ``(X11, X12, X22)`` of ``expm([[a, b], [b, c]])``: with ``m = (a + c) / 2`` and
    ``d = |(a - c) / 2, b|``, ``exp(m) (cosh d I + sinh(d) / d (A - m I))``. A kernel."""
    m = 0.5 * (a + c)
    d = math.hypot(0.5 * (a - c), b)
    sh = math.sinh(d) / d if d > 1e-12 else 1.0
    e = math.exp(m)
    ch = math.cosh(d)
    return e * (ch + sh * (a - m)), e * sh * b, e * (ch + sh * (c - m))


def predicted_rows(x0: float, x1: float, x2: float, dx: float, dy: float, W00: float, W01: float, W11: float,
                   out: np.ndarray) -> bool:
    """``E[y]`` of a.12.7 for the shape ``xi = (x0, x1, x2)`` seen along ``d = t - p``: ``out[:2]``
    the mean offset ``g``, ``out[2:5]`` the entries 00, 01, 11 of ``S + W_s``; returns the kernel's
    clamp flag (the sensor inside the outline). A kernel."""
    X11, X12, X22 = exp_sym2(x0, x1, x2)
    r = arc_moments(dx, dy, X11, X12, X22)
    out[0] = r[0]
    out[1] = r[1]
    out[2] = r[6] + W00
    out[3] = r[7] + W01
    out[4] = r[8] + W11
    return r[9] > 0.5


def rows_and_jacobian(x: np.ndarray, dx: float, dy: float, Ws: np.ndarray, step: float, h: np.ndarray,
                      H: np.ndarray, Hf: np.ndarray) -> bool:
    """``E[y]`` of a.12.7 at the shape ``x (3,)`` in ``h (5,)`` (:func:`predicted_rows`) and its
    Jacobian over ``x`` in the ``nr`` rows of ``H (nr, 3)``: by central differences of ``step``, or
    analytic (a.12.9, :func:`~radarslam.extent.partial_view_jac.arc_xi_rows`; ``Hf (5, 3)`` its
    scratch) for ``step = 0``. Returns the clamp flag at ``x`` (the sensor inside the outline). A kernel."""
    nr = H.shape[0]
    if step == 0.0:
        X11, X12, X22 = exp_sym2(x[0], x[1], x[2])
        clamped = arc_xi_rows(dx, dy, X11, X12, X22, h, Hf)
        h[2] += Ws[0, 0]
        h[3] += Ws[0, 1]
        h[4] += Ws[1, 1]
        for r in range(nr):
            for i in range(3):
                H[r, i] = Hf[r, i]
        return clamped
    if predicted_rows(x[0], x[1], x[2], dx, dy, Ws[0, 0], Ws[0, 1], Ws[1, 1], h):
        return True
    hp = np.empty(5)
    hm = np.empty(5)
    for i in range(3):
        x[i] += step
        predicted_rows(x[0], x[1], x[2], dx, dy, Ws[0, 0], Ws[0, 1], Ws[1, 1], hp)
        x[i] -= 2.0 * step
        predicted_rows(x[0], x[1], x[2], dx, dy, Ws[0, 0], Ws[0, 1], Ws[1, 1], hm)
        x[i] += step
        for r in range(nr):
            H[r, i] = (hp[r] - hm[r]) / (2.0 * step)
    return False


def view_update(xi: np.ndarray, P: np.ndarray, dx: float, dy: float, y: np.ndarray, m: int, Ws: np.ndarray,
                Pc: np.ndarray, qv2: float, rel: float, spread_only: bool, fd_step: float):
    """One scan's iterated EKF update of a landmark's shape (a.12.7): ``xi (3,)`` and its covariance
    ``P (3, 3)`` (process noise already added), the view ``d = t - p``, the measurement ``y (5,)``
    (``zbar - p`` and the entries 00, 01, 11 of the sample covariance; only the first two when
    ``m < 3``), the mean sensor noise ``Ws (2, 2)``, the centroid's covariance ``Pc (2, 2)``; the
    Jacobian by central differences of ``fd_step`` on ``xi``, or analytic (a.12.9) for ``fd_step = 0``.
    Returns ``(xi, P, status)``: status 0 updated, 1 seen from inside the outline (unchanged), 2
    not finite (unchanged). A kernel."""
    nr = 5 if m >= 3 else 2
    h = np.empty(5)
    Hf = np.empty((5, 3))
    x = xi.copy()
    by3 = np.empty((3, nr, 3))                                 # scratch by shape, each made once
    H, Y, HP = by3[0], by3[1], by3[2]                          # Y = Sy^-1 H P, so that K = Y^T
    square = np.zeros((3, nr, nr))
    Rn, Sy, L = square[0], square[1], square[2]
    col = np.empty((3, nr, 1))
    r, inn, sol = col[0], col[1], col[2]
    for _ in range(VIEW_ITERATIONS):
        if rows_and_jacobian(x, dx, dy, Ws, fd_step, h, H, Hf):
            return xi, P, 1
        # noise: the mean rows (S + Ws) / m + P_c + Q_v; the spread rows Wishart(m - 1) + relative error
        S00, S01, S11 = h[2], h[3], h[4]                      # S + W_s
        Rn[:, :] = 0.0
        big = 1e6 if (spread_only and nr == 5) else 0.0
        Rn[0, 0] = S00 / m + Pc[0, 0] + qv2 + big
        Rn[0, 1] = Rn[1, 0] = S01 / m + Pc[0, 1]
        Rn[1, 1] = S11 / m + Pc[1, 1] + qv2 + big
        if nr == 5:
            for a in range(3):
                i, j = _PI[a], _PJ[a]
                for b in range(3):
                    k, l = _PI[b], _PJ[b]
                    Rn[2 + a, 2 + b] = (h[2 + i + k] * h[2 + j + l] + h[2 + i + l] * h[2 + j + k]) / (m - 1)
                Rn[2 + a, 2 + a] += (rel * h[2 + i + j]) ** 2 + 1e-6
        matmul_into(H, P, HP)
        hpht_plus(HP, H, Rn, Sy)
        for a in range(nr):
            acc = 0.0
            for i in range(3):
                acc += H[a, i] * (xi[i] - x[i])
            r[a, 0] = y[a] - h[a] - acc                        # y - h(x) - H (xi0 - x)
            inn[a, 0] = y[a] - h[a]
        solve_spd(cholesky_into(Sy, L), inn, sol)
        d2 = 0.0
        for a in range(nr):
            d2 += inn[a, 0] * sol[a, 0]
        gate = GATE_2 if nr == 2 else GATE_5
        if d2 > gate:
            Rn *= d2 / gate
            hpht_plus(HP, H, Rn, Sy)
            cholesky_into(Sy, L)                               # else the factor serves both solves
        solve_spd(L, HP, Y)
        for i in range(3):                                     # x = xi + K r
            acc = 0.0
            for a in range(nr):
                acc += Y[a, i] * r[a, 0]
            x[i] = xi[i] + acc
    for i in range(3):
        if not math.isfinite(x[i]):
            return xi, P, 2
    # Joseph form (I - K H) P (I - K H)^T + K Rn K^T with K = Y^T, symmetrised; each sum in
    # matmul_into's order, into arrays made once
    K = np.ascontiguousarray(Y.T)
    I_KH = matmul_into(K, H, np.empty((3, 3)))
    for i in range(3):
        for j in range(3):
            I_KH[i, j] = (1.0 if i == j else 0.0) - I_KH[i, j]
    T = matmul_into(I_KH, P, np.empty((3, 3)))
    KR = matmul_into(K, Rn, np.empty((3, nr)))
    P_new = abt_plus_cdt_into(T, I_KH, KR, K, np.empty((3, 3)))
    P_sym = np.empty((3, 3))
    for i in range(3):
        for j in range(3):
            P_sym[i, j] = 0.5 * (P_new[i, j] + P_new[j, i])
    return x, P_sym, 0


def arc_rows(s0: float, s1: float, centroids: np.ndarray, shapes: np.ndarray):
    """The visible arcs of the landmarks with ``centroids (N, 2)`` and shapes ``shapes (N, 2, 2)``
    seen from ``s = (s0, s1)`` (a.12.4): the predicted detection means ``mu = p + g`` ``(N, 2)``,
    ``B = I - G`` ``(N, 2, 2)`` and the arcs' spreads ``S`` ``(N, 2, 2)``. A kernel."""
    n = centroids.shape[0]
    mu = np.empty((n, 2))
    B = np.empty((n, 2, 2))
    S = np.empty((n, 2, 2))
    for a in range(n):
        px = centroids[a, 0]
        py = centroids[a, 1]
        r = arc_moments(s0 - px, s1 - py, shapes[a, 0, 0], shapes[a, 0, 1], shapes[a, 1, 1])
        put_arc_row(mu[a], B[a], S[a], px, py, r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8])
    return mu, B, S


def put_arc_row(mu: np.ndarray, B: np.ndarray, S: np.ndarray, px: float, py: float, g0: float, g1: float, G00: float,
                G01: float, G10: float, G11: float, S00: float, S01: float, S11: float) -> None:
    """One landmark's ``mu = p + g`` ``(2,)``, ``B = I - G`` and ``S`` ``(2, 2)`` in place (a.12.4). A kernel."""
    mu[0] = px + g0
    mu[1] = py + g1
    B[0, 0] = 1.0 - G00
    B[0, 1] = -G01
    B[1, 0] = -G10
    B[1, 1] = 1.0 - G11
    S[0, 0] = S00
    S[0, 1] = S01
    S[1, 0] = S01
    S[1, 1] = S11


def sift_spreads(B: np.ndarray, S: np.ndarray, centroid_covs: np.ndarray, Qv: np.ndarray):
    """The sifting test's spreads ``S + Q_v`` and the means' covariances ``B P_pp B^T`` (a.12.5),
    ``(N, 2, 2)`` each, of :func:`arc_rows`' ``B`` and ``S``. A kernel."""
    n = B.shape[0]
    spread = np.empty((n, 2, 2))
    cov = np.empty((n, 2, 2))
    for a in range(n):
        C = centroid_covs[a]
        for i in range(2):
            t0 = B[a, i, 0] * C[0, 0] + B[a, i, 1] * C[1, 0]
            t1 = B[a, i, 0] * C[0, 1] + B[a, i, 1] * C[1, 1]
            for j in range(2):
                spread[a, i, j] = S[a, i, j] + Qv[i, j]
                cov[a, i, j] = t0 * B[a, j, 0] + t1 * B[a, j, 1]
    return spread, cov


def view_scan_data(polar: np.ndarray, pts: np.ndarray, theta: float, c0: float, c1: float, R: np.ndarray):
    """What one scan's ``m >= 1`` detections of a landmark tell its shape (a.12.7): the
    measurement ``y (5,)`` (the sample mean minus the centroid ``(c0, c1)``, then the entries 00,
    01, 11 of the sample covariance when ``m >= 3``, else zeros) and the detections' mean sensor
    noise in the world frame ``Ws (2, 2)`` (seed eq. 5 without the pose's part: ``J R J^T``, ``J``
    the Jacobian of the detection at heading ``theta``), averaged. A kernel."""
    m = pts.shape[0]
    y = np.zeros(5)
    Ws = np.zeros((2, 2))
    r00, r01, r10, r11 = R[0, 0], R[0, 1], R[1, 0], R[1, 1]
    for k in range(m):
        a = theta + polar[k, 1]
        c = math.cos(a)
        s = math.sin(a)
        r = polar[k, 0]
        j00, j01, j10, j11 = c, -r * s, s, r * c
        t00 = j00 * r00 + j01 * r10
        t01 = j00 * r01 + j01 * r11
        t10 = j10 * r00 + j11 * r10
        t11 = j10 * r01 + j11 * r11
        Ws[0, 0] += t00 * j00 + t01 * j01
        Ws[0, 1] += t00 * j10 + t01 * j11
        Ws[1, 0] += t10 * j00 + t11 * j01
        Ws[1, 1] += t10 * j10 + t11 * j11
    for i in range(2):
        for j in range(2):
            Ws[i, j] = Ws[i, j] / m
    s0 = 0.0
    s1 = 0.0
    for k in range(m):
        s0 += pts[k, 0]
        s1 += pts[k, 1]
    m0 = s0 / m
    m1 = s1 / m
    y[0] = m0 - c0
    y[1] = m1 - c1
    if m >= 3:
        a00 = a01 = a11 = 0.0
        for k in range(m):
            u = pts[k, 0] - m0
            v = pts[k, 1] - m1
            a00 += u * u
            a01 += u * v
            a11 += v * v
        f = 1.0 / (m - 1)
        y[2] = a00 * f
        y[3] = a01 * f
        y[4] = a11 * f
    return y, Ws


def view_rows(E, N, old, aoff, arow, polar, xy, cents, ccovs, pose, R, Q, qv2, rel, spread_only, shape_step):
    """The partial view's part of the extent step (a.12.7) for every landmark ``j < N`` of the
    array-held states ``E`` (:mod:`radarslam.extent.rows`): the shape's random walk ``P_xi += Q``,
    then with this scan's detections the iterated update (:func:`view_update`) about the centroid
    ``cents[j]`` (covariance ``ccovs[j]``) seen from the updated ``pose``; kept, and counted, when it
    succeeds. In place. A kernel: the fused engine and :class:`PartialViewEstimator` alike."""
    for j in range(N):
        Pn = E.Pxi[j]
        for a in range(3):
            for b in range(3):
                Pn[a, b] += Q[a, b]
        o = old[j]
        m = aoff[o + 1] - aoff[o]
        if m == 0:
            continue
        y, Ws = view_scan_data(detections(polar, aoff, arow, o), detections(xy, aoff, arow, o), pose[2], cents[j, 0],
                               cents[j, 1], R)
        xi, Pu, status = view_update(E.xi[j], Pn, pose[0] - cents[j, 0], pose[1] - cents[j, 1], y, m, Ws, ccovs[j],
                                     qv2, rel, spread_only, shape_step)
        if status == 0:
            E.xi[j] = xi
            E.Pxi[j] = Pu
            E.nview[j] += 1


#: The kernels of this module, compiled with the arc kernels (extent/_compiled.py).
KERNELS = (exp_sym2, predicted_rows, *small_matrices.KERNELS, rows_and_jacobian, view_update, arc_rows, put_arc_row,
           sift_spreads, view_scan_data, detections, view_rows)
