"""EKF-SLAM maths on the augmented state ``x = [x, y, theta, p1x, p1y, ..., pNx, pNy]``.

Pure functions: every function returns new arrays and leaves its inputs untouched. Landmark ``j``
(0-based) occupies ``x[i : i + 2]`` with ``i = landmark_index(j, platform)`` (:mod:`.layout`), where
``platform`` is the size of the platform block at the head of the state: 3 (the pose, the default)
or 3 plus the odometry-bias states (docs/method.md c.11), which no measurement depends on. The
heading is kept in ``[0, 2 pi)`` (docs/method.md a.1).

One source for each kernel: :func:`sparse_jacobian` (the range-azimuth measurement Jacobian),
:func:`r_eff` (the extent-inflated noise), :func:`joseph_update` (the Joseph update),
:func:`innovation_cov_terms` and :func:`gaussian_log_distance` (the log distance) and the angle wraps
of :mod:`radarslam.core.angles` are plain functions in a subset of Python and numpy that numba
compiles as they are: the compiled associator (:mod:`radarslam.slam._numba`) runs these very
functions, not copies of them.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_2pi_scalar, wrap_pi_scalar
from radarslam.models.motion import MotionModel
from radarslam.models.radar import inverse_jacobians
from radarslam.slam.layout import POSE_DIM, landmark_index

LOG_2PI_SQ = 2.0 * math.log(2.0 * math.pi)  # log((2 pi)^2)


def predict(x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, model: MotionModel,
            U: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction with the odometer reading ``u`` (APSIPA App. A; docs/method.md c.2).

    Landmarks are static, so only the pose block and the pose rows/columns change:
    ``P_pp <- Fx P_pp Fx^T + Fu U Fu^T + Q`` and ``P_pl <- Fx P_pl``. Returns new arrays; the
    filter applies :func:`predict_terms` in place instead, which costs O(N) rather than a copy of P.
    """
    pose, Ppp, Ppl = predict_terms(x, P, u, dt, model, U, Q)
    x_new, P_new = x.copy(), P.copy()
    apply_prediction(x_new, P_new, pose, Ppp, Ppl)
    return x_new, P_new


