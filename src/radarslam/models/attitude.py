"""Levelling a hand-held or tilted platform: its attitude from a gyro and an accelerometer
(docs/method.md c.10.6).

The 2-D SLAM needs three things a tilted body frame does not give directly: the yaw rate about the
vertical, the velocity in the horizontal plane and each detection's height. All three follow from
the attitude ``R_k`` (body to a levelled world frame, z up). It is propagated with the gyro and
pulled towards the accelerometer's gravity direction with time constant ``tau`` (a complementary
filter in the proportional form of Mahony et al. 2008):

    g_k = R_k^T e_z                          (the estimated up direction, body frame)
    e_k = (a_k / |a_k|) x g_k                (rotation that moves g_k towards the measured up)
    R_{k+1} = R_k Exp((w_k - b + e_k / tau) dt_k)

where ``w_k`` is the gyro's rate (rad/s), ``b`` its bias and ``a_k`` the accelerometer's specific
force (m/s^2; at rest ``+g`` along the up direction). The correction is perpendicular to gravity
(``e_k`` is perpendicular to ``g_k``), so it moves roll and pitch and leaves the heading to the gyro.
The heading is ``psi = atan2(R[1, 0], R[0, 0])`` and the levelling rotation of sample ``k``
``L_k = Rz(-psi_k) R_k`` maps body vectors into the frame whose x axis is the body's x projected on
the horizontal plane and whose z axis is up: the 2-D platform frame of the SLAM.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError

__all__ = ["exp_so3", "initial_attitude", "integrate_attitude", "headings", "levelling"]


def exp_so3(w: np.ndarray) -> np.ndarray:
    """The rotation matrix ``Exp(w)`` (3, 3) of a rotation vector ``w`` (rad), Rodrigues' formula."""
    th = math.sqrt(float(w[0]) ** 2 + float(w[1]) ** 2 + float(w[2]) ** 2)
    K = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if th < 1e-12:
        return np.eye(3) + K
    return np.eye(3) + (math.sin(th) / th) * K + ((1.0 - math.cos(th)) / th ** 2) * (K @ K)


def initial_attitude(f: np.ndarray) -> np.ndarray:
    """``R`` (3, 3) with heading 0 whose up direction ``R^T e_z`` is along the specific force ``f``
    (3,) of a platform at rest: ``R = Ry(pitch) Rx(roll)``, roll ``atan2(f_y, f_z)``, pitch
    ``atan2(-f_x, hypot(f_y, f_z))``."""
    n = float(np.linalg.norm(f))
    if not (math.isfinite(n) and n > 0):
        raise InputError(f"accelerometer: expected a non-zero finite mean specific force to level with, got {f}")
    roll = math.atan2(f[1], f[2])
    pitch = math.atan2(-f[0], math.hypot(f[1], f[2]))
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return Ry @ Rx


def integrate_attitude(t: np.ndarray, gyro: np.ndarray, accel: np.ndarray, *, tau_s: float,
                       bias: np.ndarray | None = None, init_window_s: float = 0.5) -> np.ndarray:
    """The attitude ``R_k`` (n, 3, 3) at every IMU sample (module docstring).

    Parameters
    ----------
    t : ndarray, shape (n,)
        Sample times (s), increasing.
    gyro, accel : ndarray, shape (n, 3)
        Angular rate (rad/s) and specific force (m/s^2) in the body frame.
    tau_s : float
        Time constant of the accelerometer's pull (s), > 0.
    bias : ndarray, shape (3,), optional
        Gyro bias subtracted from every sample (rad/s); zero by default.
    init_window_s : float
        The first attitude levels the mean specific force of the samples within this time of the
        first (the platform is taken at rest then; heading 0).
    """
    t = np.asarray(t, dtype=float)
    n = t.size
    if n < 2 or gyro.shape != (n, 3) or accel.shape != (n, 3):
        raise InputError(f"IMU: expected at least 2 samples with (n, 3) gyro and accel, got {n} samples, gyro "
                         f"{gyro.shape}, accel {accel.shape}")
    if not np.all(np.diff(t) > 0):
        raise InputError("IMU: expected increasing sample times, got times that repeat or go backwards")
    if not (tau_s > 0 and math.isfinite(tau_s)):
        raise InputError(f"attitude time constant: expected a finite value > 0, got {tau_s}")
    b = np.zeros(3) if bias is None else np.asarray(bias, dtype=float)
    R = initial_attitude(accel[t <= t[0] + init_window_s].mean(axis=0))
    out = np.empty((n, 3, 3))
    out[0] = R
    k = 1.0 / tau_s
    norms = np.linalg.norm(accel, axis=1)
    for i in range(n - 1):
        g = R[2]                                        # R^T e_z: the third row of R
        w = gyro[i] - b
        if norms[i] > 0:
            a = accel[i] / norms[i]
            w = w + k * np.array([a[1] * g[2] - a[2] * g[1], a[2] * g[0] - a[0] * g[2], a[0] * g[1] - a[1] * g[0]])
        R = R @ exp_so3(w * (t[i + 1] - t[i]))
        out[i + 1] = R
    return out


def headings(R: np.ndarray) -> np.ndarray:
    """The unwrapped heading ``atan2(R[1, 0], R[0, 0])`` (rad) of each attitude ``R`` (n, 3, 3)."""
    return np.unwrap(np.arctan2(R[:, 1, 0], R[:, 0, 0]))


def levelling(R: np.ndarray) -> np.ndarray:
    """``L_k = Rz(-psi_k) R_k`` (n, 3, 3): body vectors into the levelled platform frame (x the
    body's x on the horizontal plane, z up)."""
    psi = np.arctan2(R[:, 1, 0], R[:, 0, 0])
    c, s = np.cos(psi), np.sin(psi)
    Rz = np.zeros_like(R)
    Rz[:, 0, 0], Rz[:, 0, 1], Rz[:, 1, 0], Rz[:, 1, 1], Rz[:, 2, 2] = c, s, -s, c, 1.0
    return Rz @ R
