"""The plain recording format: CSV files in a directory, or one NPZ file (docs/recordings.md).

A directory holds ``detections.csv``, ``odometry.csv`` and optionally ``truth.csv``,
``scans.csv`` and ``sensors.csv`` (a multi-radar rig, :mod:`.sensors`); an ``.npz`` file holds
the same tables as arrays named ``TABLE.COLUMN`` (e.g. ``detections.range_m``). Columns carry
their unit in their name; every fault is one :class:`InputError` line naming the file, the line
(CSV) or array (NPZ), the column and the fault.
"""

from __future__ import annotations

import csv
import math
import zipfile
from pathlib import Path

import numpy as np

from radarslam.core.angles import wrap_pi
from radarslam.core.errors import InputError
from radarslam.io.recording import sensors as S
from radarslam.io.recording.stream import CHANNELS, ODOMETRY_KINDS, Recording, check_times

#: Required and optional columns of every table (``rcs`` may be spelt ``intensity``).
REQUIRED = {"detections": ("t_s", "range_m", "azimuth_rad"), "truth": ("t_s", "x_m", "y_m", "yaw_rad"),
            "scans": ("t_s",), "sensors": S.REQUIRED}
#: ``label`` (an annotation, evaluation only: it never reaches the filter) and ``scan`` (which scan a
#: detection belongs to) are read apart from the channels.
OPTIONAL = {"detections": CHANNELS + ("label", "scan"), "truth": (), "scans": (), "odometry": (),
            "sensors": S.OPTIONAL}
#: Columns whose values must be whole numbers >= 0.
INTEGER = ("sensor_id", "label", "scan")
ALIASES = {"intensity": "rcs"}
#: Largest plausible magnitude of an angle-like column (rad); beyond it the values look like degrees.
#: The truth's yaw is exempt: a yaw unwrapped over turns (7 rad after a full turn) is radians, wrapped
#: on reading (:data:`UNWRAPPED`).
ANGLE_LIMITS = {"azimuth_rad": 2 * math.pi, "yaw_rad": 2 * math.pi, "steering_rad": math.pi / 2,
                "yaw_rate_rad_s": 2 * math.pi}
#: Column names in other units, refused with the name expected.
WRONG_UNITS = {"azimuth_deg": "azimuth_rad", "bearing_deg": "azimuth_rad", "yaw_deg": "yaw_rad",
               "yaw_rate_deg_s": "yaw_rate_rad_s", "steering_deg": "steering_rad", "range_km": "range_m",
               "t_ms": "t_s", "t_ns": "t_s", "speed_kmh": "speed_mps"}
FILES = ("detections", "odometry", "truth", "scans", "sensors")
#: ``(table, column)`` of angles that may be unwrapped: accepted at any size and wrapped to (-pi, pi].
UNWRAPPED = (("truth", "yaw_rad"),)


def _columns(table: str, header: list[str], where: str) -> list[str]:
    """Check a header; return it with aliases resolved."""
    names = [ALIASES.get(h.strip(), h.strip()) for h in header]
    for h in names:
        if h in WRONG_UNITS:
            raise InputError(f"{where} column {h}: expected {WRONG_UNITS[h]} (SI units and radians), got {h}")
    if table == "odometry":
        kinds = [k for k, cols in ODOMETRY_KINDS.items() if set(cols) <= set(names)]
        if len(kinds) != 1 or "t_s" not in names:
            raise InputError(f"{where}: expected columns t_s and either speed_mps, yaw_rate_rad_s (unicycle) or "
                             f"wheel_speed_mps, steering_rad (ackermann), got {', '.join(names) or 'none'}")
        allowed = ("t_s",) + ODOMETRY_KINDS[kinds[0]]
    else:
        missing = [c for c in REQUIRED[table] if c not in names]
        if missing:
            raise InputError(f"{where}: missing column(s) {', '.join(missing)}; expected "
                             f"{', '.join(REQUIRED[table])}, got {', '.join(names) or 'none'}")
        allowed = REQUIRED[table] + OPTIONAL[table]
    extra = [h for h in names if h not in allowed]
    if extra or len(set(names)) != len(names):
        raise InputError(f"{where}: unexpected or repeated column(s) {', '.join(extra or names)}; expected "
                         f"{', '.join(allowed)}")
    return names


