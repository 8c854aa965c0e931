"""Ego-motion of a vehicle from the Doppler of a rig of radars (docs/method.md c.12).

A static point seen by radar ``s`` mounted at ``(x_s, y_s)`` with boresight ``yaw_s`` (vehicle frame:
rear-axle origin, x forward, y left) at azimuth ``phi`` (sensor frame) has the radial velocity

    d = -(cos a, sin a) . (v_x - omega y_s, v_y + omega x_s),    a = phi + yaw_s

(positive receding), linear in ``theta = (v_x, v_y, omega)``: ``d = a_i^T theta`` with the design
row ``a_i = -(cos a, sin a, x_s sin a - y_s cos a)`` (:func:`rig_design`, c.12.1). One radar gives
only its own velocity (rank 2); two radars with different lever arms give ``omega`` (c.12.2). With
the no-sideslip constraint (``v_y = 0`` at the rear axle) the unknowns are ``(v_x, omega)``.

:func:`fit_rig_velocity` fits one window of detections and :func:`fit_rig_windows` every window
of a recording in one vectorised call (c.12.3-c.12.4): RANSAC on minimal sets for the consensus and
least squares on it (:mod:`radarslam.models._rig_consensus`), a robust scale (1.4826 MAD of the
consensus), Tukey's biweight by IRLS at that scale, and the M-estimator's sandwich covariance
(:mod:`radarslam.models._rig_robust`, which also holds :data:`TUKEY_C`, the status codes and the
chunking; re-exported here). With each detection's radar and :func:`rig_design_yaw`, the covariance
adds the mounting-yaw and timing terms (c.12.3 step 5b). :func:`.rig_gates.gate_rig_velocity` flags fits that
disagree with the gyro or the previous sweeps and :func:`.rig_gates.velocity_given_yaw_rate` conditions a fit on
the gyro's yaw rate (c.12.7). :func:`yaw_offset_of_sweep` and :func:`tukey_location` are the pieces of
the mounting calibration (c.12.5).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError
from radarslam.models._rig_robust import (  # noqa: F401  (RANK_TOL, the status codes, CHUNK_ROWS: re-exported)
    CHUNK_ROWS,
    FLAGGED_GYRO,
    FLAGGED_JUMP,
    MAD_TO_STD,
    NO_CONSENSUS,
    OK,
    RANK_TOL,
    STATUS,
    STATUS_WORDS,
    TOO_FEW,
    TUKEY_C,
    UNOBSERVABLE,
    fit_windows,
)

__all__ = [
    "TUKEY_C",
    "RigVelocity",
    "RigVelocitySeries",
    "fit_rig_velocity",
    "fit_rig_windows",
    "rig_design",
    "rig_design_yaw",
    "static_doppler",
    "tukey_location",
    "window_bounds",
    "yaw_offset_of_sweep",
]


def rig_design(azimuth: np.ndarray, mount_x: np.ndarray, mount_y: np.ndarray, mount_yaw: np.ndarray,
               lateral: bool = True) -> np.ndarray:
    """Design rows ``A`` of ``d = A theta`` (c.12.1), ``(n, 3)`` for ``theta = (v_x, v_y, omega)`` or,
    with ``lateral`` False (no sideslip, ``v_y = 0``), ``(n, 2)`` for ``(v_x, omega)``.

    Parameters
    ----------
    azimuth : ndarray, shape (n,)
        Each detection's azimuth in its sensor's frame (rad).
    mount_x, mount_y, mount_yaw : ndarray, shape (n,)
        Each detection's sensor mounting in the vehicle frame (m, m, rad).
    """
    az = np.asarray(azimuth, dtype=float)
    n = az.shape[0]
    cols = [np.asarray(v, dtype=float) for v in (mount_x, mount_y, mount_yaw)]
    for name, v in zip(("mount_x", "mount_y", "mount_yaw"), cols):
        if v.shape != (n,):
            raise InputError(f"{name}: expected shape ({n},), got {v.shape}")
    a = az + cols[2]
    c, s = np.cos(a), np.sin(a)
    lever = cols[0] * s - cols[1] * c                 # (l x u)_z, c.12.1
    if lateral:
        return np.ascontiguousarray(np.column_stack([-c, -s, -lever]))
    return np.ascontiguousarray(np.column_stack([-c, -lever]))


def rig_design_yaw(azimuth: np.ndarray, mount_x: np.ndarray, mount_y: np.ndarray, mount_yaw: np.ndarray,
                   lateral: bool = True) -> np.ndarray:
    """``d A / d psi``: each design row's derivative with respect to its radar's mounting yaw (c.12.3
    step 5b), ``(n, 3)`` or, with ``lateral`` False, ``(n, 2)``. With ``a = -(cos a, sin a, x sin a -
    y cos a)`` and ``a = phi + psi``: ``(sin a, -cos a, -(x cos a + y sin a))``."""
    az = np.asarray(azimuth, dtype=float)
    a = az + np.asarray(mount_yaw, dtype=float)
    c, s = np.cos(a), np.sin(a)
    x, y = np.asarray(mount_x, dtype=float), np.asarray(mount_y, dtype=float)
    if not (x.shape == y.shape == a.shape == az.shape):
        raise InputError(f"azimuth, mount_x, mount_y, mount_yaw: expected equal shapes (n,), got {az.shape}, "
                         f"{x.shape}, {y.shape}, {np.shape(mount_yaw)}")
    dlever = -(x * c + y * s)
    if lateral:
        return np.ascontiguousarray(np.column_stack([s, -c, dlever]))
    return np.ascontiguousarray(np.column_stack([s, dlever]))


def static_doppler(azimuth: np.ndarray, mount_x: np.ndarray, mount_y: np.ndarray, mount_yaw: np.ndarray,
                   vx: float, vy: float, omega: float) -> np.ndarray:
    """The radial velocity ``(n,)`` (m/s, positive receding) of static points at ``azimuth`` (sensor
    frame) seen by sensors at the given mountings on a vehicle moving at ``(vx, vy)`` turning at
    ``omega`` (c.12.1), computed the long way: the sensor's velocity in the vehicle frame, rotated
    into the sensor frame, against the line of sight. ``rig_design(...) @ theta`` equals it."""
    az = np.asarray(azimuth, dtype=float)
    wx = vx - omega * np.asarray(mount_y, dtype=float)
    wy = vy + omega * np.asarray(mount_x, dtype=float)
    c, s = np.cos(mount_yaw), np.sin(mount_yaw)
    sx, sy = c * wx + s * wy, -s * wx + c * wy        # R(-yaw_s) w
    return -(np.cos(az) * sx + np.sin(az) * sy)


def window_bounds(t: np.ndarray, t_out: np.ndarray, half_window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Row ranges ``[lo, hi)`` of the time-sorted ``t`` within ``+-half_window_s`` of each ``t_out``."""
    lo = np.searchsorted(t, np.asarray(t_out) - half_window_s, side="left")
    hi = np.searchsorted(t, np.asarray(t_out) + half_window_s, side="right")
    return lo.astype(np.int64), hi.astype(np.int64)