def predict_terms(x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, model: MotionModel,
                  U: np.ndarray, Q: np.ndarray, pose_first: np.ndarray | None = None,
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the prediction changes: the new pose ``(3,)``, pose block ``(3, 3)`` and pose-landmark
    block ``(3, n - 3)`` (c.2), computed without touching ``x`` or ``P``. With ``pose_first``
    (3,), the first estimate of the current pose (the previous prediction's), ``F_x`` is the
    first-estimates Jacobian of :func:`fej_motion_jacobian` (docs/method.md c.2.1)."""
    Fx, Fu = model.jacobians(x[:3], u, dt)
    pose = model.step(x[:3], u, dt)
    if pose_first is not None:
        Fx = fej_motion_jacobian(Fx, pose, pose_first)
    Ppp = Fx @ P[:3, :3] @ Fx.T + Fu @ U @ Fu.T + Q
    Ppl = Fx @ P[:3, 3:]
    return pose, Ppp, Ppl


def interval_noise(U: np.ndarray, Q: np.ndarray, dt: float, ref: float) -> tuple[np.ndarray, np.ndarray]:
    """U and Q of one odometry reading over ``dt`` (s) when they are quoted for a reading over
    ``ref`` (docs/method.md c.2.2): the reading's error is the mean of a white input noise over its
    interval, ``U ref / dt``, and the process noise is a density, ``Q dt / ref``; so ``Fu U Fu^T + Q``
    grows with time, not with the rate. The arrays themselves when ``dt`` is ``ref`` within 1 ns
    (a clock's rounding: the profiles' own rates then run bit for bit as before)."""
    if abs(dt - ref) <= 1e-9:
        return U, Q
    return U * (ref / dt), Q * (dt / ref)


def fej_motion_jacobian(Fx: np.ndarray, pose_new: np.ndarray, pose_first: np.ndarray) -> np.ndarray:
    """The first-estimates pose Jacobian (docs/method.md c.2.1; Huang, Mourikis & Roumeliotis 2008).

    For a model whose position moves by an increment that does not depend on the position (the
    unicycle, Ackermann and body-velocity models, ``se2_increment``: ``F_x`` has the heading column
    ``(-dy, dx, 1)`` with ``(dx, dy) = t_{k+1} - t_k`` in m), the column is taken
    between the new prediction ``pose_new`` (3,) and the *first* estimate of the current pose,
    ``pose_first`` (3,), the previous prediction, instead of the updated estimate. Products of
    these Jacobians then telescope, ``F_{k+l-1} ... F_k = [[I, J (t_{k+l} - t_k)], [0, 1]]``,
    which keeps the unobservable global rotation unobservable. Returns a new ``(3, 3)`` array. A
    kernel (the fused engine compiles it as it is)."""
    F = np.asarray(Fx, dtype=np.float64).copy()
    F[0, 2] = -(pose_new[1] - pose_first[1])
    F[1, 2] = pose_new[0] - pose_first[0]
    return F


def apply_prediction(x: np.ndarray, P: np.ndarray, pose: np.ndarray, Ppp: np.ndarray, Ppl: np.ndarray) -> None:
    """Write the terms of :func:`predict_terms` into ``x`` and ``P`` (in place): the platform block
    ``pose`` (p,) (the pose, or the pose and the bias states of c.11), its covariance ``Ppp``
    (p, p) and its cross-covariance with the landmarks ``Ppl`` (p, n - p)."""
    p = pose.shape[0]
    x[:p] = pose
    P[:p, :p] = Ppp
    if P.shape[0] > p:
        P[:p, p:] = Ppl
        P[p:, :p] = Ppl.T


def landmark_measurement(x: np.ndarray, j: int, platform: int = POSE_DIM) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Predicted measurement of landmark ``j`` and its sparse Jacobian (APSIPA eq. 8, App. B).

    Returns
    -------
    h : ndarray, shape (2,)
        ``[range, azimuth]``, azimuth in (-pi, pi].
    Hs : ndarray, shape (2, 5)
        Non-zero columns of H: the pose ``(x, y, theta)`` then the landmark ``(px, py)``.
    idx : ndarray, shape (5,)
        The state indices of those columns.
    """
    i = landmark_index(j, platform)
    dx, dy = x[i] - x[0], x[i + 1] - x[1]
    h = np.array([math.sqrt(dx * dx + dy * dy), wrap_pi_scalar(math.atan2(dy, dx) - x[2])])
    Hs, idx = sparse_jacobian(x, j, platform)
    return h, Hs, idx


def innovation(z: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``z - h`` with the azimuth residual wrapped to (-pi, pi] (docs/method.md c.4)."""
    return np.array([z[0] - h[0], wrap_pi_scalar(z[1] - h[1])])


def innovation_cov(P: np.ndarray, Hs: np.ndarray, idx: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``S = H P H^T + R`` using only the 5 x 5 block of P that the sparse H touches."""
    return Hs @ P[np.ix_(idx, idx)] @ Hs.T + R


def log_distance(e: np.ndarray, S: np.ndarray) -> float:
    """APSIPA eq. (9): ``-log N(e; 0, S) = e^T S^-1 e / 2 + log((2 pi)^2 |S|) / 2`` for 2-D ``e``."""
    return gaussian_log_distance(float(S[0, 0]), float(S[0, 1]), float(S[1, 1]), float(e[0]), float(e[1]))


def update(x: np.ndarray, P: np.ndarray, e: np.ndarray, Hs: np.ndarray, idx: np.ndarray,
           R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF update with a sparse measurement Jacobian, Joseph form (docs/method.md c.4):
    :func:`joseph_update` without the NIS."""
    x_new, P_new, _ = joseph_update(x, P, e, Hs, idx, R)
    return x_new, P_new


def joseph_update(x: np.ndarray, P: np.ndarray, e: np.ndarray, Hs: np.ndarray, idx: np.ndarray,
                  R: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """:func:`joseph_update_inplace` on copies: ``(x_new, P_new, nis)``, the inputs untouched."""
    x_new, P_new = x.copy(), P.copy()
    nis = joseph_update_inplace(x_new, P_new, e, Hs, idx, R)
    return x_new, P_new, nis


def joseph_update_inplace(x: np.ndarray, P: np.ndarray, e: np.ndarray, Hs: np.ndarray, idx: np.ndarray,
                          R: np.ndarray) -> float:
    """EKF update with a sparse measurement Jacobian, Joseph form, in place; returns the update's NIS.

    ``K = P H^T S^-1``, ``x <- x + K e`` and the Joseph form
    ``P <- (I - K H) P (I - K H)^T + K R K^T``, which for any gain K expands to
    ``P - T - T^T + K S K^T`` with ``T = K (P H^T)^T`` and ``S = H P H^T + R``. With H non-zero
    on the 5 columns ``idx`` everything but the final n x n pass (:func:`joseph_apply`) is O(n).
    The normalised innovation squared ``e^T S^-1 e`` (chi-square with 2 degrees of freedom for a
    consistent filter) comes with it. A kernel (numba compiles it).
    """
    PHt = P[:, idx] @ Hs.T                                  # (n, 2)
    S = Hs @ PHt[idx] + R                                   # H P H^T + R
    a, b, d = S[0, 0], 0.5 * (S[0, 1] + S[1, 0]), S[1, 1]
    det = a * d - b * b
    K = PHt @ np.array([[d, -b], [-b, a]]) / det           # P H^T S^-1
    x += K @ e
    x[2] = wrap_2pi_scalar(x[2])
    # K S K^T = (K L)(K L)^T for S = L L^T (2 x 2 Cholesky): every term is symmetric bit for bit.
    l00 = math.sqrt(a)
    l10 = b / l00
    KL = K @ np.array([[l00, 0.0], [l10, math.sqrt(d - l10 * l10)]])
    joseph_apply(P, K, PHt, KL)
    return (d * e[0] * e[0] - 2.0 * b * e[0] * e[1] + a * e[1] * e[1]) / det


def joint_update_inplace(x: np.ndarray, P: np.ndarray, e: np.ndarray, H: np.ndarray, R: np.ndarray) -> np.ndarray:
    """One EKF update with q stacked measurements (docs/method.md a.7.4), in place; returns the
    whitened innovation's squares summed in pairs (q/2 values, each chi-square with 2 degrees of
    freedom for a consistent filter; their sum is the update's NIS).

    ``S = H P H^T + R = L L^T`` (Cholesky), ``B = P H^T L^-T``, ``w = L^-1 e``; then
    ``x <- x + B w`` (``K e`` with ``K = P H^T S^-1 = B L^-1``) and ``P <- P - B B^T``
    (``K S K^T``, the Joseph form's value for this optimal gain, as one rank-q term). ``H`` is
    dense ``(q, n)`` here, the reference; :func:`radarslam.slam._numba.joint_update_loops` is the
    compiled form on the sparse blocks.
    """
    from scipy.linalg import solve_triangular

    PHt = P @ H.T                                            # (n, q)
    S = H @ PHt + R
    L = np.linalg.cholesky(0.5 * (S + S.T))
    B = solve_triangular(L, PHt.T, lower=True).T             # P H^T L^-T
    w = solve_triangular(L, e, lower=True)
    x += B @ w
    x[2] = wrap_2pi_scalar(x[2])
    BBt = B @ B.T
    P -= np.triu(BBt) + np.triu(BBt, 1).T                    # exactly symmetric
    return (w * w).reshape(-1, 2).sum(axis=1)


def joseph_apply(P: np.ndarray, K: np.ndarray, PHt: np.ndarray, KL: np.ndarray) -> None:
    """The n x n part of the Joseph update, in place: ``P <- P - (T + T^T) + KL KL^T``,
    ``T = K PHt^T`` (:func:`joseph_update_inplace`). The compiled backend replaces it by one fused
    loop over P (:func:`radarslam.slam._numba.joseph_apply_loops`); both are exactly symmetric."""
    T = K @ PHt.T
    P -= T + T.T
    P += KL @ KL.T


def score_landmarks(x: np.ndarray, P: np.ndarray, z: np.ndarray, js: list[int], R: np.ndarray,
                    gX: list | None = None, xs: list[float] | None = None,
                    platform: int = POSE_DIM) -> tuple[int, float, tuple[float, float]]:
    """Smallest log distance (APSIPA eq. 9) of detection ``z`` over the landmarks ``js``.

    The hot path of association, on plain floats (numpy's per-call overhead dominates 2 x 2 work).
    It is :func:`landmark_measurement` + :func:`innovation` + :func:`innovation_cov` +
    :func:`log_distance` per landmark (tested equal), rewritten on the relative vector
    ``delta = p - [x, y]``: with ``g1 = [dx, dy] / r``, ``g2 = [-dy, dx] / r^2``,
    ``C = cov(delta)`` and ``c = cov(delta, theta)``,

        S = [[g1 C g1', g1 C g2' - g1.c], [., g2 C g2' - 2 g2.c + P_tt]] + R_j,

    with ``R_j = R + g (gamma_z X_j) g'`` (docs/method.md a.7.2) where ``gX[k]`` is ``gamma_z X_j``.
    ``xs`` may pass ``x.tolist()`` when the caller already has it; ``platform`` is the size of the
    state's platform block (:mod:`.layout`).

    Returns
    -------
    j : int
        The landmark of smallest log distance (-1 if ``js`` is empty).
    D : float
    e : tuple of float
        Its innovation ``[range, wrapped azimuth]``.
    """
    best_j, best_D, best_e = -1, math.inf, (0.0, 0.0)
    if not js:
        return best_j, best_D, best_e
    # One flat gather of the 9 entries each landmark needs (its rows at the pose columns and its
    # own 2 x 2 block) and the 6 of the pose block: a whole-row copy costs more than the maths.
    n = P.shape[0]
    flat = [0, 1, 2, n + 1, n + 2, 2 * n + 2]
    for j in js:
        i = landmark_index(j, platform)
        flat += [i * n, i * n + 1, i * n + 2, i * n + i, i * n + i + 1,
                 (i + 1) * n, (i + 1) * n + 1, (i + 1) * n + 2, (i + 1) * n + i + 1]
    v = P.take(flat).tolist()
    pxx, pxy, pxt, pyy, pyt, ptt = v[:6]
    xs = x.tolist() if xs is None else xs
    x0, y0, th = xs[0], xs[1], xs[2]
    r00, r01, r11 = R[0, 0], R[0, 1], R[1, 1]
    z0, z1 = float(z[0]), float(z[1])
    for k, j in enumerate(js):
        i = landmark_index(j, platform)
        lx0, lx1, lx2, lxx, lxy, ly0, ly1, ly2, lyy = v[6 + 9 * k: 15 + 9 * k]
        # cov(delta) and cov(delta, theta)
        cxx = lxx - 2.0 * lx0 + pxx
        cxy = lxy - lx1 - ly0 + pxy
        cyy = lyy - 2.0 * ly1 + pyy
        ctx = lx2 - pxt
        cty = ly2 - pyt
        dx = xs[i] - x0
        dy = xs[i + 1] - y0
        if dx == 0.0 and dy == 0.0:
            continue  # a landmark at the sensor itself has no bearing: it cannot be scored
        if gX is not None and gX[k] is not None:
            (g00, g01), (_, g11) = gX[k]
            s00, s01, s11, r = innovation_cov_terms(cxx, cxy, cyy, ctx, cty, ptt, dx, dy, r00, r01, r11,
                                                    True, g00, g01, g11)
        else:
            s00, s01, s11, r = innovation_cov_terms(cxx, cxy, cyy, ctx, cty, ptt, dx, dy, r00, r01, r11,
                                                    False, 0.0, 0.0, 0.0)
        e0 = z0 - r
        e1 = wrap_pi_scalar(z1 - (math.atan2(dy, dx) - th))
        D = gaussian_log_distance(s00, s01, s11, e0, e1)
        if D < best_D:
            best_j, best_D, best_e = j, D, (e0, e1)
    return best_j, best_D, best_e


def innovation_cov_terms(cxx, cxy, cyy, ctx, cty, ptt, dx, dy, r00, r01, r11, has_g, g00, g01, g11):
    """Scalar kernel of :func:`score_landmarks`: ``(S00, S01, S11, r)`` of one landmark.

    ``c..`` are ``cov(delta)`` and ``cov(delta, theta)``, ``ptt`` the heading variance, ``(dx, dy)``
    the landmark relative to the pose, ``r..`` the entries of R and, when ``has_g``, ``g..`` those
    of ``gamma_z X_j`` (docs/method.md a.7.2). Plain floats, so the numba backend compiles this very
    function (:mod:`radarslam.slam._numba`).
    """
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    a1, b1 = dx / r, dy / r
    a2, b2 = -dy / q, dx / q
    Ca1 = cxx * a1 + cxy * b1
    Cb1 = cxy * a1 + cyy * b1
    s00 = a1 * Ca1 + b1 * Cb1 + r00
    s01 = a2 * Ca1 + b2 * Cb1 - (a1 * ctx + b1 * cty) + r01
    s11 = (a2 * (cxx * a2 + cxy * b2) + b2 * (cxy * a2 + cyy * b2)
           - 2.0 * (a2 * ctx + b2 * cty) + ptt + r11)
    if has_g:
        s00 += a1 * (g00 * a1 + g01 * b1) + b1 * (g01 * a1 + g11 * b1)
        s01 += a2 * (g00 * a1 + g01 * b1) + b2 * (g01 * a1 + g11 * b1)
        s11 += a2 * (g00 * a2 + g01 * b2) + b2 * (g01 * a2 + g11 * b2)
    return s00, s01, s11, r


def gaussian_log_distance(s00, s01, s11, e0, e1):
    """APSIPA eq. (9) on scalars: ``S = [[s00, s01], [s01, s11]]``, ``e = [e0, e1]``; ``inf`` unless
    ``S`` is positive definite."""
    det = s00 * s11 - s01 * s01
    if det <= 0.0:
        return math.inf
    return 0.5 * (s11 * e0 * e0 - 2.0 * s01 * e0 * e1 + s00 * e1 * e1) / det + 0.5 * (LOG_2PI_SQ + math.log(det))


def sparse_jacobian(x: np.ndarray, j: int, platform: int = POSE_DIM) -> tuple[np.ndarray, np.ndarray]:
    """``(Hs (2, 5), idx (5,))`` of landmark ``j`` (APSIPA App. B): the non-zero columns of the
    range-azimuth Jacobian, pose ``(x, y, theta)`` then landmark ``(px, py)``, and their state indices
    (after a platform block of ``platform`` entries). A kernel (numba compiles it as it is)."""
    i = landmark_index(j, platform)
    dx, dy = x[i] - x[0], x[i + 1] - x[1]
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    return (np.array([[-dx / r, -dy / r, 0.0, dx / r, dy / r], [dy / q, -dx / q, -1.0, -dy / q, dx / q]]),
            np.array([0, 1, 2, i, i + 1]))


def sensor_xy_measurement(x: np.ndarray, j: int, platform: int = POSE_DIM) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Landmark ``j`` in the sensor's Cartesian frame, ``h = Rot(-theta) (p - t)``, with its sparse
    Jacobian ``(Hs (2, 5), idx (5,))`` over ``(x, y, theta, px, py)`` (docs/method.md a.7.3): the
    measurement of the per-landmark batch update (``platform``: as :func:`sparse_jacobian`)."""
    i = landmark_index(j, platform)
    dx, dy = x[i] - x[0], x[i + 1] - x[1]
    c, s = math.cos(x[2]), math.sin(x[2])
    h0 = c * dx + s * dy
    h1 = -s * dx + c * dy
    Hs = np.array([[-c, -s, h1, c, s], [s, -c, -h0, -s, c]])
    return np.array([h0, h1]), Hs, np.array([0, 1, 2, i, i + 1])


def polar_to_sensor_xy(polar: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Detections ``(m, 2)`` of ``[r, phi]`` as sensor-frame points ``(m, 2)`` and the mean of their
    noise covariances ``J_i R J_i^T``, ``J_i = [[c, -r s], [s, r c]]`` the Jacobian of
    ``(r cos phi, r sin phi)``. A kernel (numba compiles it)."""
    r, phi = polar[:, 0], polar[:, 1]
    c, s = np.cos(phi), np.sin(phi)
    pts = np.empty((polar.shape[0], 2))
    pts[:, 0] = r * c
    pts[:, 1] = r * s
    a, b, d = R[0, 0], R[0, 1], R[1, 1]
    w00 = (c * c * a - 2.0 * r * c * s * b + r * r * s * s * d).mean()
    w01 = (c * s * a + r * (c * c - s * s) * b - r * r * s * c * d).mean()
    w11 = (s * s * a + 2.0 * r * s * c * b + r * r * c * c * d).mean()
    return pts, np.array([[w00, w01], [w01, w11]])


def rotate_to_sensor(theta: float, C: np.ndarray) -> np.ndarray:
    """A world-frame covariance ``C (2, 2)`` expressed in the frame of a sensor with heading ``theta``."""
    c, s = math.cos(theta), math.sin(theta)
    Rt = np.array([[c, s], [-s, c]])
    return Rt @ C @ Rt.T


def batch_noise(theta: float, gX_j: np.ndarray, has_j: bool, R_xy: np.ndarray, m: int,
                offset_k: float = 0.0) -> np.ndarray:
    """Covariance ``(2, 2)`` of the sensor-frame mean of ``m`` detections about a landmark's
    predicted centroid (docs/method.md a.7.3 part 3): ``(Rot(-theta) gamma_z X Rot(-theta)^T + R_xy) / m``,
    the spread term only where ``has_j``; ``R_xy`` is the detections' mean sensor noise. With
    ``offset_k`` > 0 the part in view may be centred anywhere on the object (c.17): ``offset_k``
    times the spread is added once, not divided by ``m`` (``offset_k = 1 / (4 gamma_z)`` gives X/4,
    a point uniform over the ellipse). A kernel."""
    noise = R_xy.copy()
    if has_j:
        S = rotate_to_sensor(theta, gX_j)
        noise += S
        if offset_k != 0.0:
            return noise / m + offset_k * S
    return noise / m


def r_eff(R: np.ndarray, Hs: np.ndarray, spread: np.ndarray) -> np.ndarray:
    """Extent-inflated noise ``R_eff = R + H_p (gamma_z X) H_p^T`` (docs/method.md a.7.2).

    ``Hs`` is the sparse Jacobian of :func:`sparse_jacobian` (its last two columns are ``H_p``) and
    ``spread`` the landmark's ``gamma_z X``. A kernel (numba compiles it as it is)."""
    Hp = np.ascontiguousarray(Hs[:, 3:])
    return R + Hp @ spread @ Hp.T


def augment(x: np.ndarray, P: np.ndarray, s: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Append a landmark initialised from detection ``s = [r, phi]`` (APSIPA eqs. 10-11, App. C).

    ``p = [x + r cos(theta + phi), y + r sin(theta + phi)]``,
    ``P_aug = J1 P J1^T + J2 R J2^T`` with ``J1 = [I; Gx 0]`` and ``J2 = [0; Gs]``. A kernel.
    """
    Gx, Gs = inverse_jacobians(x[:3], s)
    a = x[2] + s[1]
    p = np.array([x[0] + s[0] * math.cos(a), x[1] + s[0] * math.sin(a)])
    return augment_point(x, P, p, Gx, Gs @ R @ Gs.T)


def augment_mean(x: np.ndarray, P: np.ndarray, polar: np.ndarray, R: np.ndarray,
                 spread: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Append a landmark at the mean of detections ``polar (m, 2)`` (docs/method.md c.8, [PROP]).

    The mean in the sensor frame ``zbar`` has the noise ``mean_i J_i R J_i^T / m``; the landmark
    ``p = t + Rot(theta) zbar`` gets ``Gx P_pose Gx^T + Rot(theta) (that) Rot(theta)^T + spread``,
    where ``spread`` (world frame) bounds how far the centroid may be from the mean of what was seen
    (the prior extent's ``gamma_z X0``).
    """
    pts, R_xy = polar_to_sensor_xy(polar, R)
    zbar = pts.mean(axis=0)
    c, s = math.cos(x[2]), math.sin(x[2])
    rot = np.array([[c, -s], [s, c]])
    p = x[:2] + rot @ zbar
    Gx = np.array([[1.0, 0.0, x[1] - p[1]], [0.0, 1.0, p[0] - x[0]]])
    C = rot @ (R_xy / polar.shape[0]) @ rot.T
    if spread is not None:
        C = C + spread
    return augment_point(x, P, p, Gx, C)


def augment_point(x: np.ndarray, P: np.ndarray, p: np.ndarray, Gx: np.ndarray,
                  C: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Append landmark ``p`` whose position depends on the pose through ``Gx (2, 3)`` and carries its
    own covariance ``C (2, 2)``: ``P_pp = Gx P_pose Gx^T + C``, ``P_p* = Gx P_pose,*``. A kernel
    (the fused engine compiles it as it is)."""
    n = x.shape[0]
    x_new = np.concatenate((x, p))
    P_new = np.empty((n + 2, n + 2))
    P_new[:n, :n] = P
    cross = Gx @ np.ascontiguousarray(P[:3, :])              # (2, n)
    P_new[n:, :n] = cross
    P_new[:n, n:] = cross.T
    P_new[n:, n:] = Gx @ np.ascontiguousarray(P[:3, :3]) @ Gx.T + C
    return x_new, P_new


def remove_landmarks(x: np.ndarray, P: np.ndarray, js: list[int] | np.ndarray,
                     platform: int = POSE_DIM) -> tuple[np.ndarray, np.ndarray]:
    """Delete landmarks ``js`` (their 2 rows and 2 columns each) from the state."""
    if len(js) == 0:
        return x.copy(), P.copy()
    drop = np.concatenate([[landmark_index(j, platform), landmark_index(j, platform) + 1] for j in js])
    keep = np.setdiff1d(np.arange(x.shape[0]), drop)
    return x[keep], P[np.ix_(keep, keep)]
