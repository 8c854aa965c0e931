"""Reading, checking and writing configurations (:mod:`radarslam.config`): the type and range
check of every field (:func:`validate`, with the cross-field constraints), TOML in and out.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import tomllib
import typing
from pathlib import Path
from typing import Any

from radarslam.config.profile_files import list_profiles
from radarslam.config.sections import (
    MAX_DETECTIONS_PER_SCAN,
    MAX_VEHICLES,
    RIG_REQUIRED,
    Config,
    RigSensorConfig,
)
from radarslam.core.errors import ConfigError


# --------------------------------------------------------------------------------------------
# Loading, validating, writing
# --------------------------------------------------------------------------------------------
@functools.cache
def _type_hints(cls: type) -> dict[str, Any]:
    """The resolved annotations of a config section (resolving them costs ~0.5 ms per call)."""
    return typing.get_type_hints(cls)


def _field_type(cls: type, name: str) -> Any:
    return _type_hints(cls)[name]


def _check_value(key: str, typ: Any, meta: dict, value: Any) -> Any:
    """Type-check (and coerce int -> float) one leaf value; range-check it."""
    origin = typing.get_origin(typ)
    if typ is bool:
        if not isinstance(value, bool):
            raise ConfigError(f"{key}: expected true or false, got {value!r}")
        return value
    if typ is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ConfigError(f"{key}: expected an integer, got {value!r}")
    elif typ is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ConfigError(f"{key}: expected a number, got {value!r}")
        value = float(value)
        if math.isnan(value):
            raise ConfigError(f"{key}: expected a number, got nan")
        if math.isinf(value) and not meta.get("allow_inf"):
            raise ConfigError(f"{key}: expected a finite number, got {value}")
    elif typ is str:
        if not isinstance(value, str):
            raise ConfigError(f"{key}: expected a string, got {value!r}")
        if meta.get("choices") and value not in meta["choices"]:
            raise ConfigError(f"{key}: expected one of {list(meta['choices'])}, got {value!r}")
        if meta.get("profiles"):
            if value not in list_profiles():
                raise ConfigError(f"{key}: expected one of {list_profiles()}, got {value!r}")
        if meta.get("registry") is not None and value not in meta["registry"].names():
            raise ConfigError(f"{key}: expected one of {meta['registry'].names()}, got {value!r}")
        return value
    elif origin is list:
        (inner,) = typing.get_args(typ)
        if not isinstance(value, list):
            raise ConfigError(f"{key}: expected a list, got {value!r}")
        if meta.get("length") is not None and len(value) != meta["length"]:
            raise ConfigError(f"{key}: expected a list of {meta['length']} values, got {len(value)}")
        return [_check_value(f"{key}[{i}]", inner, {}, v) for i, v in enumerate(value)]
    low, high = meta.get("low"), meta.get("high")
    if low is not None and (value < low or (meta.get("low_open") and value == low)):
        raise ConfigError(f"{key}: expected a value {'>' if meta.get('low_open') else '>='} {low}, got {value!r}")
    if high is not None and value > high:
        raise ConfigError(f"{key}: expected a value <= {high}, got {value!r}")
    return value


#: The key of the config's multi-radar rig, an array of tables (``[[sensors]]``): not ``[[sensor]]``,
#: which TOML could not hold beside the single radar's ``[sensor]`` table; its name is the rig's
#: everywhere else (``sensors.csv``, ``--sensors FILE``, ``Recording.sensors``).
RIG_KEY = "sensors"


def _apply(obj: Any, data: dict, prefix: str) -> None:
    """Overlay ``data`` onto the dataclass ``obj`` with full checking; unknown keys are refused."""
    fields = {f.name: f for f in dataclasses.fields(obj)}
    for key, value in data.items():
        dotted = f"{prefix}{key}"
        if key not in fields:
            raise ConfigError(f"{dotted}: unknown key (known here: {', '.join(sorted(fields))})")
        if isinstance(obj, Config) and key == RIG_KEY:
            obj.sensors = _apply_rig(value, dotted)
            continue
        current = getattr(obj, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                if key == "sensor" and isinstance(value, list):
                    raise ConfigError(f"{dotted}: expected the table [sensor] (one radar's mounting), got an array "
                                      f"of tables [[sensor]]; a rig of several radars is [[{RIG_KEY}]]")
                raise ConfigError(f"{dotted}: expected a table, got {value!r}")
            _apply(current, value, dotted + ".")
        else:
            setattr(obj, key, _check_value(dotted, _field_type(type(obj), key), dict(fields[key].metadata), value))


def _apply_rig(value: Any, key: str = RIG_KEY) -> list[RigSensorConfig]:
    """The ``[[sensors]]`` tables (a list of dicts) as :class:`RigSensorConfig`, each checked: the
    required keys, the types and ranges of :mod:`.sections`, each ``id`` once, the yaw in degrees.
    Every fault is one :class:`ConfigError` line naming the table's index and key (``sensors[1].id``)."""
    if not isinstance(value, list):
        got = "a table [sensors]" if isinstance(value, dict) else repr(value)
        raise ConfigError(f"{key}: expected an array of tables [[{RIG_KEY}]], one per radar, got {got}")
    fields = {f.name: f for f in dataclasses.fields(RigSensorConfig)}
    out: list[RigSensorConfig] = []
    seen: dict[int, int] = {}
    for i, table in enumerate(value):
        at = f"{key}[{i}]"
        if isinstance(table, RigSensorConfig):
            table = {k: v for k, v in dataclasses.asdict(table).items() if v is not None}
        if not isinstance(table, dict):
            raise ConfigError(f"{at}: expected a table (id, x_m, y_m, yaw_deg, ...), got {table!r}")
        if "yaw_rad" in table:
            raise ConfigError(f"{at}.yaw_rad: unknown key; the config takes the yaw in degrees, yaw_deg "
                              f"(sensors.csv's yaw_rad is radians), got yaw_rad = {table['yaw_rad']!r}")
        for k in table:
            if k not in fields:
                raise ConfigError(f"{at}.{k}: unknown key (known here: {', '.join(fields)})")
        for k in RIG_REQUIRED:
            if table.get(k) is None:
                raise ConfigError(f"{at}.{k}: missing (each [[{RIG_KEY}]] table needs {', '.join(RIG_REQUIRED)})")
        s = RigSensorConfig()
        for k, v in table.items():
            if v is None:                       # an optional value not stated (TOML has no null)
                continue
            typ = _field_type(RigSensorConfig, k)
            inner = [a for a in typing.get_args(typ) if a is not type(None)]
            meta = dict(fields[k].metadata)
            if k == "yaw_deg":              # the range check below, with the hint of a radian given
                meta = dict(meta, low=None, high=None)
            v = _check_value(f"{at}.{k}", inner[0] if inner else typ, meta, v)
            if k == "yaw_deg" and abs(v) > 360.0:
                raise ConfigError(f"{at}.yaw_deg: expected degrees within [-360, 360], got {v!r}")
            setattr(s, k, v)
        if s.id in seen:
            raise ConfigError(f"{at}.id: expected each sensor once, got {s.id} again (as {key}[{seen[s.id]}])")
        seen[s.id] = i
        out.append(s)
    return out