def _check_values(table: str, cols: dict[str, np.ndarray], where: str, row: str, first: int) -> None:
    """Finite values, non-negative ranges, angles in radians, whole ids, ordered times."""
    for name, v in cols.items():
        if name in S.TEXT:
            continue
        bad = np.flatnonzero(~np.isfinite(v))
        if bad.size:
            raise InputError(f"{where} {row} {int(bad[0]) + first} column {name}: expected a finite number, "
                             f"got {float(v[bad[0]])!r}")
        lim = None if (table, name) in UNWRAPPED else ANGLE_LIMITS.get(name)
        if lim is not None and v.size and np.max(np.abs(v)) > lim + 1e-9:
            i = int(np.argmax(np.abs(v)))
            raise InputError(f"{where} {row} {i + first} column {name}: expected radians (|value| <= {lim:.4g}), "
                             f"got {float(v[i])!r}: degrees?")
        if name in INTEGER and table == "detections":
            S.integer_column(v, name, where, row, first)
    if "range_m" in cols and np.any(cols["range_m"] < 0):
        i = int(np.argmax(cols["range_m"] < 0))
        raise InputError(f"{where} {row} {i + first} column range_m: expected a range >= 0, "
                         f"got {float(cols['range_m'][i])!r}")
    if "t_s" in cols:
        check_times(cols["t_s"], where, strict=table != "detections", row=row, first=first)


def _read_csv(path: Path, table: str) -> dict[str, np.ndarray]:
    """One table of a plain recording: numpy's C parser for an all-numeric table (a million rows in
    about a second), and on any fault the cell-by-cell reader below, whose one-line error names the
    line and column."""
    fast = None if table == "sensors" else _read_csv_fast(path, table)
    if fast is not None:
        return fast
    return _read_csv_careful(path, table)


def _read_csv_fast(path: Path, table: str) -> dict[str, np.ndarray] | None:
    """All-numeric CSV through ``np.loadtxt``; None when anything is off (then the careful reader)."""
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            header = next(csv.reader([fh.readline()]), None)
            if not header:
                return None
            names = _columns(table, header, str(path))
            data = np.loadtxt(fh, delimiter=",", dtype=np.float64, ndmin=2)
    except (OSError, UnicodeDecodeError, csv.Error, ValueError, InputError):
        return None
    if data.size == 0 or data.shape[1] != len(names):
        return None
    cols = {n: np.ascontiguousarray(data[:, j]) for j, n in enumerate(names)}
    _check_values(table, cols, str(path), "line", 2)
    return cols


