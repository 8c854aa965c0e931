"""Ego-motion from Doppler: the sensor's velocity fitted to one scan's radial velocities
(docs/method.md c.10).

For a static point seen in the unit direction ``u`` (from the sensor, sensor frame) the radial
velocity is ``d = -u . v`` with ``v`` the sensor's velocity in the sensor frame (positive =
receding). One scan of ``n`` detections is the linear model ``d = -U v + e``; :func:`fit_ego_velocity`
fits it robustly (RANSAC on minimal sets of 2 or 3 detections, then least squares on the
consensus set, refined once), with the covariance ``s^2 (U_I^T U_I)^-1`` from the inliers'
residual variance, and a chi-square test of ``v = 0`` (the platform at rest).
:func:`moving_mask` tests each detection against the static-world prediction (c.10.4).

The kernel is compiled (numba); ``benchmarks/bench_ego_motion.py`` times it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from radarslam.core.errors import InputError

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
    ``u = q / |q|``. A zero mounting gives :func:`directions` exactly."""
    if mount_x == 0.0 and mount_y == 0.0 and mount_yaw == 0.0:
        return directions(polar)
    polar = np.asarray(polar, dtype=float).reshape(-1, 2)
    x = polar[:, 0] * np.cos(polar[:, 1]) - mount_x
    y = polar[:, 0] * np.sin(polar[:, 1]) - mount_y
    c, s = math.cos(mount_yaw), math.sin(mount_yaw)
    q = np.column_stack([c * x + s * y, -s * x + c * y])
    n = np.hypot(q[:, 0], q[:, 1])
    return q / np.where(n > 0, n, 1.0)[:, None]


def sensor_velocity(v_forward: float, v_lateral: float, yaw_rate: float, mount_x: float = 0.0,
                    mount_y: float = 0.0, mount_yaw: float = 0.0) -> np.ndarray:
    """Velocity ``(2,)`` (m/s) of a sensor mounted at ``(mount_x, mount_y)`` (m) with boresight
    ``mount_yaw`` (rad) on a platform moving at ``(v_forward, v_lateral)`` (m/s) turning at
    ``yaw_rate`` (rad/s), in the sensor frame (c.10.1): ``R(-yaw_m) (v + omega x l)``."""
    vx = v_forward - yaw_rate * mount_y
    vy = v_lateral + yaw_rate * mount_x
    c, s = math.cos(mount_yaw), math.sin(mount_yaw)
    return np.array([c * vx + s * vy, -s * vx + c * vy])


@njit(cache=True)
def _solve_small(A, b, dim):  # pragma: no cover - compiled
    """``A x = b`` for ``dim`` 2 or 3 by Cramer's rule; ``ok`` False when (nearly) singular."""
    x = np.zeros(dim)
    if dim == 2:
        det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
        if abs(det) < 1e-9:
            return x, False
        x[0] = (b[0] * A[1, 1] - A[0, 1] * b[1]) / det
        x[1] = (A[0, 0] * b[1] - b[0] * A[1, 0]) / det
        return x, True
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    if abs(det) < 1e-9:
        return x, False
    inv = np.empty((3, 3))
    inv[0, 0], inv[1, 0], inv[2, 0] = c00, c01, c02
    inv[0, 1] = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
    inv[1, 1] = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
    inv[2, 1] = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
    inv[0, 2] = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
    inv[1, 2] = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
    inv[2, 2] = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    for i in range(3):
        x[i] = (inv[i, 0] * b[0] + inv[i, 1] * b[1] + inv[i, 2] * b[2]) / det
    return x, True


