"""Hand-made scans for the landmark-management and extent tests."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from radarslam.config import profile_config
from radarslam.core.types import Scan
from radarslam.models.radar import xy_to_polar

POSE = np.array([0.0, 0.0, 0.0])


def quiet_config(profile: str = "apsipa", use_extent: bool = False, **landmarks):
    """Filter that starts at the true pose with tiny uncertainty; 'With extent' only if asked."""
    cfg = profile_config(profile)
    f = replace(cfg.filter, initial_pose=[0.0, 0.0, 0.0], initial_pose_std=[1e-3, 1e-3, 1e-4])
    return replace(cfg, filter=f, landmarks=replace(cfg.landmarks, **landmarks),
                   extent=replace(cfg.extent, use_in_slam=use_extent))


def rect_points(x0: float, y0: float, sx: float, sy: float, n: int, seed: int) -> np.ndarray:
    """``n`` points uniform on the rectangle ``[x0, x0 + sx] x [y0, y0 + sy]``."""
    r = np.random.default_rng(seed)
    return r.uniform(0, 1, (n, 2)) * [sx, sy] + [x0, y0]


def blob(center, n: int, spread: float = 0.3, seed: int = 0) -> np.ndarray:
    """``n`` world points within ``spread`` of ``center`` (one DBSCAN cluster)."""
    r = np.random.default_rng(seed)
    return np.asarray(center) + r.uniform(-spread, spread, (n, 2))


def scan(k: int, *point_sets) -> Scan:
    pts = np.concatenate(point_sets) if point_sets else np.empty((0, 2))
    return Scan(t=0.16 * (k - 1), index=k, polar=xy_to_polar(POSE, pts) if pts.size else np.empty((0, 2)))