# ---------------------------------------------------------------------------------------------
# Python API


@dataclass(frozen=True)
class RigVelocity:
    """One window's fit (c.12.3).

    Attributes
    ----------
    theta : ndarray, shape (3,)
        ``(v_x m/s, v_y m/s, omega rad/s)`` of the vehicle (rear-axle origin); NaN when not ``valid``;
        under the no-sideslip model ``v_y`` is 0.
    cov : ndarray, shape (3, 3)
        Its covariance; under the no-sideslip model row and column 1 are 0.
    weights : ndarray, shape (n,)
        Tukey weights of the detections (0: rejected).
    sigma_mps : float
        The robust scale of the Doppler residuals (m/s).
    rank : int
        Rank of the weighted information matrix (3, or 2 without a second lever arm).
    status : str
        ``"ok"``, ``"too few detections"``, ``"no consensus"`` or ``"rank deficient"``.
    """

    theta: np.ndarray
    cov: np.ndarray
    weights: np.ndarray
    sigma_mps: float
    rank: int
    status: str

    @property
    def valid(self) -> bool:
        return self.status == "ok"

    @property
    def n_inliers(self) -> int:
        return int(np.count_nonzero(self.weights))


@dataclass(frozen=True)
class RigVelocitySeries:
    """The fits of a recording's windows (``K`` of them, c.12.4).

    Attributes
    ----------
    t : ndarray, shape (K,)
        Output times (s), the centres of the windows.
    theta : ndarray, shape (K, 3)
        ``(v_x, v_y, omega)``; NaN where not valid.
    cov : ndarray, shape (K, 3, 3)
    status : ndarray of int, shape (K,)
        0 ok, 1 too few detections, 2 no consensus, 3 rank deficient.
    sigma_mps : ndarray, shape (K,)
    n_inliers, n_used : ndarray of int, shape (K,)
        Detections with a non-zero weight, and in the window.
    cov_noise : ndarray, shape (K, 3, 3) or None
        The part of ``cov`` from the Doppler's noise alone (the floored sandwich, c.12.3 step 5);
        ``cov`` adds the systematic terms (step 5b). None: ``cov`` is all.
    theta_dot : ndarray, shape (K, 3) or None
        The motion's rate of change at each window (slope of the valid fits within
        ``slope_half_window_s``; 1/s units of ``theta``), the systematic terms' input.
    overlap : ndarray, shape (K,) or None
        The mean number of windows each of the window's detections is in (about 5 at +-40 ms).
    mount_jac : ndarray, shape (K, 3, S) or None
        ``sigma_psi d theta / d psi_s``: the fit's response to one std of each radar's mounting-yaw error.
    time_bias : ndarray, shape (K, 3) or None
        ``T theta_dot``: the fit's offset from the motion at the window's centre (c.12.3 step 5b).
    """

    t: np.ndarray
    theta: np.ndarray
    cov: np.ndarray
    status: np.ndarray
    sigma_mps: np.ndarray
    n_inliers: np.ndarray
    n_used: np.ndarray
    cov_noise: np.ndarray | None = None
    theta_dot: np.ndarray | None = None
    overlap: np.ndarray | None = None
    mount_jac: np.ndarray | None = None
    time_bias: np.ndarray | None = None

    def white_cov(self) -> np.ndarray:
        """``cov`` as a filter that takes every window's fit as an independent reading needs it
        (c.12.7): the noise part times the windows' ``overlap`` (each detection's mean number of
        windows), the systematic part once. ``(K, 3, 3)``."""
        if self.cov_noise is None or self.overlap is None:
            return self.cov
        return self.cov + (np.asarray(self.overlap) - 1.0)[:, None, None] * self.cov_noise

    @property
    def valid(self) -> np.ndarray:
        return self.status == OK


