"""DBSCAN clustering of the unsifted detections and the cluster centres (docs/method.md c.6)."""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Cluster:
    """A DBSCAN cluster of one scan.

    ``centre_polar`` / ``centre_xy`` are those of the member with the smallest range (the largest
    return, h.13), not the mean.
    """

    centre_polar: np.ndarray  # (2,)
    centre_xy: np.ndarray  # (2,)
    size: int
    members: np.ndarray  # indices into the scan's detections


#: Above this many points the exact pairwise neighbourhoods (an m x m matrix) give way to the
#: kd-tree search of scikit-learn's DBSCAN; both give the same labels (tested).
DENSE_MAX = 512


@functools.cache
def _sklearn_dbscan_core():
    """scikit-learn's compiled DBSCAN expansion (``DBSCAN.fit`` calls it after its neighbour search).

    Private to scikit-learn, so it is imported defensively; without it the public estimator runs.
    """
    try:
        from sklearn.cluster._dbscan_inner import dbscan_inner
    except ImportError:  # pragma: no cover - depends on the installed scikit-learn
        return None
    return dbscan_inner


def dbscan_labels(points: np.ndarray, eps: float, min_samples: int) -> np.ndarray:
    """DBSCAN labels ``(m,)`` (-1 = noise); the point itself counts towards ``min_samples``.

    The clustering is scikit-learn's: ``DBSCAN.fit`` finds each point's eps-neighbourhood (its
    radius-neighbour search) and hands them to the compiled ``dbscan_inner``. A scan has a few
    dozen points, where that search and the estimator's validation cost ~0.7-1 ms a call, 95% of
    the work, so the neighbourhoods are computed here from the exact pairwise distances and passed
    to the same compiled routine (~25 us). ``tests/test_landmarks.py`` checks the labels equal
    ``sklearn.cluster.DBSCAN(eps, min_samples).fit(points).labels_``.
    """
    m = points.shape[0]
    if m < min_samples or m == 0:
        # No point can have min_samples neighbours: everything is noise (exact shortcut).
        return np.full(m, -1)
    core = _sklearn_dbscan_core()
    if core is None or m > DENSE_MAX:
        # A large scan: scikit-learn's own DBSCAN, whose kd-tree radius search never builds the
        # m x m distance matrix (10,000 detections in well under a second).
        from sklearn.cluster import DBSCAN

        return DBSCAN(eps=eps, min_samples=min_samples, algorithm="kd_tree").fit(points).labels_
    d = points[:, None, :] - points[None, :, :]
    near = np.sqrt(np.einsum("ijk,ijk->ij", d, d)) <= eps
    counts = near.sum(axis=1)
    if counts.max() < min_samples:
        return np.full(m, -1)  # no core point: all noise (exact)
    neighborhoods = np.empty(m, dtype=object)
    cols = np.nonzero(near)[1]  # row-major: each row's neighbours, ascending, as radius_neighbors sorts them
    for i, nb in enumerate(np.split(cols, np.cumsum(counts)[:-1])):
        neighborhoods[i] = nb
    labels = np.full(m, -1, dtype=np.intp)
    core(np.asarray(counts >= min_samples, dtype=np.uint8), neighborhoods, labels)
    return labels


def clusters_of(polar: np.ndarray, xy: np.ndarray, labels: np.ndarray, index: np.ndarray) -> list[Cluster]:
    """Clusters from DBSCAN labels; ``index`` maps rows of ``polar``/``xy`` to scan indices."""
    out = []
    for lab in np.unique(labels):
        if lab < 0:
            continue
        rows = np.flatnonzero(labels == lab)
        c = rows[np.argmin(polar[rows, 0])]
        out.append(Cluster(polar[c].copy(), xy[c].copy(), int(rows.size), index[rows]))
    return out
