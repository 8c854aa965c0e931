"""RadarScenes in its official layout, read into the :class:`~radarslam.io.recording.stream.Recording`
that ``radarslam run --recording`` takes (docs/datasets.md "nuScenes and RadarScenes in their
official layouts").

The layout (the dataset's README and its tools, ``radar_scenes.sequence.Sequence.from_json`` and
``radar_scenes.sensors.get_mounting``)::

    DATAROOT/data/sensors.json                   {"radar_1": {"id": 1, "x": m, "y": m, "yaw": rad}, ...}
    DATAROOT/data/sequence_<N>/scenes.json       {"sequence_name", "first_timestamp", "last_timestamp",
                                                  "scenes": {"<timestamp>": {"sensor_id", "odometry_index",
                                                  "odometry_timestamp", "radar_indices": [a, b], ...}}}
    DATAROOT/data/sequence_<N>/radar_data.h5     datasets "radar_data" and "odometry" (structured arrays)

``radar_data`` holds one row per detection: ``timestamp`` (us), ``sensor_id`` (1-4), ``range_sc``
(m), ``azimuth_sc`` (rad, counter-clockwise, sensor frame), ``rcs`` (dBsm), ``vr`` (the measured radial
velocity, m/s, positive receding), ``vr_compensated`` (the same with the car's motion removed), the
positions ``x_cc``, ``y_cc``, ``x_seq``, ``y_seq``, and the annotation ``uuid``, ``track_id``,
``label_id`` (11 the static world). ``odometry`` holds ``timestamp``, ``x_seq``, ``y_seq``,
``yaw_seq``, ``vx`` (m/s) and ``yaw_rate`` (rad/s) of the car (rear axle). Each scene of
``scenes.json`` is one scan of one radar (the rows ``radar_indices`` of ``radar_data``) paired with
the odometry row ``odometry_index``.

Read as ``../shared/data/radarscenes`` was converted (its SOURCE.md): the raw ``vr`` is the Doppler
(never ``vr_compensated``, from which no ego-motion can be had), each radar's mounting comes from
``sensors.json`` (``sensor_id`` N - 1, named ``radarN``), ``label_id`` is kept for evaluation only
(``Recording.labels``), the odometry is the rows the scans are paired with (``odometry="scenes"``;
``odometry="all"`` takes every row of the table), and there is no truth (the dataset's poses are
its odometry integrated). Times are seconds from the earliest scan or odometry row read.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from radarslam.core.errors import DataError, InputError
from radarslam.core.mounting import Mounting
from radarslam.io.recording.stream import Recording

RADAR_FIELDS = ("timestamp", "sensor_id", "range_sc", "azimuth_sc", "rcs", "vr", "label_id")
ODOMETRY_FIELDS = ("timestamp", "vx", "yaw_rate")
ODOMETRY_CHOICES = ("scenes", "all")


def sequence_folder(dataroot: Path, sequence: str | int) -> tuple[Path, Path]:
    """``(DATAROOT/data/sequence_N, DATAROOT/data/sensors.json)``; ``DATAROOT`` may also be the
    ``data`` folder itself. ``sequence`` is ``N`` or ``sequence_N``."""
    name = str(sequence).strip()
    name = name if name.startswith("sequence_") else f"sequence_{name}"
    if not name[len("sequence_"):].isdigit():
        raise InputError(f"--sequence: expected a RadarScenes sequence number (e.g. 105) or sequence_N, got "
                         f"{sequence!r}")
    if not dataroot.is_dir():
        raise InputError(f"--dataset radarscenes: expected the RadarScenes folder (holding data/sequence_N/), got "
                         f"{dataroot}: no such directory")
    data = dataroot / "data" if (dataroot / "data").is_dir() else dataroot
    folder = data / name
    if not folder.is_dir():
        have = sorted(p.name for p in data.glob("sequence_*") if p.is_dir())
        shown = ", ".join(have[:20]) + (f", ... ({len(have)} sequences)" if len(have) > 20 else "")
        raise InputError(f"--sequence: expected {folder} (a RadarScenes sequence folder), got no such folder; "
                         f"{data} holds {shown or 'no sequence_N folder'}")
    return folder, data / "sensors.json"


def _json(path: Path, what: str):
    try:
        with path.open("rb") as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise DataError(f"{path}: expected {what} (the RadarScenes layout), got no such file") from None
    except (OSError, ValueError) as exc:
        raise DataError(f"{path}: expected {what} as JSON, got unreadable content ({exc})") from None


def read_sensors(path: Path) -> dict[int, Mounting]:
    """Each radar's :class:`Mounting` from ``sensors.json`` by ``sensor_id`` (its ``id`` - 1, named ``radarN``)."""
    raw = _json(path, "the radars' mountings sensors.json")
    out: dict[int, Mounting] = {}
    for key, m in (raw.items() if isinstance(raw, dict) else []):
        try:
            rid = int(m.get("id", key.rsplit("_", 1)[-1]))
            x, y, yaw = float(m["x"]), float(m["y"]), float(m["yaw"])
        except (AttributeError, KeyError, TypeError, ValueError):
            raise DataError(f"{path} entry {key!r}: expected {{\"id\": N, \"x\": m, \"y\": m, \"yaw\": rad}}, got "
                            f"{m!r}") from None
        if not all(np.isfinite([x, y, yaw])) or abs(yaw) > 2 * np.pi or rid < 1:
            raise DataError(f"{path} entry {key!r}: expected id >= 1 and finite x, y (m) and yaw (rad), got "
                            f"id {rid}, x {x}, y {y}, yaw {yaw}")
        out[rid - 1] = Mounting(x, y, yaw, str(path), rid - 1, f"radar{rid}")
    if not out:
        raise DataError(f"{path}: expected an object of radars {{\"radar_1\": {{...}}, ...}}, got none")
    return out


