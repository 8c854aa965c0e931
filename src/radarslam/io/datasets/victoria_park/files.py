"""The Victoria Park dataset's file readers (:mod:`radarslam.io.datasets.victoria_park`): every
failure becomes a :class:`~radarslam.core.errors.DataError` naming the file.
"""

from __future__ import annotations

import math
import zipfile
from pathlib import Path

import numpy as np

from radarslam.core.errors import DataError
from radarslam.io.datasets.victoria_park.records import (
    FILE_DR,
    FILE_GPS,
    FILE_NPZ,
    FILE_ZIP,
    MAT_EPOCH_MS,
    MAX_CODE_CM,
    N_BEAMS,
    TIME_MATCH_S,
    ZIP_MEMBER,
)



# --------------------------------------------------------------------------------------------
def _require(path: Path) -> Path:
    if not path.is_file():
        raise DataError(f"{path}: file not found" + (" (is a directory)" if path.is_dir() else ""))
    return path


def _read_mat(path: Path, names: tuple[str, ...]) -> dict[str, np.ndarray]:
    import scipy.io

    _require(path)
    try:
        with open(path, "rb") as fh:
            mat = scipy.io.loadmat(fh, variable_names=names)
    # The MAT reader signals a truncated or corrupt file with OSError, ValueError, IndexError,
    # zlib.error, MatReadError, ... depending on where the damage is; any of them means the same here.
    except Exception as exc:  # noqa: BLE001
        raise DataError(f"{path}: cannot read the MAT file (truncated or corrupt?): {type(exc).__name__}: {exc}") from exc
    missing = [n for n in names if n not in mat]
    if missing:
        raise DataError(f"{path}: missing variable(s) {missing}; expected {list(names)}")
    return {n: mat[n] for n in names}


def _vector(path: Path | str, name: str, arr: np.ndarray, n: int | None = None) -> np.ndarray:
    """A numeric (n,) float64 vector from a MAT (n, 1) / (1, n) / (n,) variable, finite."""
    a = np.asarray(arr)
    if a.dtype.kind not in "biuf" or a.ndim > 2 or (a.ndim == 2 and min(a.shape) != 1):
        raise DataError(f"{path}: variable {name!r}: expected a numeric vector, got dtype {a.dtype} shape {a.shape}")
    v = a.astype(np.float64).ravel()
    if n is not None and v.size != n:
        raise DataError(f"{path}: variable {name!r}: expected {n} values (as the other variables), got {v.size}")
    _finite(path, name, v)
    return v


def _finite(path: Path | str, name: str, v: np.ndarray) -> None:
    if not np.all(np.isfinite(v)):
        bad = np.argwhere(~np.isfinite(v))[0]
        raise DataError(f"{path}: variable {name!r}: expected finite values, "
                        f"got {v[tuple(bad)]} at index {tuple(int(i) for i in bad)}")


def _increasing(path: Path, name: str, t: np.ndarray, minimum: int = 2) -> None:
    if t.size < minimum:
        raise DataError(f"{path}: variable {name!r}: expected at least {minimum} samples, got {t.size}")
    d = np.diff(t)
    if np.any(d <= 0):
        i = int(np.argmax(d <= 0))
        raise DataError(f"{path}: variable {name!r}: expected strictly increasing times, "
                        f"got {t[i]!r} then {t[i + 1]!r} at index {i + 1}")


