"""Sifting (method.md c.3; with extent a.7.1): which detections are candidates for association."""

from __future__ import annotations

import numpy as np


def sift(points: np.ndarray, landmarks: np.ndarray, radius: float,
         extents_inv: np.ndarray | None = None, has_extent: np.ndarray | None = None,
         kappa: float = 1.0) -> np.ndarray:
    """Boolean mask ``(m,)`` of the detections that are candidates for some landmark.

    Parameters
    ----------
    points : ndarray, shape (m, 2)
        Detections in the world frame (converted with the predicted pose).
    landmarks : ndarray, shape (N, 2)
        Landmark centroids.
    radius : float
        gamma_s: a detection within this Euclidean distance of a landmark is a candidate.
    extents_inv : ndarray, shape (N, 2, 2), optional
        ``X_n^-1`` of each landmark; used where ``has_extent`` is True (contour test
        ``(z - p)^T X^-1 (z - p) <= kappa^2``, a.7.1) instead of the radius.
    has_extent : ndarray of bool, shape (N,), optional
    kappa : float
        Contour scale.
    """
    m, n = points.shape[0], landmarks.shape[0]
    if m == 0 or n == 0:
        return np.zeros(m, dtype=bool)
    d = points[:, None, :] - landmarks[None, :, :]               # (m, N, 2)
    inside = np.einsum("mni,mni->mn", d, d) < radius * radius
    if extents_inv is not None and has_extent is not None and np.any(has_extent):
        q = np.einsum("mni,nij,mnj->mn", d, extents_inv, d)
        inside = np.where(has_extent[None, :], q <= kappa * kappa, inside)
    return inside.any(axis=1)