@njit(cache=True)
def _least_squares(U, d, mask, dim):  # pragma: no cover - compiled
    """``v`` minimising ``sum_I (d + U v)^2`` over ``mask``, ``(U_I^T U_I)`` and the RSS (c.10.2)."""
    N = np.zeros((dim, dim))
    g = np.zeros(dim)
    for i in range(U.shape[0]):
        if mask[i]:
            for a in range(dim):
                g[a] -= U[i, a] * d[i]
                for b in range(dim):
                    N[a, b] += U[i, a] * U[i, b]
    v, ok = _solve_small(N, g, dim)
    rss = 0.0
    for i in range(U.shape[0]):
        if mask[i]:
            r = d[i]
            for a in range(dim):
                r += U[i, a] * v[a]
            rss += r * r
    return v, N, rss, ok


@njit(cache=True)
def _consensus(U, d, v, threshold, dim, mask):  # pragma: no cover - compiled
    """Mark ``|d + U v| <= threshold`` in ``mask``; the count and the inliers' squared residuals."""
    cnt = 0
    sq = 0.0
    for i in range(U.shape[0]):
        r = d[i]
        for a in range(dim):
            r += U[i, a] * v[a]
        if abs(r) <= threshold:
            mask[i] = True
            cnt += 1
            sq += r * r
        else:
            mask[i] = False
    return cnt, sq


@njit(cache=True)
def ransac_kernel(U, d, rng, iterations, threshold):  # pragma: no cover - compiled
    """RANSAC over ``iterations`` minimal sets drawn from ``rng``, then least squares on the best
    consensus refined once (c.10.2). Returns ``(v (dim,), N = U_I^T U_I (dim, dim), rss, mask (n,),
    ok)``."""
    n, dim = U.shape
    best = np.zeros(n, dtype=np.bool_)
    mask = np.zeros(n, dtype=np.bool_)
    best_cnt, best_sq = -1, np.inf
    A = np.empty((dim, dim))
    b = np.empty(dim)
    idx = np.empty(dim, dtype=np.int64)
    if n < dim:
        return np.zeros(dim), np.zeros((dim, dim)), 0.0, best, False
    for _ in range(iterations):
        for a in range(dim):          # distinct, uniform: draw among the n - a left, step over the taken
            j = rng.integers(0, n - a)
            for c in range(a):        # idx[:a] is kept sorted
                if j >= idx[c]:
                    j += 1
            q = a                     # insert j in order
            while q > 0 and idx[q - 1] > j:
                idx[q] = idx[q - 1]
                q -= 1
            idx[q] = j
        for a in range(dim):
            b[a] = -d[idx[a]]
            for c in range(dim):
                A[a, c] = U[idx[a], c]
        v, ok = _solve_small(A, b, dim)
        if not ok:
            continue
        cnt, sq = _consensus(U, d, v, threshold, dim, mask)
        if cnt > best_cnt or (cnt == best_cnt and sq < best_sq):
            best_cnt, best_sq = cnt, sq
            best[:] = mask
    if best_cnt < dim:
        return np.zeros(dim), np.zeros((dim, dim)), 0.0, best, False
    v, N, rss, ok = _least_squares(U, d, best, dim)
    if ok:                            # one refinement: the consensus of the least-squares fit
        cnt, _ = _consensus(U, d, v, threshold, dim, mask)
        if cnt >= dim + 1:
            v2, N2, rss2, ok2 = _least_squares(U, d, mask, dim)
            if ok2:
                return v2, N2, rss2, mask.copy(), True
    return v, N, rss, best, ok


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
    v, N, rss, mask, ok = ransac_kernel(U, d, rng, int(iterations), float(threshold_mps))
    n_in = int(mask.sum())
    valid = bool(ok) and n_in >= dim + 2 and n_in >= min_inlier_fraction * U.shape[0]
    if not valid:
        nan = np.full(dim, np.nan)
        return EgoVelocity(nan, np.full((dim, dim), np.nan), mask, math.nan, math.nan, False, False)
    s2 = max(rss / (n_in - dim), sigma_floor_mps ** 2)
    cov = s2 * np.linalg.inv(N)
    stat = float(v @ np.linalg.solve(cov, v))
    return EgoVelocity(v, cov, mask, math.sqrt(s2), stat, stat <= chi2_quantile(zero_probability, dim), True)


