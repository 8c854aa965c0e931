"""The rig's ego-motion under the single-track model with rear-axle sideslip (docs/method.md c.12.2,
c.12.3 step 5b, c.16.2).

c.12.2: where every radar sits at about one ``x`` (RadarScenes: 3.66-3.86 m), the radars' lateral
velocities give only ``v_y + x omega``; the full model ``(v_x, v_y, omega)`` takes ``omega`` from the
difference of the radars' forward velocities across 1.4-1.75 m of lateral lever arm, where a
0.03 m/s disagreement between two radars is 1 deg/s; the no-sideslip model (``v_y = 0``) takes
``omega`` from the lateral velocities over the 3.8-m lever arm, but a car's rear axle does slip in a
turn. The single-track (bicycle) model says how: at the rear axle, in a steady turn,

    v_y = -D v_x a_y = -D v_x^2 omega,

``D`` the rear axle's cornering compliance (rad of sideslip per m/s^2 of lateral acceleration; the
linear single-track model's ``m l_f / (C_r L)``). The rear axle's direction of travel at zero lateral
acceleration is the vehicle's x axis (no thrust angle: the gauge of c.12.5; a thrust angle and a
common turn of the radars give the same Doppler, c.16.2, and the mounting prior's common part
stands for both).

:func:`cornering_compliance` estimates ``D`` from the rig's own full-model fits (no reference): the
constraint ``v_y + D v_x^2 omega = 0`` holds in every window up to the fit's noise, so ``D``
maximises its Gaussian likelihood over the windows (each window's residual variance ``h^T C h`` from
the fit's noise covariance times its overlap, c.12.7), with a wide prior; its std is a block
jackknife over :data:`BLOCK_S`-second blocks (the fits' errors are correlated over seconds).
:func:`single_track_velocity` imposes the constraint on each window's fit: the Gaussian conditional of
the full fit on ``h^T theta = 0`` under its noise covariance (the constrained weighted least squares to
first order), every systematic term of c.12.3 step 5b carried through the same projection, plus the
response to ``D``'s own error.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.optimize import minimize_scalar

from radarslam.models.rig_velocity import OK, RigVelocitySeries

__all__ = ["BLOCK_S", "COMPLIANCE_PRIOR_STD", "MIN_SPEED_MPS", "VIF_LIMIT", "constraint_rows", "cornering_compliance",
           "single_track_velocity", "yaw_rate_vif"]

#: The prior std of the rear axle's cornering compliance ``D`` (rad per m/s^2, mean 0): 5 deg/g, wider
#: than a passenger car's rear axle (a few deg of slip at 1 g); the drive's turns decide ``D``, and a
#: drive without turns (``a_y`` about 0, where ``D`` does not matter) keeps the no-sideslip model.
COMPLIANCE_PRIOR_STD = math.radians(5.0) / 9.80665
#: Block length of the jackknife of ``D`` (s): the constraint's residual stays correlated for seconds
#: (the same scene, the same radars' share of the windows): on RadarScenes 105 its integrated
#: autocorrelation time is 4.8 s and its autocorrelation 0.23 at 8 s, 0.00 at 16 s.
BLOCK_S = 10.0
#: Windows slower than this (m/s) do not inform ``D`` (``a_y = v_x omega`` is 0 at a standstill).
MIN_SPEED_MPS = 1.0
#: The variance inflation factor of ``omega`` beyond which a rig's full model cannot tell its yaw rate
#: from its sideslip: the usual limit of regression diagnostics (a VIF above 10 signals collinearity
#: that dominates the least-squares estimate; Marquardt 1970, Kutner et al. "Applied Linear Regression
#: Models" ch. 10). A rig's geometry puts it far on one side: nuScenes' five radars (x from -0.56 to
#: 3.41 m) give a median 1.8-2.8 over a scene's windows, RadarScenes' four (x 3.66-3.86 m) 26.
VIF_LIMIT = 10.0
#: The search interval of ``D`` (rad per m/s^2): +-0.05 is +-28 deg/g, beyond any car.
_D_BOUND = 0.05


def constraint_rows(vx: np.ndarray, D: float) -> np.ndarray:
    """``h (K, 3)`` of the single-track constraint ``h^T (v_x, v_y, omega) = v_y + D v_x^2 omega = 0``
    at each window's forward speed ``vx`` (K,) (module docstring)."""
    h = np.zeros((np.size(vx), 3))
    h[:, 1] = 1.0
    h[:, 2] = D * np.asarray(vx, dtype=float) ** 2
    return h


