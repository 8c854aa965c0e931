"""Ego-motion from Doppler: the sensor's velocity fitted to one scan's radial velocities
(docs/method.md c.10).

For a static point seen in the unit direction ``u`` (from the sensor, sensor frame) the radial
velocity is ``d = -u . v`` with ``v`` the sensor's velocity in the sensor frame (positive =
receding). One scan of ``n`` detections is the linear model ``d = -U v + e``; :func:`fit_ego_velocity`
fits it robustly (RANSAC on minimal sets of 2 or 3 detections, then least squares on the
consensus set, refined once), with the covariance ``s^2 (U_I^T U_I)^-1`` from the inliers'
residual variance, and a chi-square test of ``v = 0`` (the platform at rest).
:func:`moving_mask` tests each detection against the static-world prediction (c.10.4).

The arithmetic is the plain kernels of :mod:`radarslam.models.doppler_kernels`, called compiled
(:mod:`radarslam.models._doppler_compiled`); ``benchmarks/bench_ego_motion.py`` times the fit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError
from radarslam.models import _doppler_compiled as _C
from radarslam.models._ransac import ransac_kernel  # noqa: F401  (re-exported)
from radarslam.models.doppler_kernels import CLIP_SIGMAS  # noqa: F401  (re-exported)

__all__ = ["EgoVelocity", "directions", "fit_ego_velocity", "mounted_directions", "moving_mask", "moving_objects",
           "object_statistic", "sensor_velocity"]


@dataclass(frozen=True)
class EgoVelocity:
    """One scan's ego-velocity fit (docs/method.md c.10).

    Attributes
    ----------
    v : ndarray, shape (dim,)
        Sensor velocity in the sensor frame (m/s); NaN when not ``valid``.
    cov : ndarray, shape (dim, dim)
        Its covariance (m^2/s^2); NaN when not ``valid``.
    inliers : ndarray of bool, shape (n,)
        The consensus set the least squares used.
    sigma_mps : float
        Residual std of the inliers (m/s), floored at ``sigma_floor_mps``.
    zero_stat : float
        ``v^T cov^-1 v``, chi-square with ``dim`` dof when the sensor is at rest.
    at_rest : bool
        ``zero_stat`` below the ``zero_probability`` quantile.
    valid : bool
        Enough detections and a large enough consensus (c.10.3).
    """

    v: np.ndarray
    cov: np.ndarray
    inliers: np.ndarray
    sigma_mps: float
    zero_stat: float
    at_rest: bool
    valid: bool

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())


def directions(polar: np.ndarray, z: np.ndarray | None = None) -> np.ndarray:
    """Unit directions from the sensor, ``(n, 2)`` from ``polar`` ``[range m, azimuth rad]`` or
    ``(n, 3)`` when the heights ``z`` (m, sensor frame, ``(n,)``) are given (``range`` is then the
    horizontal range, as the bag reader's ``hypot(x, y)``)."""
    polar = np.asarray(polar, dtype=float).reshape(-1, 2)
    c, s = np.cos(polar[:, 1]), np.sin(polar[:, 1])
    if z is None:
        return np.column_stack([c, s])
    z = np.asarray(z, dtype=float)
    if z.shape != (polar.shape[0],):
        raise InputError(f"z: expected shape ({polar.shape[0]},), got {z.shape}")
    r = polar[:, 0]
    n = np.hypot(r, z)
    n = np.where(n > 0, n, 1.0)
    return np.column_stack([r * c / n, r * s / n, z / n])


def mounted_directions(polar: np.ndarray, mount_x: float = 0.0, mount_y: float = 0.0,
                       mount_yaw: float = 0.0) -> np.ndarray:
    """Unit directions ``(n, 2)`` from a sensor mounted at ``(mount_x, mount_y)`` (m) with boresight
    ``mount_yaw`` (rad), in the sensor frame, of detections given as platform-frame ``polar``
    ``[range m, azimuth rad]`` about the platform origin (c.10.1): ``q = R(-yaw_m)(p - l)``,
    ``u = q / |q|`` (:func:`~radarslam.models.doppler_kernels.mounted_dirs`); a zero mounting gives
    :func:`directions`."""
    polar = np.ascontiguousarray(np.asarray(polar, dtype=float).reshape(-1, 2))
    return _C.mounted_dirs(polar, float(mount_x), float(mount_y), float(mount_yaw))


def sensor_velocity(v_forward: float, v_lateral: float, yaw_rate: float, mount_x: float = 0.0,
                    mount_y: float = 0.0, mount_yaw: float = 0.0) -> np.ndarray:
    """Velocity ``(2,)`` (m/s) of a sensor mounted at ``(mount_x, mount_y)`` (m) with boresight
    ``mount_yaw`` (rad) on a platform moving at ``(v_forward, v_lateral)`` (m/s) turning at
    ``yaw_rate`` (rad/s), in the sensor frame (c.10.1): ``R(-yaw_m) (v + omega x l)``."""
    vx = v_forward - yaw_rate * mount_y
    vy = v_lateral + yaw_rate * mount_x
    c, s = math.cos(mount_yaw), math.sin(mount_yaw)
    return np.array([c * vx + s * vy, -s * vx + c * vy])


#: chi-square quantiles are cached by (probability, dof).
_CHI2: dict[tuple[float, int], float] = {}


def chi2_quantile(p: float, dof: int) -> float:
    """The ``p`` quantile of the chi-square law with ``dof`` degrees of freedom."""
    key = (float(p), int(dof))
    if key not in _CHI2:
        from scipy.stats import chi2

        _CHI2[key] = float(chi2.ppf(p, dof))
    return _CHI2[key]


def fit_ego_velocity(U: np.ndarray, doppler: np.ndarray, rng: np.random.Generator, *, threshold_mps: float = 0.3,
                     iterations: int = 50, sigma_floor_mps: float = 0.0, zero_probability: float = 0.99,
                     min_inlier_fraction: float = 0.3) -> EgoVelocity:
    """The sensor velocity of one scan (docs/method.md c.10.2-c.10.3).

    Parameters
    ----------
    U : ndarray, shape (n, dim)
        Unit directions of the detections from the sensor (dim 2 or 3, :func:`directions`).
    doppler : ndarray, shape (n,)
        Radial velocities (m/s, positive receding).
    rng : numpy.random.Generator
        Draws the minimal sets (``iterations`` of them).
    threshold_mps : float
        Consensus threshold on ``|d_i + u_i . v|`` (m/s), about 3 noise stds.
    iterations : int
        Minimal sets tried (50 finds a clean pair with probability 1 - 1e-9 at 40% outliers in 2-D).
    sigma_floor_mps : float
        Floor of the residual std (m/s): a quantised Doppler (steps q) has at least ``q / sqrt(12)``.
    zero_probability : float
        Probability of the chi-square test of ``v = 0``.
    min_inlier_fraction : float
        A consensus below this fraction of the scan (or below ``dim + 2`` detections) is not valid.
    """
    U = np.ascontiguousarray(U, dtype=np.float64)
    d = np.ascontiguousarray(doppler, dtype=np.float64)
    if U.ndim != 2 or U.shape[1] not in (2, 3):
        raise InputError(f"U: expected shape (n, 2) or (n, 3), got {U.shape}")
    if d.shape != (U.shape[0],):
        raise InputError(f"doppler: expected shape ({U.shape[0]},), got {d.shape}")
    if not (threshold_mps > 0 and iterations >= 1):
        raise InputError(f"threshold_mps, iterations: expected > 0 and >= 1, got {threshold_mps}, {iterations}")
    dim = U.shape[1]
    v, cov, mask, sigma, stat, rest, valid = _C.ego_fit(U, d, rng, int(iterations), float(threshold_mps),
                                                         float(sigma_floor_mps), float(min_inlier_fraction),
                                                         chi2_quantile(zero_probability, dim))
    return EgoVelocity(v, cov, mask, float(sigma), float(stat), bool(rest), bool(valid))


def moving_mask(U: np.ndarray, doppler: np.ndarray, ego: EgoVelocity, probability: float = 0.99) -> np.ndarray:
    """Detections whose Doppler fails the static-world test (c.10.4), ``(n,)`` bool.

    ``(d_i + u_i . v)^2 / (s^2 + u_i^T C u_i) > chi2_1(probability)``. An invalid fit marks none.
    """
    U = np.ascontiguousarray(U, dtype=float)
    if not ego.valid:
        return np.zeros(U.shape[0], dtype=bool)
    return _C.moving_test(U, np.ascontiguousarray(doppler, dtype=float), np.ascontiguousarray(ego.v, dtype=float),
                          np.ascontiguousarray(ego.cov, dtype=float), ego.sigma_mps ** 2, chi2_quantile(probability, 1))


def object_statistic(U: np.ndarray, r: np.ndarray, s2: float, cov: np.ndarray) -> tuple[float, int]:
    """The static-world test of one object's detections pooled (c.10.4.2): ``(T, dof)``.

    ``r`` (m,) are the detections' Doppler residuals ``d_i + u_i . v`` against the ego fit ``v``
    (covariance ``cov``, residual variance ``s2``), ``U`` (m, dim) their directions; for a static
    object ``Cov(r) = s2 I + U cov U^T``. The object's own velocity ``w = (U^T U)^-1 U^T r`` then has
    covariance ``s2 (U^T U)^-1 + cov``, and ``T = w^T (s2 (U^T U)^-1 + cov)^-1 w`` is chi-square with
    ``dof = dim``. When the directions are (nearly) parallel (``m = 1`` or ``det(U^T U) <= 1e-9``)
    only the radial part is tested: the mean residual ``r_bar`` with variance
    ``s2 / m + u_bar^T cov u_bar``, ``T = r_bar^2 / var`` with 1 dof.
    """
    T, dof = _C.object_stat(np.ascontiguousarray(U, dtype=float), np.ascontiguousarray(r, dtype=float), float(s2),
                            np.ascontiguousarray(cov, dtype=float))
    return float(T), int(dof)


def moving_objects(U: np.ndarray, doppler: np.ndarray, ego: EgoVelocity, labels: np.ndarray,
                   probability: float = 0.999) -> np.ndarray:
    """Detections of the objects whose Doppler fails the static-world test (c.10.4.2).

    ``labels`` (n,) group the detections into objects (single linkage within a radius). Each
    detection's residual ``r_i = d_i + u_i . v`` is clipped to ``+-CLIP_SIGMAS sigma_i``
    (``sigma_i^2 = s^2 + u_i^T C u_i``) and an object of ``m >= 2`` detections moves when
    :func:`object_statistic` of the clipped residuals exceeds its chi-square ``probability``
    quantile. Returns the moving detections ``(n,)`` bool (none when the fit is not valid).
    """
    U = np.ascontiguousarray(U, dtype=float)
    n = U.shape[0]
    if not ego.valid or n < 2:
        return np.zeros(n, dtype=bool)
    dim = U.shape[1]
    return _C.moving_groups(U, np.ascontiguousarray(doppler, dtype=float), np.ascontiguousarray(ego.v, dtype=float),
                            np.ascontiguousarray(ego.cov, dtype=float), ego.sigma_mps ** 2,
                            np.ascontiguousarray(labels, dtype=np.int64), chi2_quantile(probability, 1),
                            chi2_quantile(probability, dim))
