"""The per-scan Doppler arithmetic as plain kernels (docs/method.md c.10.1-c.10.4; docs/architecture.md
"One source for each kernel").

Each function is in the subset of Python and numpy that numba compiles as it is; the compiled forms
(:mod:`radarslam.models._doppler_compiled`, by :func:`radarslam.core.jit.compile_kernels`) are
what :func:`~radarslam.models.doppler.fit_ego_velocity`, :class:`~radarslam.slam.doppler_gate.DopplerGate`
and the fused engine's stream call; tests/test_doppler_kernels.py checks the two forms equal. The
RANSAC draws (:func:`~radarslam.models._ransac.ransac_kernel`) and the DBSCAN
(:func:`~radarslam.landmarks._compiled.dbscan_labels`) are compiled in both forms. The chi-square
quantiles are the caller's (``q_*``: scipy's, :func:`~radarslam.models.doppler.chi2_quantile`).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.landmarks._compiled import dbscan_labels
from radarslam.models._ransac import ransac_kernel

#: Residuals are clipped at this many of their own stds before an object's detections are pooled
#: (c.10.4.2): one clutter detection (Doppler anywhere in +-5 m/s) weighs no more than a 3-sigma one.
CLIP_SIGMAS = 3.0


def mounted_dirs(polar, mount_x, mount_y, mount_yaw):
    """Unit directions ``(n, 2)`` from a sensor mounted at ``(mount_x, mount_y)`` with boresight
    ``mount_yaw`` of platform-frame ``[range, azimuth]`` detections (c.10.1): ``q = R(-yaw_m)(p - l)``,
    ``u = q / |q|``; a zero mounting gives ``(cos a, sin a)``."""
    n = polar.shape[0]
    U = np.empty((n, 2))
    zero = mount_x == 0.0 and mount_y == 0.0 and mount_yaw == 0.0
    c, s = math.cos(mount_yaw), math.sin(mount_yaw)
    for i in range(n):
        ca, sa = math.cos(polar[i, 1]), math.sin(polar[i, 1])
        if zero:
            U[i, 0], U[i, 1] = ca, sa
            continue
        x = polar[i, 0] * ca - mount_x
        y = polar[i, 0] * sa - mount_y
        q0, q1 = c * x + s * y, -s * x + c * y
        h = math.hypot(q0, q1)
        h = h if h > 0 else 1.0
        U[i, 0], U[i, 1] = q0 / h, q1 / h
    return U


def inv_small(A):
    """``A^-1`` of a 2 x 2 (adjugate over the determinant) or larger (LAPACK) matrix."""
    if A.shape[0] != 2:
        return np.linalg.inv(A)
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    out = np.empty((2, 2))
    out[0, 0], out[0, 1] = A[1, 1] / det, -A[0, 1] / det
    out[1, 0], out[1, 1] = -A[1, 0] / det, A[0, 0] / det
    return out


def solve_small(A, b):
    """``A^-1 b`` of a 2 x 2 (Cramer's rule) or larger (LAPACK) system."""
    if A.shape[0] != 2:
        return np.linalg.solve(A, b)
    det = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    x = np.empty(2)
    x[0] = (b[0] * A[1, 1] - A[0, 1] * b[1]) / det
    x[1] = (A[0, 0] * b[1] - b[0] * A[1, 0]) / det
    return x


def det_small(A):
    """``det A`` of a 2 x 2 (closed form) or larger (LAPACK) matrix."""
    if A.shape[0] != 2:
        return np.linalg.det(A)
    return A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]


#: The refit keeps residuals within this many robust stds, and the variance of a standard normal
#: truncated there corrects its residual variance (``1 - 2 c phi(c) / (2 Phi(c) - 1)`` at c = 3).
REFIT_SIGMAS = 3.0
TRUNCATED_VARIANCE = 0.97334
#: Robust scale: ``1.4826 median |r|`` estimates the std of normal residuals (MAD consistency).
MAD_TO_STD = 1.4826
#: Passes of :func:`robust_refit` at most (the set holds after 3-5 on simulated scans).
REFIT_PASSES = 10


