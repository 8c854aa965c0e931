"""nuScenes in its official layout, read into the :class:`~radarslam.io.recording.stream.Recording`
that ``radarslam run --recording`` takes (docs/datasets.md "nuScenes and RadarScenes in their
official layouts").

``DATAROOT`` is the folder nuScenes unpacks into::

    DATAROOT/<version>/{scene,sample,sample_data,calibrated_sensor,sensor,ego_pose,log}.json   (:mod:`.tables`)
    DATAROOT/samples/RADAR_*/*.pcd, DATAROOT/sweeps/RADAR_*/*.pcd                          (:mod:`.pcd`)
    DATAROOT/can_bus/<scene>_{zoe_veh_info,ms_imu,pose}.json                               (:mod:`.can_bus`)

A scene gives the five radars' sweeps (every ``sample_data`` of a ``RADAR_*`` channel from the key
frame of its first sample along ``next``), each radar's mounting from its ``calibrated_sensor``,
the odometry from the CAN bus (rear wheels' speed, the IMU's yaw rate) and the truth from the CAN
bus's 50 Hz pose (else, without ``<scene>_pose.json``, from ``ego_pose.json`` at the radar sweeps,
with one warning line). Times are seconds from the scene's first radar sweep (``Recording.t0_ns``
holds it), each the dataset's microseconds. This is how ``../shared/data/nuscenes_radar`` was
converted (its SOURCE.md), so a scene read here gives the same stream as its plain conversion.
Only json and numpy are used (the nuScenes devkit pins numpy < 2).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radarslam.core.errors import DataError, InputError
from radarslam.io.datasets.nuscenes import can_bus, tables as T
from radarslam.io.datasets.nuscenes.pcd import RADAR_FIELDS, polar_doppler, read_radar_pcd
from radarslam.io.recording.stream import Recording

__all__ = ["RADAR_CHANNELS", "RADAR_FIELDS", "read_nuscenes", "read_radar_pcd"]

RADAR_CHANNELS = T.RADAR_CHANNELS


def _check_dataroot(dataroot: Path) -> Path:
    if not dataroot.is_dir():
        raise InputError(f"--dataset nuscenes: expected the nuScenes folder (holding v1.0-*/ and can_bus/), got "
                         f"{dataroot}: no such directory")
    if not (dataroot / "can_bus").is_dir():
        raise DataError(f"{dataroot}: expected the CAN bus expansion in {dataroot / 'can_bus'} (wheel speeds, IMU and "
                        "pose: nuScenes' 'CAN bus expansion' download, unpacked into the dataroot), got no such folder")
    return dataroot / "can_bus"


def _detections(dataroot: Path, sweeps: dict[str, list[dict]], t0_us: int, folder: Path) -> dict[str, np.ndarray]:
    """Every cluster of every sweep, ordered by (time, sensor_id), each sweep in its file's order."""
    parts = []
    for ch, chain in sweeps.items():
        sid = T.RADAR_CHANNELS[ch][0]
        for sd in chain:
            name = sd.get("filename")
            if not name:
                raise DataError(f"{folder / 'sample_data.json'} record {sd['token']}: expected a filename, got none")
            rng, az, dop, rcs = polar_doppler(read_radar_pcd(dataroot / name))
            parts.append((int(sd["timestamp"]), sid, rng, az, dop, rcs))
    parts.sort(key=lambda p: (p[0], p[1]))
    n = [p[2].size for p in parts]
    t = np.repeat([(p[0] - t0_us) / 1e6 for p in parts], n)
    sid = np.repeat([float(p[1]) for p in parts], n)
    cols = [np.concatenate([p[k] for p in parts]) if parts else np.empty(0) for k in (2, 3, 4, 5)]
    return {"t_s": t.astype(np.float64), "range_m": cols[0], "azimuth_rad": cols[1], "doppler_mps": cols[2],
            "rcs": cols[3], "sensor_id": sid.astype(np.float64)}


def read_nuscenes(dataroot: str | Path, scene: str, version: str | None = None) -> Recording:
    """Scene ``scene`` (e.g. ``"scene-0061"``) of the nuScenes dataset at ``dataroot``, from the tables
    of ``dataroot/version`` (default: the one ``v1.0-*`` folder there), as a :class:`Recording`:
    detections in each radar's frame with ``doppler_mps`` (raw ``vx``, ``vy``), ``rcs`` and
    ``sensor_id`` (0 front, 1 front-left, 2 front-right, 3 back-left, 4 back-right), the rig's
    mountings, unicycle odometry and the truth.

    Every fault is one :class:`InputError` (an argument) or :class:`DataError` (a file) line naming
    the argument or file, what was expected and what was found.
    """
    dataroot = Path(dataroot)
    can_dir = _check_dataroot(dataroot)
    folder = T.version_folder(dataroot, version)
    tabs = {name: T.load_table(folder, name) for name in ("scene", "sample", "log")}
    rec = T.find_scene(tabs["scene"], scene, folder)
    samples = T.scene_samples(tabs["sample"], rec, folder)
    tabs.update({name: T.load_table(folder, name) for name in ("sensor", "calibrated_sensor", "sample_data")})
    sweeps = T.radar_sweeps(tabs, rec, samples, folder)
    sensors = T.sweep_mountings(sweeps, tabs, folder)
    t0_us = min(int(chain[0]["timestamp"]) for chain in sweeps.values())
    det = _detections(dataroot, sweeps, t0_us, folder)
    if det["t_s"].size == 0:
        raise DataError(f"{folder / 'sample_data.json'}: expected radar clusters in the sweeps of {scene}, got none "
                        f"({sum(len(c) for c in sweeps.values())} empty sweeps)")
    odo_t, odo = can_bus.odometry(can_dir, scene, t0_us)
    notes: list[str] = []
    truth = can_bus.pose_truth(can_dir, scene, t0_us)
    if truth is None:
        tokens = [sd.get("ego_pose_token") for chain in sweeps.values() for sd in chain]
        truth = can_bus.ego_pose_truth(T.load_table(folder, "ego_pose"), tokens, t0_us, folder / "ego_pose.json")
        notes.append(f"{can_bus.can_file(can_dir, scene, 'pose')} is absent: the truth is ego_pose.json at the radar "
                     f"sweeps ({truth[0].size} poses) instead of the CAN bus's 50 Hz pose")
    log = next((g for g in tabs["log"] if g.get("token") == rec.get("log_token")), {})
    source = f"{dataroot} ({folder.name} {scene}, log {log.get('logfile', '?')})"
    return Recording(det["t_s"], np.column_stack([det["range_m"], det["azimuth_rad"]]),
                     {c: det[c] for c in ("doppler_mps", "rcs", "sensor_id")}, odo_t, odo, "unicycle",
                     truth[0], truth[1], source=source, notes=notes, t0_ns=t0_us * 1000, sensors=sensors)
