"""The orchestrator's per-scan kernels by backend (docs/architecture.md "Backends"): sifting's
decision, the grouping by landmark, the sensor's view and the clustering, as the Python reference
or their compiled forms (:mod:`radarslam.landmarks._compiled`)."""

from __future__ import annotations

import numpy as np

from radarslam.landmarks.clustering import Cluster, clusters_of, dbscan_labels
from radarslam.landmarks.confirmation import in_view
from radarslam.landmarks.grouping import by_landmark
from radarslam.landmarks.sifting import candidates


def reference_clusters(polar: np.ndarray, xy: np.ndarray, index: np.ndarray, eps: float,
                        min_samples: int) -> list[Cluster]:
    """DBSCAN of ``xy`` (c.6) and the clusters with their centres (h.13); ``index`` maps rows to the scan."""
    return clusters_of(polar, xy, dbscan_labels(xy, eps, min_samples), index)


def step_kernels(backend: str):
    """Steps 3-5's kernels in ``backend``: sifting's decision
    (:func:`~radarslam.landmarks.sifting.candidates`), the grouping by landmark
    (:func:`~radarslam.landmarks.grouping.by_landmark`) and the sensor's view
    (:func:`~radarslam.landmarks.confirmation.in_view`), or their compiled forms."""
    if backend != "numba":
        return candidates, by_landmark, in_view
    from radarslam.landmarks._compiled import compiled_by_landmark, compiled_candidates, compiled_in_view
    return compiled_candidates, compiled_by_landmark, compiled_in_view


def cluster_kernel(backend: str):
    """Step 7's clustering in ``backend``: the reference (scikit-learn's DBSCAN), or the same labels
    and centres from compiled loops (:mod:`radarslam.landmarks._compiled`), for a scan of any size."""
    if backend != "numba":
        return reference_clusters
    from radarslam.landmarks._compiled import dbscan_centres, dbscan_labels as compiled_labels

    def clusters(polar, xy, index, eps, min_samples):
        labels = compiled_labels(xy, eps, min_samples)
        return [Cluster(polar[c].copy(), xy[c].copy(), int(rows.size), index[rows])
                for c, rows in ((c, np.flatnonzero(labels == lab))
                                for lab, c in enumerate(dbscan_centres(polar[:, 0], labels).tolist()))]
    return clusters