def validate(cfg: Config) -> Config:
    """Check every field of ``cfg`` (type and range) and cross-field constraints; return ``cfg``."""
    _apply(copy.deepcopy(cfg), to_dict(cfg), "")
    t = cfg.trajectory
    if t.turn_end < t.turn_start:
        raise ConfigError(f"trajectory.turn_end: expected >= turn_start ({t.turn_start}), got {t.turn_end}")
    if cfg.radar.scene_max_m <= cfg.radar.scene_min_m:
        raise ConfigError(f"radar.scene_max_m: expected > scene_min_m ({cfg.radar.scene_min_m}), got {cfg.radar.scene_max_m}")
    for i, v in enumerate(cfg.world.vehicles):
        if len(v) != 4 or v[2] <= 0 or v[3] <= 0:
            raise ConfigError(f"world.vehicles[{i}]: expected [x, y, size_x > 0, size_y > 0], got {v}")
    r, w = cfg.radar, cfg.world
    if w.layout == "rows":
        n_vehicles = w.rows * w.cars_per_row
        if n_vehicles > MAX_VEHICLES:
            raise ConfigError(f"world.cars_per_row: expected at most {MAX_VEHICLES} cars in all (rows x cars_per_row), "
                              f"got {w.rows} x {w.cars_per_row} = {n_vehicles}")
        area = n_vehicles * w.car_length_m * w.car_width_m
    else:
        n_vehicles = len(w.vehicles)
        area = sum(v[2] * v[3] for v in w.vehicles)
    clutter = r.clutter_rate_per_m2 * (r.scene_max_m - r.scene_min_m) ** 2
    if r.points_per_m2 * area > MAX_DETECTIONS_PER_SCAN:
        raise ConfigError(f"radar.points_per_m2: expected at most {MAX_DETECTIONS_PER_SCAN} expected vehicle detections "
                          f"per scan, got {r.points_per_m2 * area:.3g} ({r.points_per_m2} per m^2 over {area:.3g} m^2)")
    if r.spread_model == "scatter-centres":   # the most a scan can expect, nearest range (b.4.2)
        sides = (2 * w.rows * w.cars_per_row * (w.car_length_m + w.car_width_m) if w.layout == "rows"
                 else sum(2 * (v[2] + v[3]) for v in w.vehicles))
        peak = (r.scatter_ref_range_m / r.scatter_near_range_m) ** r.scatter_range_exponent * (
            n_vehicles * (4 * r.scatter_corner_points + 4 * r.scatter_wheel_points + r.scatter_underbody_points)
            + r.scatter_face_points_per_m * sides / 2)
        if peak > MAX_DETECTIONS_PER_SCAN:
            raise ConfigError(f"radar.scatter_ref_range_m: expected at most {MAX_DETECTIONS_PER_SCAN} expected vehicle "
                              f"detections per scan at the nearest range, got {peak:.3g}")
    if clutter > MAX_DETECTIONS_PER_SCAN:
        raise ConfigError(f"radar.clutter_rate_per_m2: expected at most {MAX_DETECTIONS_PER_SCAN} clutter points per "
                          f"scan, got {clutter:.3g} ({r.clutter_rate_per_m2} per m^2 over the scene)")
    if w.departing_vehicle >= n_vehicles:
        raise ConfigError(f"world.departing_vehicle: expected -1 or an index < {n_vehicles}, got {w.departing_vehicle}")
    if cfg.landmarks.removal_max_hits >= cfg.landmarks.removal_window:
        raise ConfigError(f"landmarks.removal_max_hits: expected < removal_window ({cfg.landmarks.removal_window}), got {cfg.landmarks.removal_max_hits}")
    for key in ("initial_pose_std", "truth_pose_std"):     # 0: that coordinate exact (b.5.1)
        if any(s < 0 for s in getattr(cfg.filter, key)):
            raise ConfigError(f"filter.{key}: expected values >= 0, got {getattr(cfg.filter, key)}")
    if not cfg.sensor.height_min_m < cfg.sensor.height_max_m:
        raise ConfigError(f"sensor.height_min_m: expected below sensor.height_max_m ({cfg.sensor.height_max_m}), got "
                          f"{cfg.sensor.height_min_m}")
    q = cfg.sensor.mount_quaternion
    if len(q) not in (0, 4) or (q and not sum(x * x for x in q) > 0):
        raise ConfigError(f"sensor.mount_quaternion: expected [] or a non-zero [x, y, z, w], got {q}")
    if any(s <= 0 for s in cfg.extent.mem_ekf_init_std):
        raise ConfigError(f"extent.mem_ekf_init_std: expected positive values, got {cfg.extent.mem_ekf_init_std}")
    if any(s < 0 for s in cfg.extent.mem_ekf_process_std):
        raise ConfigError(f"extent.mem_ekf_process_std: expected values >= 0, got {cfg.extent.mem_ekf_process_std}")
    return cfg