def _read_laser_npz(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            missing = [n for n in ("LASER", "TLsr") if n not in z.files]
            if missing:
                raise DataError(f"{path}: missing array(s) {missing}; expected ['LASER', 'TLsr'], got {sorted(z.files)}")
            ranges, t = z["LASER"], z["TLsr"]
    except DataError:
        raise
    # zipfile.BadZipFile, zlib.error, EOFError, ValueError (bad header), ...: all mean a damaged file.
    except Exception as exc:  # noqa: BLE001
        raise DataError(f"{path}: cannot read the npz file (truncated or corrupt?): {type(exc).__name__}: {exc}") from exc
    if ranges.dtype.kind not in "iu" or ranges.ndim != 2 or ranges.shape[1] != N_BEAMS:
        raise DataError(f"{path}: array 'LASER': expected integer cm of shape (N, {N_BEAMS}), "
                        f"got dtype {ranges.dtype} shape {ranges.shape}")
    if t.ndim != 1 or t.shape[0] != ranges.shape[0] or t.dtype.kind not in "iuf":
        raise DataError(f"{path}: array 'TLsr': expected ({ranges.shape[0]},) times matching 'LASER', "
                        f"got dtype {t.dtype} shape {t.shape}")
    t = t.astype(np.float64)
    _finite(path, "TLsr", t)
    if ranges.size and (ranges.min() < 0 or ranges.max() > MAX_CODE_CM):
        raise DataError(f"{path}: array 'LASER': expected cm values in [0, {MAX_CODE_CM}], got [{ranges.min()}, {ranges.max()}]")
    return ranges.astype(np.uint16, copy=False), t


def _read_laser_zip(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        with zipfile.ZipFile(path) as zf:
            if ZIP_MEMBER not in zf.namelist():
                raise DataError(f"{path}: missing member {ZIP_MEMBER!r}; got {zf.namelist()}")
            text = zf.read(ZIP_MEMBER)
    except DataError:
        raise
    except Exception as exc:  # noqa: BLE001  (BadZipFile, zlib.error, EOFError, CRC errors, ...)
        raise DataError(f"{path}: cannot read the zip file (truncated or corrupt?): {type(exc).__name__}: {exc}") from exc
    where = f"{path}:{ZIP_MEMBER}"
    try:
        values = np.array(text.split(), dtype=np.float64)
    except ValueError as exc:
        raise DataError(f"{where}: expected whitespace-separated numbers: {exc}") from exc
    width = 1 + N_BEAMS
    if values.size == 0 or values.size % width:
        raise DataError(f"{where}: expected records of {width} numbers (time + {N_BEAMS} ranges), got {values.size} numbers")
    rec = values.reshape(-1, width)
    _finite(where, "LASER.txt", rec)
    r = rec[:, 1:]
    if r.min() < 0 or r.max() > MAX_CODE_CM / 100 + 1e-9:
        raise DataError(f"{where}: expected ranges in [0, {MAX_CODE_CM / 100}] m, got [{r.min()}, {r.max()}]")
    return np.rint(r * 100.0).astype(np.uint16), rec[:, 0].copy()


def _read_tlsr_h5(path: Path, laser_t: np.ndarray) -> np.ndarray | None:
    """The complete original laser times (s) if the h5 file and h5py are both there, else None."""
    if not path.is_file():
        return None
    try:
        import h5py
    except ImportError:
        return None
    try:
        with h5py.File(path, "r") as f:
            if "timeLsr" not in f:
                raise DataError(f"{path}: missing dataset 'timeLsr'; got {sorted(f.keys())}")
            ms = np.asarray(f["timeLsr"][()], dtype=np.float64).ravel()
    except DataError:
        raise
    except Exception as exc:  # noqa: BLE001
        raise DataError(f"{path}: cannot read the HDF5 file (truncated or corrupt?): {type(exc).__name__}: {exc}") from exc
    t = (ms - MAT_EPOCH_MS) / 1000.0
    _finite(path, "timeLsr", t)
    n = laser_t.size
    if t.size < n or np.max(np.abs(t[:n] - laser_t)) > TIME_MATCH_S:
        raise DataError(f"{path}: 'timeLsr' does not start with the {n} laser times of the scan file "
                        f"(the ASCII scans are its first entries); {t.size} entries")
    return t


def _read_trees(path: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    names = ("lidar_ranges", "lidar_bearings", "lidar_signatures")
    mat = _read_mat(path, names)
    arrs = []
    for n in names:
        a = np.asarray(mat[n])
        if a.dtype.kind not in "biuf" or a.ndim != 2 or a.shape != np.shape(mat[names[0]]):
            raise DataError(f"{path}: variable {n!r}: expected a numeric 2-D array of the shape of 'lidar_ranges' "
                            f"{np.shape(mat[names[0]])}, got dtype {a.dtype} shape {a.shape}")
        a = a.astype(np.float64)
        _finite(path, n, a)
        if a.size and a.min() < 0:
            raise DataError(f"{path}: variable {n!r}: expected values >= 0, got {a.min()}")
        arrs.append(a)
    rng, brg, dia = arrs
    if brg.size and brg.max() > math.pi + 1e-9:
        raise DataError(f"{path}: variable 'lidar_bearings': expected radians in [0, pi], got max {brg.max()}")
    pad = rng == 0
    if np.any(pad & ((brg != 0) | (dia != 0))) or np.any(~pad & (dia == 0)):
        raise DataError(f"{path}: expected zero padding in the same places in 'lidar_ranges', 'lidar_bearings' "
                        f"and 'lidar_signatures' (0 = no detection)")
    return rng, brg, dia


def _read_laser(root: Path, laser_source: str) -> tuple[Path, np.ndarray, np.ndarray]:
    """The laser file read (the npz, or the zip when asked or when there is no npz): ``(file,
    ranges (N, 361) cm, times (N,) s)``, the times strictly increasing."""
    npz, zf = root / FILE_NPZ, root / FILE_ZIP
    if laser_source == "npz" or (laser_source == "auto" and npz.exists()):
        laser_file = _require(npz)
        ranges_cm, laser_t = _read_laser_npz(npz)
    else:
        if laser_source == "auto" and not zf.exists():
            raise DataError(f"{root}: no laser file: expected {FILE_NPZ} or {FILE_ZIP}")
        laser_file = _require(zf)
        ranges_cm, laser_t = _read_laser_zip(zf)
    _increasing(laser_file, "TLsr", laser_t)
    return laser_file, ranges_cm, laser_t


#: Largest gap (s) allowed between the start (end) of the odometry and the first (last) scan: the
#: recording's dead reckoning starts 0.12 s after its first scan; a scan beyond this gap would be
#: processed with no motion model input at all.
ODOMETRY_GAP_S = 1.0


def _read_dead_reckoning(root: Path, laser_file: Path, laser_t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The dead reckoning ``(t (s, ASCII time base), speed, steering)``, checked to cover the laser
    times ``laser_t`` (within :data:`ODOMETRY_GAP_S`)."""
    dr_file = root / FILE_DR
    mat = _read_mat(dr_file, ("time", "speed", "steering"))
    dr_t = (_vector(dr_file, "time", mat["time"]) - MAT_EPOCH_MS) / 1000.0
    speed = _vector(dr_file, "speed", mat["speed"], dr_t.size)
    steering = _vector(dr_file, "steering", mat["steering"], dr_t.size)
    _increasing(dr_file, "time", dr_t)
    if np.max(np.abs(steering)) >= math.pi / 2:
        raise DataError(f"{dr_file}: variable 'steering': expected radians within (-pi/2, pi/2), "
                        f"got max |steering| {np.max(np.abs(steering))}")
    if dr_t[0] >= laser_t[-1] or dr_t[-1] <= laser_t[0]:
        raise DataError(f"{dr_file}: variable 'time' ({dr_t[0]:.3f}..{dr_t[-1]:.3f} s after conversion) does not overlap "
                        f"the laser times of {laser_file.name} ({laser_t[0]:.3f}..{laser_t[-1]:.3f} s): wrong time base?")
    if dr_t[0] > laser_t[0] + ODOMETRY_GAP_S or dr_t[-1] < laser_t[-1] - ODOMETRY_GAP_S:
        raise DataError(f"{dr_file}: variable 'time': expected odometry over the whole laser span "
                        f"{laser_t[0]:.3f}..{laser_t[-1]:.3f} s of {laser_file.name} (within {ODOMETRY_GAP_S} s), got "
                        f"{dr_t[0]:.3f}..{dr_t[-1]:.3f} s: the scans outside it would be processed without motion")
    return dr_t, speed, steering


def _read_gps(root: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The GPS fixes ``(t (s, ASCII time base), x = Lo_m, y = La_m)``."""
    gps_file = root / FILE_GPS
    mat = _read_mat(gps_file, ("timeGps", "La_m", "Lo_m"))
    gps_t = (_vector(gps_file, "timeGps", mat["timeGps"]) - MAT_EPOCH_MS) / 1000.0
    gps_y = _vector(gps_file, "La_m", mat["La_m"], gps_t.size)
    gps_x = _vector(gps_file, "Lo_m", mat["Lo_m"], gps_t.size)
    _increasing(gps_file, "timeGps", gps_t)
    return gps_t, gps_x, gps_y