def _check_options(threshold_mps, hypotheses, sample, half_window_s=None):
    if not (threshold_mps > 0 and hypotheses >= 1 and sample >= 1):
        raise InputError(f"threshold_mps, hypotheses, sample: expected > 0, >= 1, >= 1, got {threshold_mps}, "
                         f"{hypotheses}, {sample}")
    if half_window_s is not None and not half_window_s > 0:
        raise InputError(f"half_window_s: expected > 0 s, got {half_window_s}")


def _full(theta: np.ndarray, cov: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(v_x, omega)`` fits as ``(v_x, 0, omega)`` with a zero row and column 1 of the covariance."""
    if theta.shape[-1] == 3:
        return theta, cov
    th = np.zeros(theta.shape[:-1] + (3,))
    th[..., 0], th[..., 2] = theta[..., 0], theta[..., 1]
    th[np.isnan(theta[..., 0])] = np.nan
    C = np.zeros(cov.shape[:-2] + (3, 3))
    C[..., ::2, ::2] = cov
    C[np.isnan(cov[..., 0, 0])] = np.nan
    return th, C


#: Defaults of the fit (c.12.3 gives the reasons).
DEFAULTS = {"threshold_mps": 0.5, "hypotheses": 50, "sample": 128, "sigma_floor_mps": 0.03,
            "min_inlier_fraction": 0.3, "irls_steps": 20}


def fit_rig_velocity(A: np.ndarray, doppler: np.ndarray, rng: np.random.Generator, *, threshold_mps: float = 0.5,
                     hypotheses: int = 50, sample: int = 128, sigma_floor_mps: float = 0.03,
                     min_inlier_fraction: float = 0.3, irls_steps: int = 20) -> RigVelocity:
    """The vehicle's velocity from one window of detections of several radars (c.12.3).

    Parameters
    ----------
    A : ndarray, shape (n, 3) or (n, 2)
        Design rows (:func:`rig_design`; two columns under the no-sideslip model).
    doppler : ndarray, shape (n,)
        Radial velocities (m/s, positive receding).
    rng : numpy.random.Generator
        Draws RANSAC's minimal sets and scoring rows.
    threshold_mps : float
        RANSAC's consensus threshold on ``|d_i - a_i^T theta|`` (c.12.3: 0.5 m/s from the data sheets).
    hypotheses : int
        Minimal sets of p rows drawn (50: an all-static set of 3 with probability 1 - 5e-6 at 40%
        moving detections).
    sample : int
        Rows (drawn with replacement) on which each minimal set's consensus is counted; all rows
        when the window has no more.
    sigma_floor_mps : float
        Floor of the robust scale, and the covariance never below ``sigma_floor_mps^2 (A^T W A)^-1``
        (c.12.3 step 5; default the Doppler's quantisation, 0.1 m/s / sqrt(12); a run passes the
        profile's ``filter.doppler_std_floor_mps``).
    min_inlier_fraction : float
        Fewer weighted detections than this fraction of the window: not valid.
    irls_steps : int
        Most IRLS steps of the biweight.
    """
    A = np.ascontiguousarray(A, dtype=np.float64)
    d = np.ascontiguousarray(doppler, dtype=np.float64)
    if A.ndim != 2 or A.shape[1] not in (2, 3):
        raise InputError(f"A: expected shape (n, 3) or (n, 2), got {A.shape}")
    if d.shape != (A.shape[0],):
        raise InputError(f"doppler: expected shape ({A.shape[0]},), got {d.shape}")
    _check_options(threshold_mps, hypotheses, sample)
    n, p = A.shape
    theta, cov, st, sigma, _, w = fit_windows(A, d, np.array([0]), np.array([n]), rng, int(hypotheses), int(sample),
                                              float(threshold_mps), float(sigma_floor_mps),
                                              float(min_inlier_fraction), int(irls_steps), keep_weights=True)
    if w.size != n:
        w = np.zeros(n)
    rank = p
    if n:
        N = (A * (w if w.any() else np.ones(n))[:, None]).T @ A
        dg = np.sqrt(np.diag(N))
        rank = int(np.linalg.matrix_rank(N / np.outer(dg, dg), tol=1e-7) if np.all(dg > 0) else
                   np.linalg.matrix_rank(N))
    th, C = _full(theta[0], cov[0])
    return RigVelocity(th, C, w, float(sigma[0]), rank, STATUS[int(st[0])])


def fit_rig_windows(t: np.ndarray, A: np.ndarray, doppler: np.ndarray, t_out: np.ndarray,
                    rng: np.random.Generator, *, half_window_s: float = 0.04, threshold_mps: float = 0.5,
                    hypotheses: int = 50, sample: int = 128, sigma_floor_mps: float = 0.03,
                    min_inlier_fraction: float = 0.3, irls_steps: int = 20, sensor: np.ndarray | None = None,
                    dA_dyaw: np.ndarray | None = None, mount_yaw_std_rad: float = 0.0,
                    time_offset_std_s: float = 0.0, slope_half_window_s: float = 0.2) -> RigVelocitySeries:
    """:func:`fit_rig_velocity` on the detections within ``+-half_window_s`` of each ``t_out`` (c.12.4),
    all windows vectorised together, with the covariance of c.12.3 steps 5-5b.

    Parameters
    ----------
    t : ndarray, shape (n,)
        Detection times (s), non-decreasing.
    A, doppler : ndarray, shapes (n, p), (n,)
        As :func:`fit_rig_velocity`.
    t_out : ndarray, shape (K,)
        Output times (s).
    sensor : ndarray of int, shape (n,), optional
        Each detection's radar (0 .. S-1); with ``dA_dyaw`` turns on the systematic terms (step 5b).
    dA_dyaw : ndarray, shape (n, p), optional
        :func:`rig_design_yaw` of the same rows.
    mount_yaw_std_rad : float
        Std of each radar's mounting-yaw error, independent between radars (rad).
    time_offset_std_s : float
        Std of the radars' common time offset against the vehicle's clock (s).
    slope_half_window_s : float
        The fits within this distance of a window give its ``theta_dot`` (s).
    """
    t = np.ascontiguousarray(t, dtype=np.float64)
    A = np.ascontiguousarray(A, dtype=np.float64)
    d = np.ascontiguousarray(doppler, dtype=np.float64)
    t_out = np.ascontiguousarray(t_out, dtype=np.float64)
    if A.ndim != 2 or A.shape[1] not in (2, 3) or t.shape != (A.shape[0],) or d.shape != t.shape:
        raise InputError(f"t, A, doppler: expected shapes (n,), (n, 3 or 2), (n,), got {t.shape}, {A.shape}, "
                         f"{d.shape}")
    if t.size and np.any(np.diff(t) < 0):
        raise InputError("t: expected non-decreasing detection times, got a decrease")
    _check_options(threshold_mps, hypotheses, sample, half_window_s)
    if not (mount_yaw_std_rad >= 0 and time_offset_std_s >= 0 and slope_half_window_s > 0):
        raise InputError(f"mount_yaw_std_rad, time_offset_std_s, slope_half_window_s: expected >= 0, >= 0, > 0, "
                         f"got {mount_yaw_std_rad}, {time_offset_std_s}, {slope_half_window_s}")
    aux = None
    if sensor is not None or dA_dyaw is not None:
        sensor = np.ascontiguousarray(sensor, dtype=np.int64)
        G = np.ascontiguousarray(dA_dyaw, dtype=np.float64)
        if sensor.shape != t.shape or G.shape != A.shape or (sensor.size and sensor.min() < 0):
            raise InputError(f"sensor, dA_dyaw: expected shapes {t.shape} (values >= 0), {A.shape}, got "
                             f"{sensor.shape}, {G.shape}")
        aux = (t, t_out, G, sensor, int(sensor.max()) + 1 if sensor.size else 1)
    lo, hi = window_bounds(t, t_out, half_window_s)
    out = fit_windows(A, d, lo, hi, rng, int(hypotheses), int(sample), float(threshold_mps), float(sigma_floor_mps),
                      float(min_inlier_fraction), int(irls_steps), aux=aux)
    theta, cov, status, sigma, n_in = out[:5]
    # c.12.3 step 5: a detection is in kappa windows on average (about 5 at +-40 ms and a sweep every 16 ms);
    # a filter that takes every window's fit as a new, independent reading counts it kappa times (c.12.7)
    cover = np.zeros(t.size + 1)
    np.add.at(cover, lo, 1.0)
    np.add.at(cover, hi, -1.0)
    csum = np.concatenate([[0.0], np.cumsum(np.cumsum(cover)[:-1])])
    with np.errstate(invalid="ignore", divide="ignore"):
        kappa = np.maximum((csum[hi] - csum[lo]) / (hi - lo), 1.0)
    kappa = np.where(np.isfinite(kappa), kappa, 1.0)
    cov_noise = cov.copy()
    theta_dot = mount_jac = time_bias = None
    if aux is not None:
        T, J = out[6], out[7]
        theta_dot = _slopes(t_out, theta, status == OK, slope_half_window_s)
        Tq = np.einsum("kij,kj->ki", T, theta_dot)              # the window's own spread in time (step 5b)
        mount_jac, time_bias = mount_yaw_std_rad * J, Tq
        cov = (cov + mount_yaw_std_rad ** 2 * J @ np.swapaxes(J, 1, 2)
               + time_offset_std_s ** 2 * theta_dot[:, :, None] * theta_dot[:, None, :]
               + Tq[:, :, None] * Tq[:, None, :])
        theta_dot = _full(theta_dot, np.zeros(theta_dot.shape + (theta_dot.shape[-1],)))[0]
    th, C = _full(theta, cov)
    Cn = _full(theta, cov_noise)[1]
    if mount_jac is not None and theta.shape[1] == 2:
        mj = np.zeros((theta.shape[0], 3, mount_jac.shape[2]))
        mj[:, ::2] = mount_jac
        tb = np.zeros((theta.shape[0], 3))
        tb[:, ::2] = time_bias
        mount_jac, time_bias = mj, tb
    return RigVelocitySeries(t_out, th, C, status, sigma, n_in, hi - lo, Cn, theta_dot, kappa, mount_jac, time_bias)


def _slopes(t: np.ndarray, theta: np.ndarray, ok: np.ndarray, h: float) -> np.ndarray:
    """The least-squares slope ``(K, p)`` of ``theta`` against ``t`` over the ``ok`` fits within ``+-h`` of
    each ``t[k]`` (0 where fewer than 3 or no spread in time): the motion's rate of change."""
    K, p = theta.shape
    tv, yv = t[ok], theta[ok]
    if tv.size < 3:
        return np.zeros((K, p))
    tc = tv - tv.mean()
    c = lambda x: np.concatenate([np.zeros((1,) + x.shape[1:]), np.cumsum(x, axis=0)])
    S0, S1, S2 = c(np.ones(tv.size)), c(tc), c(tc * tc)
    Sy, Sty = c(yv), c(tc[:, None] * yv)
    lo = np.searchsorted(tv, t - h, side="left")
    hi = np.searchsorted(tv, t + h, side="right")
    n, s1, s2 = S0[hi] - S0[lo], S1[hi] - S1[lo], S2[hi] - S2[lo]
    sy, sty = Sy[hi] - Sy[lo], Sty[hi] - Sty[lo]
    den = n * s2 - s1 * s1
    good = (n >= 3) & (den > 1e-12 * np.maximum(n * s2, 1e-300))
    with np.errstate(invalid="ignore", divide="ignore"):
        slope = (n[:, None] * sty - s1[:, None] * sy) / den[:, None]
    return np.where(good[:, None], slope, 0.0)


# ---------------------------------------------------------------------------------------------
# Mounting calibration pieces (c.12.5)


def yaw_offset_of_sweep(w: np.ndarray, cov_w: np.ndarray, w_ref: np.ndarray) -> tuple[np.ndarray, np.ndarray,
                                                                                         np.ndarray]:
    """A sensor's yaw offset from each of ``K`` sweeps (c.12.5): ``delta = angle(w_ref) - angle(w)``.

    ``w`` (K, 2) is the sensor's velocity fitted to each sweep in its own nominal frame, with
    covariance ``cov_w`` (K, 2, 2); ``w_ref`` (K, 2) the velocity the reference motion predicts there
    with the nominal mounting. A boresight truly at ``yaw + delta`` measures ``R(-delta) w_ref``.
    Returns ``delta`` (K,) (rad, wrapped to [-pi, pi)), its variance ``J^T cov_w J`` (K,) (rad^2, first
    order) and ``J = d delta / d w = (w_y, -w_x) / |w|^2`` (K, 2).
    """
    w = np.asarray(w, dtype=float).reshape(-1, 2)
    wr = np.asarray(w_ref, dtype=float).reshape(-1, 2)
    C = np.asarray(cov_w, dtype=float).reshape(-1, 2, 2)
    if wr.shape != w.shape or C.shape[0] != w.shape[0]:
        raise InputError(f"w, cov_w, w_ref: expected shapes (K, 2), (K, 2, 2), (K, 2), got {w.shape}, {C.shape}, "
                         f"{wr.shape}")
    delta = np.arctan2(wr[:, 1], wr[:, 0]) - np.arctan2(w[:, 1], w[:, 0])
    delta = (delta + np.pi) % (2 * np.pi) - np.pi
    with np.errstate(divide="ignore", invalid="ignore"):
        J = np.column_stack([w[:, 1], -w[:, 0]]) / np.einsum("ki,ki->k", w, w)[:, None]
    return delta, np.einsum("ki,kij,kj->k", J, C, J), J


def tukey_location(x: np.ndarray, std: np.ndarray, iterations: int = 50) -> tuple[float, float, np.ndarray]:
    """Tukey-biweight M-estimate of one location from values ``x`` (n,) with stds ``std`` (n,) (c.12.5).

    Start: the weighted median; scale: 1.4826 MAD of the normalised residuals ``(x - mu) / std``
    (so an unmodelled spread between values inflates it), at least 1; IRLS at that scale. Returns ``(mu,
    std of mu, weights (n,))``; the std is the sandwich form of :func:`fit_rig_velocity` with the
    values taken as independent.
    """
    x = np.asarray(x, dtype=float)
    sd = np.asarray(std, dtype=float)
    if x.ndim != 1 or sd.shape != x.shape or x.size < 3 or np.any(~(sd > 0)):
        raise InputError(f"x, std: expected two (n,) arrays, n >= 3, std > 0, got {x.shape}, {sd.shape}")
    order = np.argsort(x)
    cw = np.cumsum(1.0 / sd[order] ** 2)
    mu = float(x[order][np.searchsorted(cw, 0.5 * cw[-1])])
    z = (x - mu) / sd
    # never below the values' own stds (s = 1): quantised data can make most values equal (MAD 0)
    s = max(MAD_TO_STD * float(np.median(np.abs(z))), 1.0)
    cs = TUKEY_C * s
    w = np.zeros_like(x)
    for _ in range(iterations):
        u = (x - mu) / sd / cs
        w = np.where(np.abs(u) < 1, (1 - u * u) ** 2, 0.0) / sd ** 2
        new = float(np.sum(w * x) / np.sum(w))
        done = abs(new - mu) < 1e-12
        mu = new
        if done:
            break
    u = (x - mu) / sd / cs
    inside = np.abs(u) < 1
    t2 = np.where(inside, 1 - u * u, 0.0)
    B = np.sum(t2 * (1 - 5 * u * u) * inside / sd ** 2)
    M = np.sum((u * cs * t2 * t2) ** 2 / sd ** 2)
    n_in = int(inside.sum())
    # the sandwich B^-1 M B^-1 of sum psi(z_i) / std_i = 0 (c.12.3); M carries s^2 through z = u c s
    # ... and never below the model's s^2 / sum(1 / std^2) (all residuals 0 would make the sandwich 0)
    floor = s * s / np.sum(inside / sd ** 2)
    var = max(M / B ** 2 * n_in / max(n_in - 1, 1), floor) if B > 0 else floor
    return mu, math.sqrt(var), np.where(inside, t2 * t2, 0.0)
