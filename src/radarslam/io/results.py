"""Writing results: atomic JSON / text / ``.npz`` files, trajectories, maps; the lock of a result directory."""

from __future__ import annotations

import fcntl
import json
import math
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from radarslam.core.errors import InputError


def to_jsonable(obj: Any) -> Any:
    """numpy-aware conversion for ``json``; NaN and inf become ``null`` (JSON has neither)."""
    if isinstance(obj, dict):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [to_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return to_jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        x = float(obj)
        return x if math.isfinite(x) else None
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    return obj


def _file_mode() -> int:
    """The mode a plain ``open(path, "w")`` would give: 0666 less the process umask (0644 usually)."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, fsync, then rename over ``path``.

    The file gets the permissions of any file the user writes (``mkstemp`` alone would leave 0600).
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix="." + path.name + ".", suffix=".tmp")
    try:
        os.fchmod(fd, _file_mode())
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def write_json(path: str | Path, obj: Any) -> None:
    """Atomically write ``obj`` as indented JSON."""
    atomic_write_text(path, json.dumps(to_jsonable(obj), indent=2, allow_nan=False) + "\n")


def make_dir(out: str | Path, what: str = "--out") -> Path:
    """Create ``out`` with its missing parents (as ``mkdir -p``); refuse a path through a file."""
    out = Path(out)
    if out.exists():
        if not out.is_dir():
            raise InputError(f"{what}: expected a directory, got an existing file {out}")
        return out
    for parent in out.parents:
        if parent.exists():
            if not parent.is_dir():
                raise InputError(f"{what}: expected a directory path, but {parent} is a file")
            break
    try:
        out.mkdir(parents=True)
    except OSError as exc:
        raise InputError(f"{what}: cannot create {out} ({exc.strerror})") from None
    return out


def prepare_out_dir(out: str | Path) -> Path:
    """Create ``out`` and its missing parents if needed; refuse a file or an unwritable directory."""
    out = make_dir(out)
    if not os.access(out, os.W_OK | os.X_OK):
        raise InputError(f"--out: directory {out} is not writable")
    return out


def refuse_finished(marker: Path, what: str, overwrite: bool) -> None:
    """Refuse to write over a finished result (whose ``marker`` file exists) unless asked to."""
    if marker.exists() and not overwrite:
        raise InputError(f"{what}: {marker.parent} already holds a finished result ({marker.name}); pass --overwrite "
                         "to replace it, or choose another directory")


class DirectoryLock:
    """``with DirectoryLock(root):`` holds an exclusive ``flock`` on ``root/.lock`` (released on exit,
    and by the kernel if the process dies)."""

    def __init__(self, root: Path):
        self.path = Path(root) / ".lock"
        self.fd: int | None = None

    def __enter__(self) -> "DirectoryLock":
        self.fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(self.fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(self.fd)
            self.fd = None
            raise InputError(f"--out: {self.path.parent} is in use by another run (lock {self.path}); wait for it "
                             "to finish or use another directory") from None
        return self

    def __exit__(self, *exc) -> None:
        if self.fd is not None:
            fcntl.flock(self.fd, fcntl.LOCK_UN)
            os.close(self.fd)
            self.fd = None


#: ``trajectory.csv``'s pose covariance columns: the upper triangle of the 3 x 3 covariance of
#: ``x, y, theta`` row by row (docs/recordings.md "Commands", the table of trajectory.csv).
POSE_COV_COLUMNS = ("var_x_m2", "cov_xy_m2", "cov_x_theta_m_rad", "var_y_m2", "cov_y_theta_m_rad", "var_theta_rad2")


def write_trajectory_csv(path: str | Path, t: np.ndarray, estimated: np.ndarray, true: np.ndarray | None = None,
                         covs: np.ndarray | None = None) -> None:
    """CSV with columns ``k,t,x,y,theta`` (+ ``x_true,y_true,theta_true``) (+ :data:`POSE_COV_COLUMNS`
    of ``covs`` (K, 3, 3), the estimate's covariance)."""
    cols = ["k", "t", "x", "y", "theta"] + (["x_true", "y_true", "theta_true"] if true is not None else [])
    if covs is not None:
        covs = np.asarray(covs, dtype=float)
        if covs.shape != (estimated.shape[0], 3, 3):
            raise InputError(f"covs: expected shape ({estimated.shape[0]}, 3, 3), one per pose, got {covs.shape}")
        cols += list(POSE_COV_COLUMNS)
        upper = covs[:, [0, 0, 0, 1, 1, 2], [0, 1, 2, 1, 2, 2]]
    rows = [",".join(cols)]
    for i in range(estimated.shape[0]):
        vals = [str(i + 1), repr(float(t[i]))] + [repr(float(v)) for v in estimated[i]]
        if true is not None:
            vals += [repr(float(v)) for v in true[i]]
        if covs is not None:
            vals += [repr(float(v)) for v in upper[i]]
        rows.append(",".join(vals))
    atomic_write_text(path, "\n".join(rows) + "\n")


def write_bias_csv(path: str | Path, t: np.ndarray, values: np.ndarray, stds: np.ndarray, names) -> None:
    """CSV of the odometry-bias states over a run (docs/method.md c.11): columns ``k,t`` then
    ``NAME,NAME_std`` for each state of ``names``; ``values`` and ``stds`` are ``(K, m)``."""
    cols = ["k", "t"] + [c for n in names for c in (n, f"{n}_std")]
    rows = [",".join(cols)]
    for i in range(values.shape[0]):
        vals = [str(i + 1), repr(float(t[i]))]
        for v, s in zip(values[i], stds[i]):
            vals += [repr(float(v)), repr(float(s))]
        rows.append(",".join(vals))
    atomic_write_text(path, "\n".join(rows) + "\n")


def write_tum(path: str | Path, t: np.ndarray, poses: np.ndarray) -> None:
    """TUM trajectory format (``t x y z qx qy qz qw``) for ``evo``: planar pose, yaw quaternion."""
    lines = []
    for ti, (x, y, th) in zip(t, poses):
        lines.append(f"{ti:.6f} {x:.6f} {y:.6f} 0.0 0.0 0.0 {math.sin(th / 2):.9f} {math.cos(th / 2):.9f}")
    atomic_write_text(path, "\n".join(lines) + "\n")
