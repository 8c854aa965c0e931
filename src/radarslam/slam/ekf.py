"""EKF-SLAM maths on the augmented state ``x = [x, y, theta, p1x, p1y, ..., pNx, pNy]``.

Pure functions: every function returns new arrays and leaves its inputs untouched. Landmark ``j``
(0-based) occupies ``x[3 + 2j : 5 + 2j]``. The heading is kept in ``[0, 2 pi)`` (method.md a.1).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_2pi_scalar, wrap_pi_scalar
from radarslam.models.motion import MotionModel
from radarslam.models.radar import inverse_jacobians

LOG_2PI_SQ = 2.0 * math.log(2.0 * math.pi)  # log((2 pi)^2)


def n_landmarks(x: np.ndarray) -> int:
    """Number of landmarks in the state vector."""
    return (x.shape[0] - 3) // 2


def predict(x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, model: MotionModel,
            U: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF prediction with the odometer reading ``u`` (APSIPA App. A; method.md c.2).

    Landmarks are static, so only the pose block and the pose rows/columns change:
    ``P_pp <- Fx P_pp Fx^T + Fu U Fu^T + Q`` and ``P_pl <- Fx P_pl``. Cost O(N).
    """
    Fx, Fu = model.jacobians(x[:3], u, dt)
    x_new = x.copy()
    x_new[:3] = model.step(x[:3], u, dt)
    P_new = P.copy()
    P_new[:3, :3] = Fx @ P[:3, :3] @ Fx.T + Fu @ U @ Fu.T + Q
    if P.shape[0] > 3:
        P_new[:3, 3:] = Fx @ P[:3, 3:]
        P_new[3:, :3] = P_new[:3, 3:].T
    return x_new, P_new


def landmark_measurement(x: np.ndarray, j: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    i = 3 + 2 * j
    dx, dy = x[i] - x[0], x[i + 1] - x[1]
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    h = np.array([r, wrap_pi_scalar(math.atan2(dy, dx) - x[2])])
    Hs = np.array([[-dx / r, -dy / r, 0.0, dx / r, dy / r],
                   [dy / q, -dx / q, -1.0, -dy / q, dx / q]])
    return h, Hs, np.array([0, 1, 2, i, i + 1])


def innovation(z: np.ndarray, h: np.ndarray) -> np.ndarray:
    """``z - h`` with the azimuth residual wrapped to (-pi, pi] (method.md c.4)."""
    return np.array([z[0] - h[0], wrap_pi_scalar(z[1] - h[1])])


def innovation_cov(P: np.ndarray, Hs: np.ndarray, idx: np.ndarray, R: np.ndarray) -> np.ndarray:
    """``S = H P H^T + R`` using only the 5 x 5 block of P that the sparse H touches."""
    return Hs @ P[np.ix_(idx, idx)] @ Hs.T + R


def log_distance(e: np.ndarray, S: np.ndarray) -> float:
    """APSIPA eq. (9): ``-log N(e; 0, S) = e^T S^-1 e / 2 + log((2 pi)^2 |S|) / 2`` for 2-D ``e``."""
    a, b, d = S[0, 0], S[0, 1], S[1, 1]
    det = a * d - b * b
    if det <= 0.0:
        return math.inf
    maha = (d * e[0] * e[0] - 2.0 * b * e[0] * e[1] + a * e[1] * e[1]) / det
    return 0.5 * maha + 0.5 * (LOG_2PI_SQ + math.log(det))


def update(x: np.ndarray, P: np.ndarray, e: np.ndarray, Hs: np.ndarray, idx: np.ndarray,
           R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF update with a sparse measurement Jacobian, Joseph form (method.md c.4).

    ``K = P H^T S^-1``, ``x <- x + K e``,
    ``P <- (I - K H) P (I - K H)^T + K R K^T``; with H non-zero on the 5 columns ``idx`` every
    product is O(N^2), so the stable Joseph form costs no more than ``P - K S K^T``.
    """
    PHt = P[:, idx] @ Hs.T                                  # (n, 2)
    S = Hs @ PHt[idx] + R                                   # H P H^T + R
    K = np.linalg.solve(S, PHt.T).T                         # P H^T S^-1 (S symmetric)
    x_new = x + K @ e
    x_new[2] = wrap_2pi_scalar(x_new[2])
    A = P - K @ PHt.T                                       # (I - K H) P, since H P = PHt^T
    P_new = A - (A[:, idx] @ Hs.T) @ K.T + K @ R @ K.T      # A (I - K H)^T + K R K^T
    P_new = 0.5 * (P_new + P_new.T)
    return x_new, P_new


def augment(x: np.ndarray, P: np.ndarray, s: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Append a landmark initialised from detection ``s = [r, phi]`` (APSIPA eqs. 10-11, App. C).

    ``p = [x + r cos(theta + phi), y + r sin(theta + phi)]``,
    ``P_aug = J1 P J1^T + J2 R J2^T`` with ``J1 = [I; Gx 0]`` and ``J2 = [0; Gs]``.
    """
    Gx, Gs = inverse_jacobians(x[:3], s)
    a = x[2] + s[1]
    p = np.array([x[0] + s[0] * math.cos(a), x[1] + s[0] * math.sin(a)])
    n = x.shape[0]
    x_new = np.concatenate([x, p])
    P_new = np.empty((n + 2, n + 2))
    P_new[:n, :n] = P
    cross = Gx @ P[:3, :]                                    # (2, n)
    P_new[n:, :n] = cross
    P_new[:n, n:] = cross.T
    P_new[n:, n:] = Gx @ P[:3, :3] @ Gx.T + Gs @ R @ Gs.T
    return x_new, P_new


def remove_landmarks(x: np.ndarray, P: np.ndarray, js: list[int] | np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Delete landmarks ``js`` (their 2 rows and 2 columns each) from the state."""
    if len(js) == 0:
        return x.copy(), P.copy()
    drop = np.concatenate([[3 + 2 * j, 4 + 2 * j] for j in js])
    keep = np.setdiff1d(np.arange(x.shape[0]), drop)
    return x[keep], P[np.ix_(keep, keep)]
