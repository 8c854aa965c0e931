"""Sifting (docs/method.md c.3; with extent a.7.1): which detections are candidates for association."""

from __future__ import annotations

import numpy as np

#: Detections per chunk: bounds the (rows, N, 2) temporaries for large scans and maps.
CHUNK_ROWS = 2048


def sift(points: np.ndarray, landmarks: np.ndarray, radius: float, extent_inside: np.ndarray | None = None,
         has_extent: np.ndarray | None = None) -> np.ndarray:
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
    """
    m, n = points.shape[0], landmarks.shape[0]
    if m == 0 or n == 0:
        return np.zeros(m, dtype=bool)
    use_extent = extent_inside is not None and has_extent is not None and bool(np.any(has_extent))
    out = np.empty(m, dtype=bool)
    r2 = radius * radius
    for a in range(0, m, CHUNK_ROWS):
        d = points[a:a + CHUNK_ROWS, None, :] - landmarks[None, :, :]               # (rows, N, 2)
        inside = np.einsum("mni,mni->mn", d, d) < r2
        if use_extent:
            inside = np.where(has_extent[None, :], extent_inside[a:a + CHUNK_ROWS], inside)
        out[a:a + CHUNK_ROWS] = inside.any(axis=1)
    return out
