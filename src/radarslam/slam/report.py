"""What one scan did to the filter, for logging and tests: :class:`ScanReport`, given by
:meth:`EkfSlam.update <radarslam.slam.filter.EkfSlam.update>` and by the fused engine run one event at a
time (:class:`~radarslam.slam.fused.online.Online`), which fill it from the same steps' outputs."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ScanReport"]


@dataclass(frozen=True)
class ScanReport:
    """What one scan did (for logging and tests)."""

    index: int
    n_detections: int
    n_candidates: int
    n_associated: int
    associations: dict[int, np.ndarray]  # landmark id -> detection indices
    removed: list[int]
    confirmed: list[int]
    merged: list[tuple[int, int]]  # (kept id, dropped id)
    n_clusters: int
    n_tentative: int
    nis: np.ndarray = field(default_factory=lambda: np.empty(0))  # NIS of each update (2 dof)
    moving: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=int))  # detections failing c.10.4
    ego: object = None  # the scan's EgoVelocity (c.10) under filter.doppler_gate, else None
    created: dict[int, np.ndarray] = field(default_factory=dict)  # new landmark id -> its cluster's detections
