"""nuScenes radar sweeps: binary PCD v0.7 files of the Continental ARS408's cluster list.

The layout is the Point Cloud Library's PCD v0.7 (pointclouds.org, "The PCD (Point Cloud Data) file
format"): a text header of ``KEY value...`` lines (``#`` lines are comments) that ends with the
``DATA`` line, then the points. With ``DATA binary`` the points follow as ``POINTS`` packed records,
each field in the order of ``FIELDS`` with ``SIZE`` bytes, ``TYPE`` F (float), I (signed) or U
(unsigned) and ``COUNT`` elements, little-endian. nuScenes' radar files (devkit
``nuscenes.utils.data_classes.RadarPointCloud.from_file``, whose docstring lists the fields) have
the 18 fields of :data:`RADAR_FIELDS`, ``WIDTH`` = ``POINTS`` (at most 125), ``HEIGHT`` 1, and are
padded after the points (the shipped files hold 125 records' worth of bytes whatever ``POINTS``
says, then zeros): exactly ``POINTS`` records are read and the rest ignored. A first point with a
NaN marks an empty sweep (the devkit's convention). Every cluster is kept: the devkit's default
filters (``invalid_state`` 0, ``ambig_state`` 3) are not applied, as in the conversion of
``../shared/data/nuscenes_radar`` (its SOURCE.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radarslam.core.errors import DataError

#: ``(name, TYPE, SIZE)`` of each field of a nuScenes radar PCD, in file order (COUNT 1 each).
RADAR_FIELDS = (("x", "F", 4), ("y", "F", 4), ("z", "F", 4), ("dyn_prop", "I", 1), ("id", "I", 2),
                ("rcs", "F", 4), ("vx", "F", 4), ("vy", "F", 4), ("vx_comp", "F", 4), ("vy_comp", "F", 4),
                ("is_quality_valid", "I", 1), ("ambig_state", "I", 1), ("x_rms", "I", 1), ("y_rms", "I", 1),
                ("invalid_state", "I", 1), ("pdh0", "I", 1), ("vx_rms", "I", 1), ("vy_rms", "I", 1))
#: numpy kind of each PCD ``TYPE``.
_KINDS = {"F": "f", "I": "i", "U": "u"}
#: Header lines read at most before ``DATA`` (the radar files have 11).
_MAX_HEADER_LINES = 64


def radar_dtype() -> np.dtype:
    """The packed little-endian record of :data:`RADAR_FIELDS` (43 bytes)."""
    return np.dtype([(n, f"<{_KINDS[t]}{s}") for n, t, s in RADAR_FIELDS])


def _header(raw: bytes, where: str) -> tuple[dict[str, list[str]], int]:
    """The header's ``KEY -> values`` and the offset of the first data byte."""
    head: dict[str, list[str]] = {}
    pos = 0
    for _ in range(_MAX_HEADER_LINES):
        nl = raw.find(b"\n", pos)
        if nl < 0:
            break
        try:
            line = raw[pos:nl].decode("ascii").strip()
        except UnicodeDecodeError:
            break
        pos = nl + 1
        if not line or line.startswith("#"):
            continue
        key, *values = line.split()
        head[key] = values
        if key == "DATA":
            return head, pos
    raise DataError(f"{where}: expected a PCD v0.7 header ending in a DATA line (pointclouds.org PCD format), "
                    "got none")


def read_radar_pcd(path: str | Path) -> np.ndarray:
    """The clusters of one radar sweep: a structured array of :func:`radar_dtype`, ``POINTS`` rows.

    Raises :class:`DataError` (one line naming the file) when the file is missing, its header is not
    PCD, its fields differ from :data:`RADAR_FIELDS`, its data is not ``binary`` or holds fewer than
    ``POINTS`` records.
    """
    path = Path(path)
    where = str(path)
    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DataError(f"{where}: cannot read the radar sweep ({exc.strerror or exc})") from None
    head, start = _header(raw, where)
    fields = head.get("FIELDS", [])
    got = list(zip(fields, head.get("TYPE", []), head.get("SIZE", []), head.get("COUNT", ["1"] * len(fields))))
    want = [(n, t, str(s), "1") for n, t, s in RADAR_FIELDS]
    if got != want or len(fields) != len(head.get("TYPE", [])) or len(fields) != len(head.get("SIZE", [])):
        names, types, sizes = (" ".join(str(f[i]) for f in RADAR_FIELDS) for i in range(3))
        raise DataError(f"{where}: expected the nuScenes radar PCD layout (FIELDS {names}; TYPE {types}; SIZE {sizes}; "
                        f"COUNT 1 each), got FIELDS {' '.join(fields) or 'none'}; TYPE "
                        f"{' '.join(head.get('TYPE', []))}; SIZE {' '.join(head.get('SIZE', []))}; COUNT "
                        f"{' '.join(head.get('COUNT', []))}")
    data = " ".join(head["DATA"])
    if data != "binary":
        raise DataError(f"{where}: expected DATA binary (nuScenes' radar sweeps), got DATA {data or 'nothing'}")
    try:
        points = int(head["POINTS"][0]) if "POINTS" in head else int(head["WIDTH"][0]) * int(head["HEIGHT"][0])
        width, height = int(head.get("WIDTH", [points])[0]), int(head.get("HEIGHT", [1])[0])
    except (ValueError, IndexError):
        raise DataError(f"{where}: expected whole numbers in WIDTH, HEIGHT and POINTS, got WIDTH "
                        f"{head.get('WIDTH')}, HEIGHT {head.get('HEIGHT')}, POINTS {head.get('POINTS')}") from None
    if points < 0 or height != 1 or width != points:
        raise DataError(f"{where}: expected an unorganised cloud (HEIGHT 1, WIDTH = POINTS >= 0), got WIDTH {width}, "
                        f"HEIGHT {height}, POINTS {points}")
    dtype = radar_dtype()
    need = points * dtype.itemsize
    if len(raw) - start < need:
        raise DataError(f"{where}: expected {points} points of {dtype.itemsize} bytes ({need} bytes) after the header, "
                        f"got {len(raw) - start} bytes (a truncated file)")
    cloud = np.frombuffer(raw, dtype=dtype, count=points, offset=start)   # the padding after them is ignored
    if points and np.isnan(cloud["x"][0]):
        return cloud[:0]
    return cloud


def polar_doppler(cloud: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(range_m, azimuth_rad, doppler_mps, rcs)`` of each cluster, in the radar's frame (x forward, y left).

    ``range = hypot(x, y)``, ``azimuth = atan2(y, x)`` and the Doppler the line-of-sight part of the
    cluster's RAW relative velocity ``(vx, vy)`` (not ego-compensated; positive receding):
    ``(x vx + y vy) / range`` (0 at range 0); ``vx_comp``, ``vy_comp`` are never read (docs/recordings.md
    "Doppler"). Computed in float64 from the file's float32 values.
    """
    x, y = cloud["x"].astype(np.float64), cloud["y"].astype(np.float64)
    vx, vy = cloud["vx"].astype(np.float64), cloud["vy"].astype(np.float64)
    rng = np.hypot(x, y)
    dop = np.divide(x * vx + y * vy, rng, out=np.zeros_like(rng), where=rng > 0)
    return rng, np.arctan2(y, x), dop, cloud["rcs"].astype(np.float64)