def _read_csv_careful(path: Path, table: str) -> dict[str, np.ndarray]:
    where = str(path)
    try:
        with path.open(newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except OSError as exc:
        raise InputError(f"{where}: cannot read ({exc.strerror})") from None
    except (UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"{where}: expected UTF-8 CSV text, got unreadable content ({exc})") from None
    if not rows:
        raise InputError(f"{where}: expected a header line, got an empty file")
    names = _columns(table, rows[0], where)
    data = np.empty((len(rows) - 1, len(names)))
    text = {j: [] for j, n in enumerate(names) if n in S.TEXT and table == "sensors"}
    for i, r in enumerate(rows[1:]):
        if len(r) != len(names):
            raise InputError(f"{where} line {i + 2}: expected {len(names)} values ({', '.join(names)}), got {len(r)} "
                             "(a truncated or malformed line)")
        for j, cell in enumerate(r):
            if j in text:
                text[j].append(cell.strip())
                continue
            try:
                data[i, j] = float(cell)
            except ValueError:
                raise InputError(f"{where} line {i + 2} column {names[j]}: expected a number, got {cell!r}") from None
    cols = {n: np.array(text[j]) if j in text else data[:, j].copy() for j, n in enumerate(names)}
    _check_values(table, cols, where, "line", 2)
    return cols


def _read_npz_tables(path: Path) -> dict[str, dict[str, np.ndarray]]:
    where = str(path)
    try:
        with path.open("rb") as fh, np.load(fh, allow_pickle=False) as z:   # our handle: closed on failure too
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise InputError(f"{where}: expected an NPZ file of arrays TABLE.COLUMN, got an unreadable file ({exc})") from None
    tables: dict[str, dict[str, np.ndarray]] = {}
    for key, arr in arrays.items():
        table, _, col = key.partition(".")
        if table not in FILES or not col:
            raise InputError(f"{where} array {key!r}: expected names TABLE.COLUMN with TABLE in {', '.join(FILES)}")
        is_text = table == "sensors" and col in S.TEXT
        if arr.ndim != 1 or arr.dtype.kind not in ("U" if is_text else "fiub"):
            raise InputError(f"{where} array {key}: expected a 1-D {'text' if is_text else 'numeric'} array, got "
                             f"shape {arr.shape} {arr.dtype}")
        tables.setdefault(table, {})[col] = arr if is_text else arr.astype(np.float64)
    for table, cols in tables.items():
        names = _columns(table, list(cols), f"{where} table {table}")
        cols = {ALIASES.get(k, k): v for k, v in cols.items()}
        sizes = {v.size for v in cols.values()}
        if len(sizes) != 1:
            raise InputError(f"{where} table {table}: expected columns of one length, got "
                             + ", ".join(f"{k} {v.size}" for k, v in cols.items()))
        tables[table] = {n: cols[n] for n in names}
        _check_values(table, tables[table], f"{where} table {table}", "row", 1)
    return tables


def read_plain(path: str | Path) -> Recording:
    """Read a plain recording: a directory of CSV files or an ``.npz`` file."""
    path = Path(path)
    if path.is_dir():
        if not (path / "detections.csv").is_file() or not (path / "odometry.csv").is_file():
            raise InputError(f"{path}: expected detections.csv and odometry.csv in the directory, got "
                             f"{sorted(p.name for p in path.iterdir())[:10]}")
        tables = {t: _read_csv(path / f"{t}.csv", t) for t in FILES if (path / f"{t}.csv").is_file()}
    elif path.suffix == ".npz" and path.is_file():
        tables = _read_npz_tables(path)
        for t in ("detections", "odometry"):
            if t not in tables:
                raise InputError(f"{path}: expected arrays {t}.* (table {t}), got none")
    else:
        raise InputError(f"{path}: expected a directory of CSV files or an .npz file")
    csv_rows = path.is_dir()
    return _recording(tables, str(path), (lambda t: str(path / f"{t}.csv")) if csv_rows else
                      (lambda t: f"{path} table {t}"), ("line", 2) if csv_rows else ("row", 1))


def _recording(tables: dict[str, dict[str, np.ndarray]], source: str, where=lambda t: t,
               row: tuple[str, int] = ("line", 2)) -> Recording:
    d, o = tables["detections"], tables["odometry"]
    sensors = None
    if "sensors" in tables:
        sensors = S.sensors_from_columns(tables["sensors"], where("sensors"), *row)
        S.check_detection_sensors(d.get("sensor_id"), sensors, where("detections"), *row)
    kind = next(k for k, cols in ODOMETRY_KINDS.items() if cols[0] in o)
    tr = tables.get("truth")
    sc = tables.get("scans")
    if d["t_s"].size == 0 and sc is None:
        raise InputError(f"{source}: expected at least one detection, got none")
    if sc is not None and not np.all(np.isin(np.unique(d["t_s"]), sc["t_s"])):
        raise InputError(f"{source}: every detection time must be a scan time of scans.csv, got one that is not")
    return Recording(d["t_s"], np.column_stack([d["range_m"], d["azimuth_rad"]]),
                     {c: d[c] for c in CHANNELS if c in d}, o["t_s"],
                     np.column_stack([o[c] for c in ODOMETRY_KINDS[kind]]), kind,
                     None if tr is None else tr["t_s"],
                     None if tr is None else np.column_stack([tr["x_m"], tr["y_m"], _wrapped(tr["yaw_rad"])]),
                     source=source, scan_t=None if sc is None else sc["t_s"], sensors=sensors,
                     labels=d["label"].astype(np.int64) if "label" in d else None,
                     det_scan=d["scan"].astype(np.int64) if "scan" in d else None)


def _wrapped(yaw: np.ndarray) -> np.ndarray:
    """``yaw`` wrapped to (-pi, pi], the values already there untouched (bit for bit)."""
    return np.where((yaw > -np.pi) & (yaw <= np.pi), yaw, wrap_pi(yaw))


def recording_tables(rec: Recording) -> dict[str, dict[str, np.ndarray]]:
    """The plain tables of ``rec`` (detections in the sensor frame)."""
    tables = {"detections": {"t_s": rec.det_t, "range_m": rec.det_polar[:, 0], "azimuth_rad": rec.det_polar[:, 1],
                             **{c: rec.channels[c] for c in CHANNELS if c in rec.channels},
                             **({} if rec.labels is None else {"label": rec.labels}),
                             **({} if rec.det_scan is None else {"scan": rec.det_scan})},
              "odometry": {"t_s": rec.odo_t, **dict(zip(ODOMETRY_KINDS[rec.odo_kind], rec.odo.T))}}
    if rec.truth is not None:
        tables["truth"] = {"t_s": rec.truth_t, "x_m": rec.truth[:, 0], "y_m": rec.truth[:, 1],
                           "yaw_rad": rec.truth[:, 2]}
    if rec.scan_t is not None and not np.array_equal(rec.scan_t, np.unique(rec.det_t)):
        tables["scans"] = {"t_s": rec.scan_t}
    if rec.sensors:
        tables["sensors"] = S.sensors_table(rec.sensors)
    return tables


def write_plain(rec: Recording, path: str | Path) -> list[Path]:
    """Write ``rec`` as CSV files into the existing directory ``path``, or as one ``.npz`` file when
    ``path`` ends in ``.npz``; values are written with ``repr`` (they read back bit for bit)."""
    from radarslam.io.results import atomic_write_bytes, atomic_write_text

    path = Path(path)
    tables = recording_tables(rec)
    if path.suffix == ".npz":
        import io

        buf = io.BytesIO()
        np.savez(buf, **{f"{t}.{c}": np.asarray(v) for t, cols in tables.items() for c, v in cols.items()})
        atomic_write_bytes(path, buf.getvalue())
        return [path]
    out = []
    for t, cols in tables.items():
        cells = [[_cell(c, v) for v in vals.tolist()] for c, vals in cols.items()]
        lines = [",".join(cols)] + [",".join(row) for row in zip(*cells)]
        atomic_write_text(path / f"{t}.csv", "\n".join(lines) + "\n")
        out.append(path / f"{t}.csv")
    return out


def _cell(column: str, v) -> str:
    """One CSV cell: whole numbers for ids, the text of a name (quoted when it must be), else ``repr``."""
    if column in S.TEXT:
        return '"' + v.replace('"', '""') + '"' if any(c in v for c in ',"\n') else v
    return str(int(v)) if column in INTEGER else repr(float(v))


def read_sensors_file(path, what: str = "--sensors") -> dict[int, S.Mounting]:
    """A ``sensors.csv`` file at ``path`` (e.g. ``--sensors FILE``), refused in one line as a recording's
    own would be (the file, line and column), or as ``{what}: PATH: no such file``."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{what}: {path}: no such file")
    return S.sensors_from_columns(_read_csv(path, "sensors"), str(path))