def robust_refit(U, d, v, s, s_max, mask):
    """The least squares again on the residuals within :data:`REFIT_SIGMAS` stds of the fit, the std
    re-estimated from them (corrected for that truncation) until it holds to 0.1% (c.10.3; at most
    :data:`REFIT_PASSES` passes). It starts from the consensus fit ``v`` with the robust std
    ``1.4826 median_i |d_i + u_i . v|`` of ALL the scan's residuals, kept between the consensus's own
    residual std ``s`` (truncated at the RANSAC threshold, so low) and ``s_max`` (the threshold, at
    least one noise std; every pass is held below it: a majority of outliers, beyond the median's
    breakdown, never blows the set up). The set ``I`` is written into ``mask``; whether the scan has
    a fit is its consensus's to say (:func:`ego_fit`). Returns
    ``(v, N = U_I^T U_I, s^2, n_I, ok)``, ``s^2 = sum_I r_i^2 / (n_I - dim) / TRUNCATED_VARIANCE``.

    The consensus threshold of RANSAC is tight and its least squares confirms the points near its own
    estimate, so the inliers' RSS underestimates the error of that estimate (velocity NEES 5.6 at a
    1.5-sigma threshold, 3.1 at 2 sigma, where 2 is consistent); a set chosen by the residuals' own
    scale, wide enough to hold the noise's tails, gives 2.2-2.6 (tests/test_doppler_covariance.py)."""
    n, dim = U.shape
    r = np.empty(n)
    for i in range(n):
        r[i] = d[i]
        for a in range(dim):
            r[i] += U[i, a] * v[a]
    s = min(max(s, MAD_TO_STD * np.median(np.abs(r))), s_max)
    N = np.zeros((dim, dim))
    n_in = 0
    for _ in range(REFIT_PASSES):
        n_in = 0
        for i in range(n):
            mask[i] = abs(r[i]) <= REFIT_SIGMAS * s
            if mask[i]:
                n_in += 1
        N = np.zeros((dim, dim))
        g = np.zeros(dim)
        for i in range(n):
            if mask[i]:
                for a in range(dim):
                    g[a] -= U[i, a] * d[i]
                    for b in range(dim):
                        N[a, b] += U[i, a] * U[i, b]
        if n_in < dim + 1 or abs(det_small(N)) < 1e-9:
            return v, N, 0.0, n_in, False
        v = solve_small(N, g)
        rss = 0.0
        for i in range(n):
            r[i] = d[i]
            for a in range(dim):
                r[i] += U[i, a] * v[a]
            if mask[i]:
                rss += r[i] * r[i]
        s_new = min(math.sqrt(rss / (n_in - dim) / TRUNCATED_VARIANCE), s_max)
        done = abs(s_new - s) <= 1e-3 * s
        s = s_new
        if done:
            break
    return v, N, s * s, n_in, True


def ego_fit(U, d, rng, iterations, threshold, sigma_floor, min_fraction, q_zero):
    """The sensor velocity of one scan (c.10.2-c.10.3): RANSAC with ``rng``, least squares on the
    consensus, refitted on the residuals within 3 robust stds (:func:`robust_refit`),
    ``cov = s^2 (U_I^T U_I)^-1`` with ``s^2 = max(s_I^2, sigma_floor^2)``, and the test
    ``v^T cov^-1 v <= q_zero`` of rest. Returns ``(v, cov, inliers, sigma, stat, at_rest, valid)``,
    ``v``, ``cov``, ``sigma`` and ``stat`` NaN when not valid: a consensus below ``dim + 2`` or below
    ``min_fraction`` of the scan (or a refit set below ``dim + 2``), or no residual spread to scale the covariance
    by (``s^2 = 0``: a scan of exact or quantised-to-zero Doppler without ``sigma_floor``) -- a scan
    without a fit, never a division by zero."""
    n, dim = U.shape
    v, N, rss, mask, ok = ransac_kernel(U, d, rng, iterations, threshold)
    n_in = 0
    for i in range(n):
        if mask[i]:
            n_in += 1
    s2 = 0.0
    if ok and n_in >= dim + 2 and n_in >= min_fraction * n:     # the consensus decides whether there is a fit
        v, N, s2, n_ref, ok = robust_refit(U, d, v, math.sqrt(rss / (n_in - dim)), threshold, mask)
        ok = ok and n_ref >= dim + 2
    s2 = max(s2, sigma_floor ** 2)
    if not (ok and n_in >= dim + 2 and n_in >= min_fraction * n and s2 > 0 and math.isfinite(s2)):
        return np.full(dim, np.nan), np.full((dim, dim), np.nan), mask, math.nan, math.nan, False, False
    cov = s2 * inv_small(N)
    stat = np.dot(v, solve_small(cov, v))
    return v, cov, mask, math.sqrt(s2), stat, stat <= q_zero, True


def residuals(U, d, v, cov, s2):
    """Each detection's Doppler residual ``d_i + u_i . v`` against the static world and its variance
    ``s2 + u_i^T cov u_i`` (c.10.4.1), ``(n,)`` each."""
    n, dim = U.shape
    r = np.empty(n)
    var = np.empty(n)
    for i in range(n):
        uv = 0.0
        ucu = 0.0
        for a in range(dim):
            uv += U[i, a] * v[a]
            for b in range(dim):
                ucu += U[i, a] * cov[a, b] * U[i, b]
        r[i] = d[i] + uv
        var[i] = s2 + ucu
    return r, var


