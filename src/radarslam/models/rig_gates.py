"""A rig's fitted ego-motion checked against the gyro and against its neighbours (docs/method.md c.12.7):
the velocity given the gyro's yaw rate, and the gates that flag a fit which disagrees with either
beyond their covariances (a rival consensus, a jump) so that it never drives the filter."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.models.rig_velocity import FLAGGED_GYRO, FLAGGED_JUMP, OK, RigVelocitySeries


def velocity_given_yaw_rate(theta: np.ndarray, cov: np.ndarray, omega: float,
                            omega_var: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """``(v_x, v_y)`` of a rig fit ``theta = (v_x, v_y, omega)`` with covariance ``cov (3, 3)`` given the
    yaw rate ``omega`` of a gyro of variance ``omega_var`` (c.12.7): the Gaussian conditional
    ``v + k (omega_g - omega_hat)``, ``k = C_vw / C_ww``, with covariance ``C_vv - k C_wv`` plus the gyro's
    own error carried through ``k``, ``k k^T omega_var``. On a linear Gaussian fit this is the refit with
    ``omega`` fixed (tested). Returns ``(v (2,), cov (2, 2))``; ``theta[:2], cov[:2, :2]`` when
    ``C_ww`` is not positive."""
    th = np.asarray(theta, dtype=float).reshape(3)
    C = np.asarray(cov, dtype=float).reshape(3, 3)
    cww = float(C[2, 2])
    if not (cww > 0 and math.isfinite(cww) and math.isfinite(float(omega))):
        return th[:2].copy(), C[:2, :2].copy()
    k = C[:2, 2] / cww
    v = th[:2] + k * (float(omega) - th[2])
    P = C[:2, :2] - np.outer(k, C[2, :2]) + np.outer(k, k) * float(omega_var)
    return v, 0.5 * (P + P.T)


def gate_rig_velocity(series: RigVelocitySeries, gyro_t: np.ndarray | None, gyro: np.ndarray | None,
                      gyro_std: float, *, probability: float = 0.999,
                      accel_std: tuple[float, float, float] = (3.0, 1.0, 1.0),
                      offset_rate_std: float = 0.05) -> RigVelocitySeries:
    """``series`` with the fits that disagree with the gyro and the previous sweeps beyond their
    covariance flagged (c.12.7; status :data:`FLAGGED_GYRO`, :data:`FLAGGED_JUMP`, no longer valid).
    Both gates compare fit ``k`` with ``j``, the last fit still ok before it, through the covariance of
    their difference ``S = C_noise,k + C_noise,j + D D^T + b b^T`` where ``D`` is the difference of the
    two fits' mounting-yaw responses (``mount_jac``) and ``b`` of their ``time_bias``: a common mounting
    or clock error moves neighbouring fits alike, and only as far as their radars' share of the windows
    differs does it move them apart (their noise parts overlap, so the sum is conservative).

    Gyro: the fit's disagreement with the gyro ``omega - omega_g`` (the gyro ``(gyro_t, gyro)``
    interpolated at each fit's time) changes from ``j`` to ``k`` by ``e``, flagged when ``e^2 / (S_ww +
    2 gyro_std^2 + offset_rate_std^2 dt^2) > chi2_1(probability)``: a steady disagreement (a gyro bias, a
    mounting error: the calibration states' to estimate) is not a fault, a sudden one is (a rival
    consensus that turns). Skipped outside the gyro's span or without one.
    Jump: the difference ``e`` of the whole fit, flagged when ``e^T (S + diag(accel_std)^2 dt^2)^-1 e >
    chi2_p(probability)``: a change the car's motion cannot make in ``dt`` (a rival that only translates).

    Parameters
    ----------
    gyro_std : float
        The gyro reading's std (rad/s).
    probability : float
        Each gate's chi-square probability (0.999: a fit whose covariance is right is flagged by each
        gate once in 1000).
    accel_std : (float, float, float)
        How fast ``(v_x m/s^2, v_y m/s^2, omega rad/s^2)`` may change between two fits (1 sigma).
    offset_rate_std : float
        How fast the fit's disagreement with the gyro may wander (rad/s^2, 1 sigma).
    """
    from scipy.stats import chi2

    if not (0 < probability < 1 and gyro_std >= 0 and len(accel_std) == 3 and min(accel_std) >= 0
            and offset_rate_std >= 0):
        raise InputError(f"probability, gyro_std, accel_std, offset_rate_std: expected in (0, 1), >= 0, three "
                         f"values >= 0, >= 0, got {probability}, {gyro_std}, {accel_std}, {offset_rate_std}")
    status = np.array(series.status, dtype=np.int64, copy=True)
    th, C = series.theta, series.cov
    Cn = series.cov_noise if series.cov_noise is not None else C
    lateral = bool(np.any(np.nan_to_num(C[:, 1, 1]) > 0))
    idx = [0, 1, 2] if lateral else [0, 2]
    q1, qp = chi2.ppf(probability, 1), chi2.ppf(probability, len(idx))
    dg = np.full(series.t.size, np.nan)                    # the fit's disagreement with the gyro
    if gyro_t is not None and gyro is not None and np.size(gyro_t) >= 2:
        gt, g = np.asarray(gyro_t, dtype=float), np.asarray(gyro, dtype=float)
        inside = (series.t >= gt[0]) & (series.t <= gt[-1])
        dg[inside] = th[inside, 2] - np.interp(series.t[inside], gt, g)
    Q = np.diag(np.asarray(accel_std, dtype=float) ** 2)[np.ix_(idx, idx)]
    j = -1
    for k in np.flatnonzero(status == OK):
        if j >= 0:
            dt2 = (series.t[k] - series.t[j]) ** 2
            S = Cn[k] + Cn[j]
            if series.mount_jac is not None:
                D = series.mount_jac[k] - series.mount_jac[j]
                b = series.time_bias[k] - series.time_bias[j]
                S = S + D @ D.T + np.outer(b, b)
            eg = dg[k] - dg[j]
            if math.isfinite(eg) and not eg * eg <= q1 * (S[2, 2] + 2 * gyro_std ** 2 + offset_rate_std ** 2 * dt2):
                status[k] = FLAGGED_GYRO
                continue
            e = (th[k] - th[j])[idx]
            if not float(e @ np.linalg.solve(S[np.ix_(idx, idx)] + Q * dt2, e)) <= qp:
                status[k] = FLAGGED_JUMP
                continue
        j = k
    return dataclasses.replace(series, status=status)
