"""What a run would be without its radar: the odometry integrated by the filter's motion model."""

from __future__ import annotations

import numpy as np

from radarslam.config import Config
from radarslam.core.types import Odometry, Scan
from radarslam.models.motion import motion_model_from_config


def dead_reckoning(events: list, config: Config, start) -> np.ndarray:
    """The odometry of ``events`` integrated by the filter's motion model from ``start`` (the filter's
    state), the pose ``(K, 3)`` at every scan: what the run would be without its radar."""
    model = motion_model_from_config(config.filter)
    pose, out = np.array(start, dtype=float), []
    for ev in events:
        if isinstance(ev, Odometry):
            pose = np.asarray(model.step(pose, np.asarray(ev.control, dtype=float), ev.dt), dtype=float)
        elif isinstance(ev, Scan):
            out.append(pose.copy())
    return np.array(out).reshape(-1, 3)
