"""Running EKF-SLAM over a recorded dataset (``radarslam run --dataset NAME PATH``)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from radarslam.config import Config, validate
from radarslam.core.types import Odometry, Scan
from radarslam.metrics.alignment import error_against_fixes
from radarslam.slam.filter import EkfSlam, MapSnapshot


@dataclass
class DatasetRun:
    """The estimate over a dataset: the pose after every scan and the final map.

    Per-scan map snapshots are not kept (hundreds of landmarks over thousands of scans).
    """

    name: str
    config: Config
    data: object
    times: np.ndarray  # (K,) scan times (s)
    poses: np.ndarray  # (K, 3)
    pose_covs: np.ndarray  # (K, 3, 3)
    n_landmarks: np.ndarray  # (K,)
    n_associated: np.ndarray  # (K,)
    final_map: MapSnapshot
    seconds: float
    load_seconds: float


def run_dataset(name: str, path, config: Config, *, first_scan: int | None = None, n_scans: int | None = None,
                progress: bool = True, loader_options: dict | None = None) -> DatasetRun:
    """Load dataset ``name`` from ``path`` and run :class:`EkfSlam` over its event stream."""
    from radarslam.experiments.montecarlo import Progress
    from radarslam.io.datasets import get_dataset

    config = validate(config)
    t0 = time.perf_counter()
    data = get_dataset(name)(path, first_scan=first_scan, n_scans=n_scans, **(loader_options or {}))
    load_s = time.perf_counter() - t0
    n = sum(isinstance(e, Scan) for e in data.events)
    slam = EkfSlam(config)
    bar = Progress(n, 0, enabled=progress, unit="scans")
    times, poses, covs, nlm, nas = [], [], [], [], []
    t0 = time.perf_counter()
    for ev in data.events:
        if isinstance(ev, Odometry):
            slam.predict(ev)
            continue
        rep = slam.update(ev)
        times.append(ev.t)
        poses.append(slam.x[:3].copy())
        covs.append(slam.P[:3, :3].copy())
        nlm.append(len(slam.landmarks))
        nas.append(rep.n_associated)
        bar.update()
    return DatasetRun(name, config, data, np.array(times), np.array(poses).reshape(-1, 3),
                      np.array(covs).reshape(-1, 3, 3), np.array(nlm), np.array(nas), slam.snapshot(),
                      time.perf_counter() - t0, load_s)


def evaluate_against_gps(run: DatasetRun) -> dict:
    """GPS-aligned position error of the estimated sensor track (the antenna sits at the laser).

    GPS jumps are removed by the fixes' own implied speed (> 8 m/s; the car's top speed is about
    6.6 m/s); the remaining fixes are aligned by least squares with no residual-based rejection.
    """
    gps = run.data.gps
    return error_against_fixes(run.times, run.poses[:, :2], np.asarray(gps.t), np.asarray(gps.xy),
                               robust=False, max_speed=8.0)
