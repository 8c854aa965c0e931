"""Hand-made scans for the landmark-management and extent tests."""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

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




#: The shared recordings (``../shared/data``; their licence keeps them out of the repository).
SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def shared_data() -> Path:
    """``../shared/data``: skip without it, but FAIL under CI (CI=true), which provides it."""
    if not SHARED.is_dir():
        if os.environ.get("CI"):
            pytest.fail(f"{SHARED} is absent under CI")
        pytest.skip("../shared/data absent")
    return SHARED


def first_seconds(src: Path, seconds: float, out: Path) -> Path:
    """The first ``seconds`` of a shared plain recording as plain files in the new directory ``out``
    (a temporary one, never the repository: the data's licence); odometry and truth 0.5 s beyond."""
    from radarslam.io.recording.plain import read_plain, write_plain

    rec = read_plain(src)
    end = rec.det_t[0] + seconds
    keep, odo = rec.det_t <= end, rec.odo_t <= end + 0.5
    tr = None if rec.truth is None else rec.truth_t <= end + 0.5
    cut = replace(rec, det_t=rec.det_t[keep], det_polar=rec.det_polar[keep],
                  channels={k: v[keep] for k, v in rec.channels.items()}, odo_t=rec.odo_t[odo], odo=rec.odo[odo],
                  truth_t=None if tr is None else rec.truth_t[tr], truth=None if tr is None else rec.truth[tr],
                  labels=None if rec.labels is None else rec.labels[keep],
                  det_scan=None if rec.det_scan is None else rec.det_scan[keep], scan_t=None)
    out.mkdir(parents=True)
    write_plain(cut, out)
    return out


def one_line_message(exc, *parts: str) -> str:
    """The message of a raised error (``pytest.raises``' ``ExceptionInfo``), asserted to be one line
    holding each of ``parts``."""
    msg = str(exc.value)
    assert "\n" not in msg, msg
    for p in parts:
        assert p in msg, msg
    return msg