def yaw_rate_vif(series: RigVelocitySeries) -> float:
    """The median over the valid windows of the variance inflation factor of ``omega`` in the full
    model, ``C_ww (C^-1)_ww`` of the fit's noise covariance: how much freeing ``v_y`` (and ``v_x``)
    inflates the variance of ``omega`` against knowing them, ``1 / (1 - R^2)`` of ``omega`` on the other
    two; ``1`` for a rig whose lever arms separate them, large where the radars share one ``x``
    (c.12.2). NaN without a valid full-model window."""
    Cn = series.cov_noise if series.cov_noise is not None else series.cov
    use = _informative(series) & (np.nan_to_num(Cn[:, 1, 1]) > 0)
    if not use.any():
        return math.nan
    C = Cn[use]
    with np.errstate(invalid="ignore", divide="ignore"):
        vif = C[:, 2, 2] * np.linalg.inv(C)[:, 2, 2]
    vif = vif[np.isfinite(vif)]
    return float(np.median(vif)) if vif.size else math.nan


def _informative(series: RigVelocitySeries) -> np.ndarray:
    """The windows that inform ``D``: valid, with a noise covariance, moving."""
    Cn = series.cov_noise if series.cov_noise is not None else series.cov
    fin = np.all(np.isfinite(series.theta), axis=1) & np.all(np.isfinite(Cn.reshape(Cn.shape[0], -1)), axis=1)
    return (series.status == OK) & fin & (np.nan_to_num(series.theta[:, 0]) >= MIN_SPEED_MPS)


def _neg_log_likelihood(D: float, th: np.ndarray, Cn: np.ndarray, kappa: np.ndarray) -> float:
    h = constraint_rows(th[:, 0], D)
    var = np.einsum("ki,kij,kj->k", h, Cn, h) * kappa
    r = np.einsum("ki,ki->k", h, th)
    return float(np.sum(r * r / var + np.log(var)) + (D / COMPLIANCE_PRIOR_STD) ** 2)


def _argmin(th: np.ndarray, Cn: np.ndarray, kappa: np.ndarray) -> float:
    if th.shape[0] == 0:
        return 0.0
    res = minimize_scalar(_neg_log_likelihood, bounds=(-_D_BOUND, _D_BOUND), method="bounded",
                          args=(th, Cn, kappa), options={"xatol": 1e-7})
    return float(res.x)


def cornering_compliance(series: RigVelocitySeries) -> tuple[float, float]:
    """``(D, std)``: the rear axle's cornering compliance (rad per m/s^2) from the rig's full-model fits
    ``series`` alone (module docstring): the maximum of the constraint's likelihood over the valid
    windows at :data:`MIN_SPEED_MPS` or more (each window's residual variance its noise covariance's,
    ``cov_noise``, times its ``overlap``: a detection is in about five windows) under the prior
    :data:`COMPLIANCE_PRIOR_STD`; the std is the block jackknife's over :data:`BLOCK_S`-second blocks
    (RadarScenes 105: 1.3 deg/g of 2.7), never below the likelihood's own (its curvature; 0.02 deg/g
    there). A series without ``v_y`` (the no-sideslip model) gives ``(0, prior std)``."""
    use = _informative(series)
    Cn = series.cov_noise if series.cov_noise is not None else series.cov
    if not use.any() or not np.any(np.nan_to_num(Cn[use, 1, 1]) > 0):
        return 0.0, COMPLIANCE_PRIOR_STD
    th, C = series.theta[use], Cn[use]
    kappa = np.ones(th.shape[0]) if series.overlap is None else np.maximum(np.asarray(series.overlap)[use], 1.0)
    D = _argmin(th, C, kappa)
    # the likelihood's own std (its curvature, the windows taken as independent past their overlap) ...
    step = 1e-5
    f0, fp, fm = (_neg_log_likelihood(x, th, C, kappa) for x in (D, D + step, D - step))
    curv = (fp - 2.0 * f0 + fm) / step ** 2 / 2.0
    formal = 1.0 / math.sqrt(curv) if curv > 0 else COMPLIANCE_PRIOR_STD
    # ... and the block jackknife's, which sees the errors that stay correlated for seconds
    block = np.floor((series.t[use] - series.t[use][0]) / BLOCK_S).astype(np.int64)
    blocks = np.unique(block)
    if blocks.size < 2:
        return D, formal
    loo = np.array([_argmin(th[block != b], C[block != b], kappa[block != b]) for b in blocks])
    B = blocks.size
    return D, max(formal, float(math.sqrt((B - 1) / B * np.sum((loo - loo.mean()) ** 2))))


