"""The nuScenes metadata tables of ``DATAROOT/<version>/`` and a scene's radar sweeps.

The schema is nuScenes' (devkit ``docs/schema_nuscenes.md``): every table is a JSON list of records
keyed by ``token``. A ``scene`` names its ``log`` and its first and last ``sample`` (key frames,
chained by ``prev``/``next``); each ``sample_data`` record is one sweep of one sensor (``filename``
under DATAROOT, ``timestamp`` in microseconds, ``is_key_frame``, the ``sample_token`` it belongs to,
its ``ego_pose_token`` and ``calibrated_sensor_token``), chained per sensor by ``prev``/``next``
("Empty if end of scene"); ``calibrated_sensor`` holds the sensor's mounting on the ego vehicle
(``translation`` [x, y, z] in m, ``rotation`` quaternion [w, x, y, z]; origin at the rear axle's
centre, x forward, y left) and names its ``sensor``, whose ``channel`` is e.g. ``RADAR_FRONT``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from radarslam.core.errors import DataError, InputError
from radarslam.core.mounting import Mounting
from radarslam.io.recording.mounting import MAX_TILT_RAD, quaternion_to_rpy

#: The five radars of a nuScenes car: channel -> (sensor_id, name), as in ``../shared/data/nuscenes_radar``.
RADAR_CHANNELS = {"RADAR_FRONT": (0, "front"), "RADAR_FRONT_LEFT": (1, "left"), "RADAR_FRONT_RIGHT": (2, "right"),
                  "RADAR_BACK_LEFT": (3, "rear_left"), "RADAR_BACK_RIGHT": (4, "rear_right")}


def version_folder(dataroot: Path, version: str | None) -> Path:
    """``DATAROOT/<version>``; without ``version`` the one folder there holding ``scene.json``."""
    if version:
        folder = dataroot / version
        if not (folder / "scene.json").is_file():
            raise DataError(f"--version {version}: expected the nuScenes tables in {folder} (scene.json, sample.json, "
                            f"...), got {'no such folder' if not folder.is_dir() else 'no scene.json there'}")
        return folder
    found = sorted(p.parent.name for p in dataroot.glob("*/scene.json"))
    if len(found) != 1:
        raise InputError(f"--version: expected one nuScenes version folder (v1.0-mini, v1.0-trainval, ...) in "
                         f"{dataroot}, got {', '.join(found) if found else 'none'}; name it with --version")
    return dataroot / found[0]


def json_list(path: Path, missing: str, what: str) -> list:
    """The JSON list in ``path``; one-line :class:`DataError` naming the file, with ``missing`` (what the
    file is) when it is absent and ``what`` (its records) when it is unreadable or not a list."""
    try:
        with path.open("rb") as fh:
            records = json.load(fh)
    except FileNotFoundError:
        raise DataError(f"{path}: expected {missing}, got no such file") from None
    except (OSError, ValueError) as exc:
        raise DataError(f"{path}: expected a JSON list of {what}, got unreadable content ({exc})") from None
    if not isinstance(records, list):
        raise DataError(f"{path}: expected a JSON list of {what}, got {type(records).__name__}")
    return records


def load_table(folder: Path, name: str) -> list[dict]:
    """The records of ``folder/<name>.json`` (a JSON list of objects)."""
    path = folder / f"{name}.json"
    records = json_list(path, f"the nuScenes table {name} (devkit docs/schema_nuscenes.md)", f"{name} records")
    if not all(isinstance(r, dict) for r in records[:1]):
        raise DataError(f"{path}: expected a JSON list of {name} records, got a list of {type(records[0]).__name__}")
    return records


def _field(rec: dict, key: str, table: str, folder: Path):
    try:
        return rec[key]
    except KeyError:
        raise DataError(f"{folder / (table + '.json')} record {rec.get('token', '?')}: expected a field {key!r} "
                        f"(devkit docs/schema_nuscenes.md), got {', '.join(sorted(rec)) or 'none'}") from None


def find_scene(scenes: list[dict], name: str, folder: Path) -> dict:
    """The scene record named ``name``; an unknown name is refused listing the scenes there."""
    for s in scenes:
        if s.get("name") == name:
            return s
    names = sorted(str(s.get("name")) for s in scenes)
    shown = ", ".join(names[:40]) + (f", ... ({len(names)} scenes)" if len(names) > 40 else "")
    raise InputError(f"--scene: expected one of the scenes of {folder / 'scene.json'} ({shown}), got {name!r}")


def scene_samples(samples: list[dict], scene: dict, folder: Path) -> list[dict]:
    """The scene's samples (key frames) in time order: ``first_sample_token`` along ``next``."""
    by_token = {s["token"]: s for s in samples}
    out, token = [], _field(scene, "first_sample_token", "scene", folder)
    while token:
        rec = by_token.get(token)
        if rec is None:
            raise DataError(f"{folder / 'sample.json'}: expected sample {token} of scene {scene.get('name')}, got none")
        if len(out) > len(by_token):
            raise DataError(f"{folder / 'sample.json'}: the next chain of scene {scene.get('name')} loops")
        out.append(rec)
        if token == scene.get("last_sample_token"):
            break
        token = rec.get("next", "")
    return out


