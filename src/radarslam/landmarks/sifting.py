"""Sifting (docs/method.md c.3; with extent a.7.1): which detections are candidates for association."""

from __future__ import annotations

import numpy as np


def candidates(points: np.ndarray, centroids: np.ndarray, r2: float, inside: np.ndarray,
               has: np.ndarray) -> np.ndarray:
    """Step 3's decision, a kernel (docs/method.md c.3, a.7.1): ``(m,)`` True for a detection
    ``points[i]`` inside the extent-aware test ``inside[i, j]`` of a landmark with ``has[j]``, or
    within ``sqrt(r2)`` of a centroid ``centroids[j]`` of one without. The fused engine links it
    compiled (:mod:`._compiled`)."""
    m, n = points.shape[0], centroids.shape[0]
    out = np.zeros(m, dtype=np.bool_)
    for i in range(m):
        for j in range(n):
            if has[j]:
                hit = inside[i, j]
            else:
                d0 = points[i, 0] - centroids[j, 0]
                d1 = points[i, 1] - centroids[j, 1]
                hit = d0 * d0 + d1 * d1 < r2
            if hit:
                out[i] = True
                break
    return out


def sift(points: np.ndarray, landmarks: np.ndarray, radius: float, extent_inside: np.ndarray | None = None,
         has_extent: np.ndarray | None = None, kernel=candidates) -> np.ndarray:
    """Boolean mask ``(m,)`` of the detections that are candidates for some landmark.

    Parameters
    ----------
    points : ndarray, shape (m, 2)
        Detections in the world frame (converted with the predicted pose).
    landmarks : ndarray, shape (N, 2)
        Landmark centroids.
    radius : float
        gamma_s: a detection within this Euclidean distance of a landmark is a candidate.
    extent_inside : ndarray of bool, shape (m, N), optional
        The extent-aware test (:mod:`radarslam.extent.sifting`); it replaces the radius test for
        the landmarks where ``has_extent`` is True.
    has_extent : ndarray of bool, shape (N,), optional
    kernel : callable
        :func:`candidates` or its compiled form (:data:`._compiled.compiled_candidates`).
    """
    m, n = points.shape[0], landmarks.shape[0]
    if m == 0 or n == 0:
        return np.zeros(m, dtype=bool)
    if extent_inside is None or has_extent is None:
        extent_inside, has_extent = np.zeros((1, 1), dtype=bool), np.zeros(n, dtype=bool)
    return kernel(np.ascontiguousarray(points, dtype=float), np.ascontiguousarray(landmarks, dtype=float),
                  float(radius) * float(radius), np.asarray(extent_inside, dtype=bool),
                  np.asarray(has_extent, dtype=bool))