def single_track_velocity(series: RigVelocitySeries, D: float, D_std: float = 0.0) -> RigVelocitySeries:
    """``series`` (full-model fits, ``(v_x, v_y, omega)``) under the single-track constraint
    ``v_y = -D v_x^2 omega`` (module docstring): each valid window's fit conditioned on it under its
    noise covariance ``C_n`` (gain ``g = C_n h / h^T C_n h``, projection ``P = I - g h^T``:
    ``theta - g h^T theta``), ``cov_noise`` ``P C_n P^T``, the systematic terms (``mount_jac``,
    ``time_bias``, ``theta_dot`` and through them ``cov``) carried by ``P``, and ``D``'s error
    ``D_std`` added: the constraint misses by ``dD v_x^2 omega``, which moves the fit by ``-g`` times
    it. Statuses, scales and counts are kept; a window that is not valid is left as it is."""
    ok = series.status == OK
    K = series.t.size
    Cn = series.cov_noise if series.cov_noise is not None else series.cov
    th = series.theta.copy()
    vx = np.where(ok, np.nan_to_num(th[:, 0]), 0.0)
    h = constraint_rows(vx, D)
    Ch = np.einsum("kij,kj->ki", np.nan_to_num(Cn), h)
    hCh = np.einsum("ki,ki->k", h, Ch)
    ok &= hCh > 0
    g = np.zeros((K, 3))
    g[ok] = Ch[ok] / hCh[ok, None]
    P = np.broadcast_to(np.eye(3), (K, 3, 3)) - g[:, :, None] * h[:, None, :]
    T = lambda M: P @ M @ np.swapaxes(P, 1, 2)
    new_th = th - g * np.einsum("ki,ki->k", h, np.nan_to_num(th))[:, None]
    miss = D_std * vx ** 2 * np.nan_to_num(new_th[:, 2])                  # the constraint's own error (1 sd)
    cov = T(np.nan_to_num(series.cov)) + (miss ** 2)[:, None, None] * g[:, :, None] * g[:, None, :]
    out = {"theta": np.where(ok[:, None], new_th, series.theta),
           "cov": np.where(ok[:, None, None], cov, series.cov)}
    if series.cov_noise is not None:
        out["cov_noise"] = np.where(ok[:, None, None], T(np.nan_to_num(series.cov_noise)), series.cov_noise)
    if series.mount_jac is not None:
        out["mount_jac"] = np.where(ok[:, None, None], P @ np.nan_to_num(series.mount_jac), series.mount_jac)
    if series.time_bias is not None:
        out["time_bias"] = np.where(ok[:, None], np.einsum("kij,kj->ki", P, np.nan_to_num(series.time_bias)),
                                    series.time_bias)
    if series.theta_dot is not None:
        out["theta_dot"] = np.where(ok[:, None], np.einsum("kij,kj->ki", P, np.nan_to_num(series.theta_dot)),
                                    series.theta_dot)
    return dataclasses.replace(series, **out)