def _h5_tables(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        import h5py
    except ImportError:
        raise InputError("--dataset radarscenes: reading radar_data.h5 needs h5py, the 'data' extra (pip install "
                         "\"radarslam[data]\")") from None
    if not path.is_file():
        raise DataError(f"{path}: expected the sequence's radar_data.h5 (the RadarScenes layout), got no such file")
    try:
        with h5py.File(path, "r") as f:
            got = {k: f[k][()] for k in ("radar_data", "odometry") if k in f}
    except (OSError, ValueError) as exc:
        raise DataError(f"{path}: expected an HDF5 file, got unreadable content ({exc})") from None
    for key, fields in (("radar_data", RADAR_FIELDS), ("odometry", ODOMETRY_FIELDS)):
        arr = got.get(key)
        names = () if arr is None or arr.dtype.names is None else arr.dtype.names
        missing = [n for n in fields if n not in names]
        if missing:
            raise DataError(f"{path} dataset {key}: expected a table with fields {', '.join(fields)}, got "
                            f"{'no such dataset' if arr is None else ', '.join(names) or 'no fields'}")
    return got["radar_data"], got["odometry"]


def _paired_rows(scenes_json: Path, odometry: np.ndarray) -> np.ndarray:
    """The odometry rows the scans are paired with (``odometry_index`` of every scene), in time order."""
    raw = _json(scenes_json, "the sequence's scenes.json")
    scenes = raw.get("scenes") if isinstance(raw, dict) else None
    if not isinstance(scenes, dict) or not scenes:
        raise DataError(f"{scenes_json}: expected an object with a non-empty \"scenes\" object, got "
                        f"{type(scenes).__name__ if scenes is not None else 'none'}")
    try:
        idx = np.unique(np.array([int(s["odometry_index"]) for s in scenes.values()], dtype=np.int64))
    except (KeyError, TypeError, ValueError):
        raise DataError(f"{scenes_json}: expected every scene to hold an integer odometry_index") from None
    if idx[0] < 0 or idx[-1] >= odometry.size:
        raise DataError(f"{scenes_json}: expected odometry_index within the {odometry.size} rows of radar_data.h5's "
                        f"odometry, got {int(idx[0] if idx[0] < 0 else idx[-1])}")
    return idx


def read_radarscenes(dataroot: str | Path, sequence: str | int, odometry: str = "scenes") -> Recording:
    """Sequence ``sequence`` (``105`` or ``"sequence_105"``) of the RadarScenes dataset at ``dataroot``
    as a :class:`Recording`: detections in each radar's frame with ``doppler_mps`` (raw ``vr``),
    ``rcs``, ``sensor_id`` (0-3) and ``labels``, the rig's mountings and unicycle odometry (``vx``,
    ``yaw_rate``): the rows paired with the scans (``odometry="scenes"``, as the plain conversion) or
    all of them (``"all"``). Every fault is one :class:`InputError` or :class:`DataError` line."""
    if odometry not in ODOMETRY_CHOICES:
        raise InputError(f"odometry: expected one of {', '.join(ODOMETRY_CHOICES)}, got {odometry!r}")
    folder, sensors_json = sequence_folder(Path(dataroot), sequence)
    h5 = folder / "radar_data.h5"
    radar, odo = _h5_tables(h5)
    sensors = read_sensors(sensors_json)
    for key, arr in (("radar_data", radar), ("odometry", odo)):
        if arr.ndim != 1 or arr.size == 0:
            raise DataError(f"{h5} dataset {key}: expected a 1-D table of rows, got shape {arr.shape}")
    rows = _paired_rows(folder / "scenes.json", odo) if odometry == "scenes" else np.arange(odo.size)
    ts = radar["timestamp"].astype(np.int64)
    order = np.argsort(ts, kind="stable")                 # the file is in time order; kept as it is then
    radar, ts = radar[order], ts[order]
    odo_ts = odo["timestamp"].astype(np.int64)[rows]
    if np.any(np.diff(odo_ts) <= 0):
        raise DataError(f"{h5} dataset odometry: expected increasing timestamps, got a repeated or earlier one")
    sid = radar["sensor_id"].astype(np.int64) - 1
    unknown = np.setdiff1d(np.unique(sid), np.array(sorted(sensors)))
    if unknown.size:
        raise DataError(f"{h5} dataset radar_data: sensor_id {int(unknown[0]) + 1} has no mounting in {sensors_json}, "
                        f"which holds radars {', '.join(str(k + 1) for k in sorted(sensors))}")
    t0 = int(min(ts[0], odo_ts[0]))
    polar = np.column_stack([radar["range_sc"].astype(np.float64), radar["azimuth_sc"].astype(np.float64)])
    channels = {"doppler_mps": radar["vr"].astype(np.float64), "rcs": radar["rcs"].astype(np.float64),
                "sensor_id": sid.astype(np.float64)}
    o = odo[rows]
    return Recording((ts - t0) / 1e6, polar, channels, (odo_ts - t0) / 1e6,
                     np.column_stack([o["vx"].astype(np.float64), o["yaw_rate"].astype(np.float64)]), "unicycle",
                     source=f"{folder} (RadarScenes)", t0_ns=t0 * 1000, sensors=sensors,
                     labels=radar["label_id"].astype(np.int64))
