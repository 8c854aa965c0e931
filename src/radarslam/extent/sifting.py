"""Extent-aware sifting tests (docs/method.md a.7.1, Decision 6, h.12).

Two tests decide whether a detection ``z`` (world frame, predicted pose) is a candidate for a
landmark whose extent is initialised:

- the *measurement contour* (the default): ``z`` lies inside the gate of the landmark's predicted
  detection spread, ``(z - p)^T (gamma_z X + W(z) + P^n)^-1 (z - p) <= g``, with ``W(z)`` the
  covariance of the converted detection (seed eq. 5: pose uncertainty and sensor noise), ``P^n``
  the centroid's covariance and ``g`` the chi-square(2) quantile of the gate probability;
- the *literal* contour of the paper, ``(z - p)^T X^-1 (z - p) <= kappa^2``, kept for ablations: it
  has no term for noise or uncertainty and rejects the corners and the noise spill of a car.

Both return an ``(m, N)`` boolean matrix; rows are detections, columns landmarks. Each is one
kernel of plain loops (no ``(m, N, 2, 2)`` temporaries), run as it is by the engine's Python form
and compiled for the fused engine.
"""

from __future__ import annotations

import math

import numpy as np


def chi2_2dof_quantile(probability: float) -> float:
    """The chi-square(2) quantile of ``probability``: ``-2 log(1 - p)`` (closed form for 2 dof)."""
    if not 0.0 < probability < 1.0:
        raise ValueError(f"probability: expected a value in (0, 1), got {probability!r}")
    return -2.0 * math.log1p(-probability)


def literal_inside(points: np.ndarray, centroids: np.ndarray, X: np.ndarray, has: np.ndarray,
                   kk: float) -> np.ndarray:
    """The literal contour of a.7.1 (seed), a kernel: ``(m, N)`` with ``(z_i - p_n)^T X_n^-1 (z_i -
    p_n) <= kk`` (``kk = kappa^2``) for the landmarks with ``has[n]``, False for the others. The fused engine
    links it compiled (:mod:`._compiled`)."""
    m, n = points.shape[0], centroids.shape[0]
    out = np.zeros((m, n), dtype=np.bool_)
    for j in range(n):
        if not has[j]:
            continue
        det = X[j, 0, 0] * X[j, 1, 1] - X[j, 0, 1] * X[j, 1, 0]
        i00, i01, i10, i11 = X[j, 1, 1] / det, -X[j, 0, 1] / det, -X[j, 1, 0] / det, X[j, 0, 0] / det
        for i in range(m):
            d0 = points[i, 0] - centroids[j, 0]
            d1 = points[i, 1] - centroids[j, 1]
            out[i, j] = d0 * (i00 * d0 + i01 * d1) + d1 * (i10 * d0 + i11 * d1) <= kk
    return out


def literal_contour(points: np.ndarray, centroids: np.ndarray, X: np.ndarray, kappa: float,
                    has: np.ndarray | None = None, kernel=literal_inside) -> np.ndarray:
    """``(z_i - p_n)^T X_n^-1 (z_i - p_n) <= kappa^2`` as an ``(m, N)`` boolean matrix (every
    landmark, or those with ``has``), through :func:`literal_inside` or its compiled ``kernel``."""
    has = np.ones(centroids.shape[0], dtype=bool) if has is None else np.asarray(has, dtype=bool)
    return kernel(np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(centroids, dtype=float),
                  np.ascontiguousarray(X, dtype=float), has, float(kappa) * float(kappa))


def contour_inside(points: np.ndarray, W: np.ndarray, centroids: np.ndarray, spreads: np.ndarray,
                   centroid_covs: np.ndarray, gate: float) -> np.ndarray:
    """The measurement contour of a.7.1, a kernel: ``(m, N)`` with ``(z_i - p_n)^T (S_n + P_n +
    W_i)^-1 (z_i - p_n) <= gate``. The fused engine links it compiled
    (:mod:`._compiled`).

    Parameters
    ----------
    points : (m, 2)
        Detections in the world frame.
    W : (m, 2, 2)
        Their converted-measurement covariances (seed eq. 5).
    centroids, spreads, centroid_covs : (N, 2), (N, 2, 2), (N, 2, 2)
        Landmark centroids, detection spreads ``gamma_z X`` and centroid covariances ``P^n``.
    gate : float
        The chi-square(2) quantile (:func:`chi2_2dof_quantile`).
    """
    m, n_lm = points.shape[0], centroids.shape[0]
    out = np.empty((m, n_lm), dtype=np.bool_)
    for i in range(m):
        for n in range(n_lm):
            s00 = (spreads[n, 0, 0] + centroid_covs[n, 0, 0]) + W[i, 0, 0]
            s01 = (spreads[n, 0, 1] + centroid_covs[n, 0, 1]) + W[i, 0, 1]
            s11 = (spreads[n, 1, 1] + centroid_covs[n, 1, 1]) + W[i, 1, 1]
            d0 = points[i, 0] - centroids[n, 0]
            d1 = points[i, 1] - centroids[n, 1]
            det = s00 * s11 - s01 * s01
            out[i, n] = (s11 * (d0 * d0) - 2.0 * s01 * d0 * d1 + s00 * (d1 * d1)) / det <= gate
    return out


def measurement_contour(points: np.ndarray, W: np.ndarray, centroids: np.ndarray, spreads: np.ndarray,
                        centroid_covs: np.ndarray, gate: float, kernel=contour_inside) -> np.ndarray:
    """``(z_i - p_n)^T (S_n + W_i + P_n)^-1 (z_i - p_n) <= gate`` as an ``(m, N)`` boolean matrix,
    through :func:`contour_inside` or its compiled ``kernel`` (arguments as there)."""
    f = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    return kernel(f(points), f(W), f(centroids), f(spreads), f(centroid_covs), float(gate))
