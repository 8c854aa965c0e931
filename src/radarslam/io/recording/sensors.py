"""A multi-radar rig in the plain format: ``sensors.csv`` (docs/recordings.md "Several radars").

One row per radar: ``sensor_id, x_m, y_m, yaw_rad`` (its mounting in the platform frame, as
:class:`~radarslam.core.mounting.Mounting`) and optionally ``name``, ``max_range_m`` and ``fov_deg`` (the full
opening angle). Each detection's ``sensor_id`` names its row. Every fault is one
:class:`InputError` line naming the file, the line (CSV) or row (NPZ), the column and the fault.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting

#: Columns of ``sensors.csv``: required, then optional.
REQUIRED = ("sensor_id", "x_m", "y_m", "yaw_rad")
OPTIONAL = ("name", "max_range_m", "fov_deg")
#: Columns holding text rather than numbers.
TEXT = ("name",)


def integer_column(v: np.ndarray, name: str, where: str, row: str, first: int) -> np.ndarray:
    """``v`` as int64, refusing a value that is not a whole number >= 0 (``sensor_id``, ``label``, ``scan``)."""
    bad = np.flatnonzero((v != np.round(v)) | (v < 0))
    if bad.size:
        raise InputError(f"{where} {row} {int(bad[0]) + first} column {name}: expected a whole number >= 0, "
                         f"got {float(v[bad[0]])!r}")
    return v.astype(np.int64)


def sensors_from_columns(cols: dict[str, np.ndarray], where: str, row: str = "line",
                         first: int = 2) -> dict[int, Mounting]:
    """Each row's :class:`Mounting`, keyed by ``sensor_id`` (finite values and radians checked already).

    Raises :class:`InputError` on a repeated ``sensor_id``, a non-positive ``max_range_m``, a
    ``fov_deg`` outside (0, 360] or an empty table.
    """
    ids = integer_column(cols["sensor_id"], "sensor_id", where, row, first)
    if ids.size == 0:
        raise InputError(f"{where}: expected one row per radar, got none")
    names = cols.get("name")
    rng = cols.get("max_range_m")
    fov = cols.get("fov_deg")
    out: dict[int, Mounting] = {}
    for i, sid in enumerate(ids.tolist()):
        if sid in out:
            raise InputError(f"{where} {row} {i + first} column sensor_id: expected each sensor once, got {sid} again")
        if rng is not None and not rng[i] > 0:
            raise InputError(f"{where} {row} {i + first} column max_range_m: expected a range > 0, "
                             f"got {float(rng[i])!r}")
        if fov is not None and not 0 < fov[i] <= 360:
            raise InputError(f"{where} {row} {i + first} column fov_deg: expected a full opening angle in (0, 360] "
                             f"deg, got {float(fov[i])!r}")
        out[sid] = Mounting(float(cols["x_m"][i]), float(cols["y_m"][i]), float(cols["yaw_rad"][i]), where, sid,
                            "" if names is None else str(names[i]), None if rng is None else float(rng[i]),
                            None if fov is None else math.radians(float(fov[i])))
    return out


def check_detection_sensors(sensor_id: np.ndarray | None, sensors: dict[int, Mounting], where: str, row: str,
                            first: int, origin: str | None = None) -> None:
    """Refuse a detection whose ``sensor_id`` has no row in ``sensors``, or several sensors and no
    ``sensor_id`` column (``where`` names the detections; ``origin``, where the mountings were looked
    for, when not the recording's own ``sensors.csv``)."""
    ids = ', '.join(map(str, sorted(sensors)))
    if sensor_id is None:
        if len(sensors) > 1:
            raise InputError(f"{where}: expected a sensor_id column ({origin or 'sensors.csv'} has {len(sensors)} "
                             f"sensors: {ids}), got none")
        return
    known = np.array(sorted(sensors), dtype=float)
    bad = np.flatnonzero(~np.isin(sensor_id, known))
    if bad.size:
        at, got = f"{where} {row} {int(bad[0]) + first} column sensor_id", float(sensor_id[bad[0]])
        if origin is None:
            raise InputError(f"{at}: expected one of sensors.csv's {ids}, got {got!r}")
        raise InputError(f"{at}: sensor {int(got) if got.is_integer() else got} has no mounting in {origin}, which "
                         f"holds sensors {ids} (mountings are looked for in --sensors FILE, else the config's "
                         f"[[sensors]], else the recording's own)")


def sensors_from_config(rig, where: str = "the config's [[sensors]]") -> dict[int, Mounting]:
    """The config's rig (``Config.sensors``, :class:`radarslam.config.RigSensorConfig`, checked when
    loaded) as ``sensors.csv`` would give it: each :class:`Mounting` by ``sensor_id``, the yaw and the
    field of view in radians (``math.radians`` of the degrees, as :func:`sensors_from_columns` takes
    ``fov_deg``; :meth:`Mounting.from_rig_config`), ``source`` naming ``where``."""
    return {int(s.id): Mounting.from_rig_config(s, where) for s in rig}


def with_sensors(rec, sensors: dict[int, Mounting], origin: str):
    """``rec`` (a :class:`~.stream.Recording`) with its rig replaced by ``sensors`` (and no single
    mounting), exactly as if they had come from its ``sensors.csv``; refuses in one line a detection
    whose ``sensor_id`` has no mounting there, naming the sensor and ``origin`` (where they were looked for)."""
    import dataclasses

    check_detection_sensors(rec.channels.get("sensor_id"), sensors, f"{rec.source} (detections)", "detection", 1,
                            origin)
    return dataclasses.replace(rec, sensors=dict(sensors), mounting=None)


def sensors_table(sensors: dict[int, Mounting]) -> dict[str, np.ndarray]:
    """The ``sensors`` table of ``sensors`` (``max_range_m``, ``fov_deg`` only when every sensor states them)."""
    ms = [sensors[k] for k in sorted(sensors)]
    t: dict[str, np.ndarray] = {"sensor_id": np.array([m.sensor_id for m in ms], dtype=np.int64),
                                "x_m": np.array([m.x for m in ms]), "y_m": np.array([m.y for m in ms]),
                                "yaw_rad": np.array([m.yaw for m in ms]), "name": np.array([m.name for m in ms])}
    if all(m.max_range_m is not None for m in ms):
        t["max_range_m"] = np.array([m.max_range_m for m in ms])
    if all(m.fov_rad is not None for m in ms):
        t["fov_deg"] = np.array([math.degrees(m.fov_rad) for m in ms])
    return t