def moving_mask(U: np.ndarray, doppler: np.ndarray, ego: EgoVelocity, probability: float = 0.99) -> np.ndarray:
    """Detections whose Doppler fails the static-world test (c.10.4), ``(n,)`` bool.

    ``(d_i + u_i . v)^2 / (s^2 + u_i^T C u_i) > chi2_1(probability)``. An invalid fit marks none.
    """
    U = np.asarray(U, dtype=float)
    if not ego.valid:
        return np.zeros(U.shape[0], dtype=bool)
    r = np.asarray(doppler, dtype=float) + U @ ego.v
    var = ego.sigma_mps ** 2 + np.einsum("ia,ab,ib->i", U, ego.cov, U)
    return r * r > chi2_quantile(probability, 1) * var


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
    m = U.shape[0]
    N = U.T @ U
    if m >= 2 and np.linalg.det(N) > 1e-9:
        w = np.linalg.solve(N, U.T @ r)
        return float(w @ np.linalg.solve(s2 * np.linalg.inv(N) + cov, w)), U.shape[1]
    ub = U.mean(axis=0)
    rb = float(r.mean())
    return rb * rb / (s2 / m + float(ub @ cov @ ub)), 1


#: Residuals are clipped at this many of their own stds before an object's detections are pooled
#: (c.10.4.2): one clutter detection (Doppler anywhere in +-5 m/s) weighs no more than a 3-sigma one.
CLIP_SIGMAS = 3.0


def moving_objects(U: np.ndarray, doppler: np.ndarray, ego: EgoVelocity, labels: np.ndarray,
                   probability: float = 0.999) -> np.ndarray:
    """Detections of the objects whose Doppler fails the static-world test (c.10.4.2).

    ``labels`` (n,) group the detections into objects (single linkage within a radius). Each
    detection's residual ``r_i = d_i + u_i . v`` is clipped to ``+-CLIP_SIGMAS sigma_i``
    (``sigma_i^2 = s^2 + u_i^T C u_i``) and an object of ``m >= 2`` detections moves when
    :func:`object_statistic` of the clipped residuals exceeds its chi-square ``probability``
    quantile. Returns the moving detections ``(n,)`` bool (none when the fit is not valid).
    """
    n = U.shape[0]
    out = np.zeros(n, dtype=bool)
    if not ego.valid or n < 2:
        return out
    s2 = ego.sigma_mps ** 2
    sd = np.sqrt(s2 + np.einsum("ia,ab,ib->i", U, ego.cov, U))
    r = np.clip(np.asarray(doppler, dtype=float) + U @ ego.v, -CLIP_SIGMAS * sd, CLIP_SIGMAS * sd)
    order = np.argsort(labels, kind="stable")
    bounds = np.flatnonzero(np.diff(labels[order])) + 1
    for rows in np.split(order, bounds):
        if rows.size < 2:
            continue
        T, dof = object_statistic(U[rows], r[rows], s2, ego.cov)
        out[rows] = T > chi2_quantile(probability, dof)
    return out
    s2 = ego.sigma_mps ** 2
    r = np.asarray(doppler, dtype=float) + U @ ego.v
    z2 = r * r / (s2 + np.einsum("ia,ab,ib->i", U, ego.cov, U))
    order = np.argsort(labels, kind="stable")
    bounds = np.flatnonzero(np.diff(labels[order])) + 1
    for rows in np.split(order, bounds):
        if rows.size < 2:
            continue
        if flagged[rows].sum() >= 2:
            out[rows], tail[rows] = True, 0.0
            continue
        test = rows if rows.size < 3 else np.delete(rows, np.argmax(z2[rows]))
        T, dof = object_statistic(U[test], r[test], s2, ego.cov)
        out[rows] = T > chi2_quantile(probability, dof)
    return out