def moving_test(U, d, v, cov, s2, q):
    """Detections whose Doppler fails the static-world test (c.10.4.1): ``r_i^2 > q var_i``."""
    r, var = residuals(U, d, v, cov, s2)
    return r * r > q * var


def object_stat(U, r, s2, cov):
    """The static-world test of one object's pooled residuals ``r`` (c.10.4.2): ``(T, dof)``, the
    object's own velocity ``w = (U^T U)^-1 U^T r`` against ``s2 (U^T U)^-1 + cov`` (``dof = dim``), or
    when the directions are (nearly) parallel the mean residual against ``s2 / m + u_bar^T cov u_bar``
    (1 dof)."""
    m, dim = U.shape
    N = np.zeros((dim, dim))
    g = np.zeros(dim)
    for i in range(m):
        for a in range(dim):
            g[a] += U[i, a] * r[i]
            for b in range(dim):
                N[a, b] += U[i, a] * U[i, b]
    if m >= 2 and det_small(N) > 1e-9:
        w = solve_small(N, g)
        return np.dot(w, solve_small(s2 * inv_small(N) + cov, w)), dim
    ub = np.zeros(dim)
    rb = 0.0
    for i in range(m):
        rb += r[i]
        for a in range(dim):
            ub[a] += U[i, a]
    ub /= m
    rb /= m
    ucu = 0.0
    for a in range(dim):
        for b in range(dim):
            ucu += ub[a] * cov[a, b] * ub[b]
    return rb * rb / (s2 / m + ucu), 1


def moving_groups(U, d, v, cov, s2, labels, q_one, q_dim):
    """Detections of the objects (``labels``, one per detection) whose clipped residuals fail
    :func:`object_stat` at the quantile ``q_one`` (1 dof) or ``q_dim`` (``dim`` dof) (c.10.4.2);
    objects of one detection are not tested."""
    n = U.shape[0]
    out = np.zeros(n, dtype=np.bool_)
    r, var = residuals(U, d, v, cov, s2)
    for i in range(n):
        lim = CLIP_SIGMAS * math.sqrt(var[i])
        r[i] = min(max(r[i], -lim), lim)
    order = np.argsort(labels, kind="mergesort")
    start = 0
    while start < n:
        end = start + 1
        while end < n and labels[order[end]] == labels[order[start]]:
            end += 1
        if end - start >= 2:
            rows = order[start:end]
            T, dof = object_stat(U[rows], r[rows], s2, cov)
            moving = T > (q_one if dof == 1 else q_dim)
            for k in range(start, end):
                out[order[k]] = moving
        start = end
    return out


def classify_scan(polar, d, mount_x, mount_y, mount_yaw, rng, iterations, threshold, sigma_floor, min_fraction,
                  q_zero, q_gate, radius, q_one, q_two):
    """The Doppler gate's steps 1-3 on one scan (c.10.4; :meth:`DopplerGate.classify`): the ego fit
    (:func:`ego_fit` of the mounted directions), the per-detection test at ``q_gate``, and when
    ``radius > 0`` and the scan has two detections or more, the objects (single linkage within
    ``radius`` of the platform-frame positions) tested at ``q_one`` / ``q_two``. Returns
    ``(v, cov, inliers, sigma, stat, at_rest, valid, bad (n,), objects (n,), tested)``."""
    n = polar.shape[0]
    U = mounted_dirs(polar, mount_x, mount_y, mount_yaw)
    v, cov, inl, sigma, stat, rest, valid = ego_fit(U, d, rng, iterations, threshold, sigma_floor, min_fraction,
                                                    q_zero)
    bad = np.zeros(n, dtype=np.bool_)
    objects = np.zeros(n, dtype=np.bool_)
    if valid:
        bad = moving_test(U, d, v, cov, sigma ** 2, q_gate)
    tested = radius > 0 and n >= 2
    if tested and valid:
        xy = np.empty((n, 2))
        for i in range(n):
            xy[i, 0] = polar[i, 0] * math.cos(polar[i, 1])
            xy[i, 1] = polar[i, 0] * math.sin(polar[i, 1])
        objects = moving_groups(U, d, v, cov, sigma ** 2, dbscan_labels(xy, radius, 1), q_one, q_two)
        bad = bad | objects
    return v, cov, inl, sigma, stat, rest, valid, bad, objects, tested


#: The kernels, for :func:`radarslam.core.jit.compile_kernels`.
KERNELS = (inv_small, solve_small, det_small, mounted_dirs, robust_refit, ego_fit, residuals, moving_test, object_stat,
           moving_groups, classify_scan)