def radar_sweeps(tables: dict[str, list[dict]], scene: dict, samples: list[dict],
                 folder: Path) -> dict[str, list[dict]]:
    """Every sweep of each radar of ``scene``: channel -> its ``sample_data`` records in time order,
    from the key frame of the scene's first sample along ``next`` (key frames and the sweeps between
    them), while they belong to the scene's samples."""
    channel_of = {s["token"]: s.get("channel", "") for s in tables["sensor"]}
    cs_channel = {c["token"]: channel_of.get(c.get("sensor_token"), "") for c in tables["calibrated_sensor"]}
    first = samples[0]["token"]
    in_scene = {s["token"] for s in samples}
    by_token: dict[str, dict] = {}
    starts: dict[str, dict] = {}
    for sd in tables["sample_data"]:
        by_token[sd["token"]] = sd
        if sd.get("sample_token") == first and sd.get("is_key_frame", True):
            ch = cs_channel.get(sd.get("calibrated_sensor_token"), "")
            if ch in RADAR_CHANNELS:
                starts[ch] = sd
    if not starts:
        raise DataError(f"{folder / 'sample_data.json'}: expected the radar sweeps (RADAR_*) of {scene.get('name')} "
                        f"(key frames of its first sample {first}), got none")
    out: dict[str, list[dict]] = {}
    for ch in sorted(starts, key=lambda c: RADAR_CHANNELS[c][0]):
        chain, sd = [], starts[ch]
        while sd is not None and sd.get("sample_token") in in_scene:
            if chain and int(sd["timestamp"]) <= int(chain[-1]["timestamp"]):
                raise DataError(f"{folder / 'sample_data.json'} record {sd['token']}: expected {ch}'s sweeps in time "
                                f"order along next, got timestamp {sd['timestamp']} after {chain[-1]['timestamp']}")
            chain.append(sd)
            nxt = sd.get("next", "")
            sd = by_token.get(nxt) if nxt else None
            if nxt and sd is None:
                raise DataError(f"{folder / 'sample_data.json'}: expected record {nxt} (next of {chain[-1]['token']}), "
                                "got none")
        out[ch] = chain
    return out


def radar_mounting(cs: dict, channel: str, folder: Path) -> Mounting:
    """A radar's planar :class:`Mounting` from its ``calibrated_sensor`` record: x, y of the
    translation and the yaw (ZYX) of the rotation quaternion [w, x, y, z]; a roll or pitch beyond
    10 deg is refused (docs/recordings.md "Mounting")."""
    where = f"{folder / 'calibrated_sensor.json'} record {cs.get('token')} ({channel})"
    t, q = _field(cs, "translation", "calibrated_sensor", folder), _field(cs, "rotation", "calibrated_sensor", folder)
    try:
        tx, ty = float(t[0]), float(t[1])
        w, x, y, z = (float(v) for v in q)
    except (TypeError, ValueError, IndexError):
        raise DataError(f"{where}: expected translation [x, y, z] and rotation [w, x, y, z], got {t!r}, "
                        f"{q!r}") from None
    try:
        roll, pitch, yaw = quaternion_to_rpy(x, y, z, w)
    except InputError as exc:
        raise DataError(f"{where}: {exc}") from None
    if abs(roll) > MAX_TILT_RAD or abs(pitch) > MAX_TILT_RAD or not (math.isfinite(tx) and math.isfinite(ty)):
        raise DataError(f"{where}: expected a planar mounting (roll and pitch within "
                        f"{math.degrees(MAX_TILT_RAD):g} deg, finite translation), got roll {math.degrees(roll):.1f} "
                        f"deg, pitch {math.degrees(pitch):.1f} deg, translation {t!r}")
    sid, name = RADAR_CHANNELS[channel]
    return Mounting(tx, ty, yaw, str(folder / "calibrated_sensor.json"), sid, name)


def sweep_mountings(sweeps: dict[str, list[dict]], tables: dict[str, list[dict]], folder: Path) -> dict[int, Mounting]:
    """Each radar's mounting by ``sensor_id``: the one ``calibrated_sensor`` of its sweeps (two
    different mountings of one radar within a scene are refused)."""
    cs_by_token = {c["token"]: c for c in tables["calibrated_sensor"]}
    out: dict[int, Mounting] = {}
    for ch, chain in sweeps.items():
        ms = {}
        for sd in chain:
            tok = sd.get("calibrated_sensor_token")
            if tok not in ms:
                if tok not in cs_by_token:
                    raise DataError(f"{folder / 'calibrated_sensor.json'}: expected record {tok} (of sample_data "
                                    f"{sd['token']}, {ch}), got none")
                ms[tok] = radar_mounting(cs_by_token[tok], ch, folder)
        distinct = {(m.x, m.y, m.yaw) for m in ms.values()}
        if len(distinct) > 1:
            raise DataError(f"{folder / 'calibrated_sensor.json'}: expected one mounting of {ch} within the scene, got "
                            f"{len(distinct)} ({', '.join(sorted(ms))})")
        m = next(iter(ms.values()))
        out[m.sensor_id] = m
    return out