def read_toml(path: str | Path, what: str = "config file", error: type[Exception] = ConfigError) -> dict:
    """The TOML file ``path`` as a dict; any failure is one ``error`` line naming ``what`` and the file
    (missing, a directory, unreadable, not UTF-8 text, not valid TOML)."""
    path = Path(path)
    try:
        with path.open("rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise error(f"{what} {path}: no such file") from None
    except IsADirectoryError:
        raise error(f"{what} {path}: expected a TOML file, got a directory") from None
    except OSError as exc:
        raise error(f"{what} {path}: cannot read ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise error(f"{what} {path}: expected UTF-8 TOML text, got undecodable bytes") from None
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{what} {path}: not valid TOML ({exc})") from None


def to_dict(cfg: Any) -> dict:
    """Plain nested dict of a config dataclass. A :class:`Config`'s rig (``sensors``) is left out when
    empty (so the dict, and the hash of a stored run, of every config without a rig is as before) and
    its optional values when not stated (None), as in TOML."""
    d = dataclasses.asdict(cfg)
    if isinstance(cfg, Config):
        rig = d.pop(RIG_KEY)
        if rig:
            d[RIG_KEY] = [{k: v for k, v in t.items() if v is not None} for t in rig]
    return d


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} as TOML")


def to_toml(cfg: Config, *, comments: bool = True, notes: dict[str, str] | None = None) -> str:
    """Serialise ``cfg`` as TOML (the stdlib reads TOML but does not write it). ``notes`` puts one
    comment line under a section's header (``{section: text}``), e.g. which radar's mounting a
    recording run's ``[sensor]`` holds."""
    lines = [f"# radarslam configuration (profile {cfg.profile!r})", f"profile = {_toml_value(cfg.profile)}"]
    for f in dataclasses.fields(cfg):
        sub = getattr(cfg, f.name)
        if not dataclasses.is_dataclass(sub):
            continue
        lines += ["", f"[{f.name}]"]
        if notes and f.name in notes:
            lines.append("# " + " ".join(str(notes[f.name]).split()))
        for g in dataclasses.fields(sub):
            doc = f"  # {g.metadata['doc']}" if comments and g.metadata.get("doc") else ""
            lines.append(f"{g.name} = {_toml_value(getattr(sub, g.name))}{doc}")
    if comments and not cfg.sensors:
        lines += ["", (f"# [[{RIG_KEY}]]: none. A rig of several radars, one table per radar, in place of the "
                       "recording's sensors.csv"),
                  ("# (docs/recordings.md \"A rig in the config\"): id, x_m, y_m, yaw_deg (DEGREES) [, name, "
                   "max_range_m, fov_deg]")]
    for s in to_dict(cfg).get(RIG_KEY, []):
        lines += ["", f"[[{RIG_KEY}]]"]
        for k, v in s.items():
            doc = RigSensorConfig.__dataclass_fields__[k].metadata.get("doc")
            lines.append(f"{k} = {_toml_value(v)}" + (f"  # {doc}" if comments and doc else ""))
    return "\n".join(lines) + "\n"
