"""Odometry and truth of a nuScenes scene from its CAN bus expansion (``DATAROOT/can_bus/``).

The expansion (devkit ``python-sdk/nuscenes/can_bus/README.md``; ``NuScenesCanBus.get_messages``
reads ``DATAROOT/can_bus/<scene>_<message>.json``, a JSON list of messages in time order, each with
``utime``, integer microseconds):

- ``<scene>_zoe_veh_info.json`` ("Zoe Vehicle Info", 100 Hz): ``FL/FR/RL/RR_wheel_speed``, in rounds
  per minute;
- ``<scene>_ms_imu.json`` ("IMU", 100 Hz): ``rotation_rate`` [x, y, z] in rad/s in the IMU frame;
- ``<scene>_pose.json`` ("Pose", 50 Hz): ``pos`` [x, y, z] (m) and ``orientation`` [w, x, y, z] of
  the ego vehicle (rear axle) in the map frame, "identical to the nuScenes ego pose, but sampled at
  a higher frequency".

As ``../shared/data/nuscenes_radar`` was made (its SOURCE.md): the odometry is one row per IMU
message within the wheel messages' time span, the speed the mean of the two REAR wheels' rpm,
linearly interpolated at the IMU's time, times ``2 pi 0.305 / 60`` (the wheel radius of the nuScenes
CAN bus tutorial), the yaw rate the IMU's z rotation rate (a gyro); the truth is the 50 Hz pose.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radarslam.core.errors import DataError
from radarslam.io.datasets.nuscenes.tables import json_list

#: Wheel radius (m) of the nuScenes CAN bus tutorial: speed = rpm * 2 pi r / 60.
WHEEL_RADIUS_M = 0.305
RPM_TO_MPS = 2.0 * math.pi * WHEEL_RADIUS_M / 60.0


def can_file(can_dir: Path, scene: str, message: str) -> Path:
    return can_dir / f"{scene}_{message}.json"


def _messages(path: Path, fields: dict[str, int]) -> dict[str, np.ndarray]:
    """``utime`` (int64) and each of ``fields`` (name -> length, 1 a scalar) of every message, as
    arrays; times must increase."""
    msgs = json_list(path, "this CAN bus message file (the nuScenes CAN bus expansion, devkit can_bus/README.md)",
                     "CAN bus messages")
    if not msgs:
        raise DataError(f"{path}: expected a non-empty JSON list of CAN bus messages, got an empty list")
    out: dict[str, np.ndarray] = {}
    for name, n in {"utime": 1, **fields}.items():
        try:
            col = [m[name] for m in msgs]
            arr = np.array(col, dtype=np.int64 if name == "utime" else np.float64)
        except (KeyError, TypeError, ValueError):
            bad = next((i for i, m in enumerate(msgs) if not isinstance(m, dict) or name not in m), None)
            raise DataError(f"{path} message {bad if bad is not None else '?'}: expected a field {name!r} of "
                            f"{'a number' if n == 1 else f'{n} numbers'}") from None
        if arr.shape != ((len(msgs),) if n == 1 else (len(msgs), n)) or not np.all(np.isfinite(arr)):
            raise DataError(f"{path}: expected {name!r} to be {'a finite number' if n == 1 else f'{n} finite numbers'} "
                            f"in every message, got shape {arr.shape}")
        out[name] = arr
    bad = np.flatnonzero(np.diff(out["utime"]) <= 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise DataError(f"{path} message {i}: expected increasing utime, got {int(out['utime'][i])} after "
                        f"{int(out['utime'][i - 1])}")
    return out


def odometry(can_dir: Path, scene: str, t0_us: int) -> tuple[np.ndarray, np.ndarray]:
    """``(t_s, [speed_mps, yaw_rate_rad_s])``: one row per IMU message inside the wheel messages'
    span (times in s from ``t0_us``)."""
    wheel = _messages(can_file(can_dir, scene, "zoe_veh_info"), {"RL_wheel_speed": 1, "RR_wheel_speed": 1})
    imu = _messages(can_file(can_dir, scene, "ms_imu"), {"rotation_rate": 3})
    wt, it = wheel["utime"], imu["utime"]
    keep = (it >= wt[0]) & (it <= wt[-1])
    if not keep.any():
        raise DataError(f"{can_file(can_dir, scene, 'ms_imu')}: expected IMU messages within the wheel speeds' span "
                        f"(utime {int(wt[0])} .. {int(wt[-1])} of {can_file(can_dir, scene, 'zoe_veh_info').name}), "
                        f"got none ({int(it[0])} .. {int(it[-1])})")
    rpm = 0.5 * (wheel["RL_wheel_speed"] + wheel["RR_wheel_speed"])
    speed = np.interp((it[keep] - wt[0]).astype(np.float64), (wt - wt[0]).astype(np.float64), rpm) * RPM_TO_MPS
    return (it[keep] - t0_us) / 1e6, np.column_stack([speed, imu["rotation_rate"][keep, 2]])


def _yaw(q: np.ndarray) -> np.ndarray:
    """The yaw (ZYX, rad) of unit quaternions ``(n, 4)`` [w, x, y, z]."""
    w, x, y, z = q.T
    return np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def pose_truth(can_dir: Path, scene: str, t0_us: int) -> tuple[np.ndarray, np.ndarray] | None:
    """``(t_s, [x, y, yaw])`` of the 50 Hz pose messages, or None without ``<scene>_pose.json``."""
    path = can_file(can_dir, scene, "pose")
    if not path.is_file():
        return None
    pose = _messages(path, {"pos": 3, "orientation": 4})
    return (pose["utime"] - t0_us) / 1e6, np.column_stack([pose["pos"][:, :2], _yaw(pose["orientation"])])


def ego_pose_truth(ego_poses: list[dict], tokens: list[str], t0_us: int, where: Path) -> tuple[np.ndarray, np.ndarray]:
    """``(t_s, [x, y, yaw])`` of the ``ego_pose`` records ``tokens`` (one per sweep; ``translation``
    [x, y, z], ``rotation`` [w, x, y, z], ``timestamp`` in us), one per distinct time, in time order."""
    by_token = {e["token"]: e for e in ego_poses}
    rows: dict[int, tuple] = {}
    for tok in tokens:
        e = by_token.get(tok)
        if e is None:
            raise DataError(f"{where}: expected ego_pose record {tok} (of a radar sweep), got none")
        try:
            rows[int(e["timestamp"])] = (*(float(v) for v in e["translation"][:2]), *(float(v) for v in e["rotation"]))
        except (KeyError, TypeError, ValueError):
            raise DataError(f"{where} record {tok}: expected timestamp, translation [x, y, z] and rotation "
                            "[w, x, y, z]") from None
    ts = np.array(sorted(rows), dtype=np.int64)
    a = np.array([rows[t] for t in ts.tolist()], dtype=np.float64).reshape(-1, 6)
    return (ts - t0_us) / 1e6, np.column_stack([a[:, :2], _yaw(a[:, 2:6])])
