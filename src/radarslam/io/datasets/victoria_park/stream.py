"""Loading the Victoria Park dataset as one event stream (:mod:`radarslam.io.datasets.victoria_park`):
the options, the time alignment of laser, dead reckoning and GPS, the window, the detections of
either input and the merged events.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radarslam.core.errors import DataError, InputError
from radarslam.core.types import Event, Odometry, Scan
from radarslam.io.datasets.victoria_park.files import (
    _increasing,
    _read_dead_reckoning,
    _read_gps,
    _read_laser,
    _read_tlsr_h5,
    _read_trees,
)
from radarslam.io.datasets.victoria_park.records import (
    BEAM_STEP,
    FILE_TLSR,
    FILE_TREES,
    INPUTS,
    N_BEAMS,
    NO_RETURN_M,
    NOISE,
    VEHICLE,
    DeadReckoning,
    GpsFixes,
    TreeDetections,
    VictoriaParkData,
)


def load_victoria_park(
    path: str | Path,
    *,
    max_range: float = 30.0,
    min_range: float = 1.0,
    first_scan: int | None = None,
    n_scans: int | None = None,
    laser_source: str = "auto",
    trees: bool = True,
    laser_time_offset: float = 0.0,
    input: str = "laser",
) -> VictoriaParkData:
    """Load the Victoria Park directory ``path`` as one validated event stream.

    Parameters
    ----------
    path : str or Path
        The dataset directory.
    max_range : float
        Beams at or beyond this range (m) are not detections; in ``(min_range, 80]``. 30 m: see the
        module docstring.
    min_range : float
        Beams shorter than this (m) are not detections (the vehicle's own body at 0.82-0.95 m).
    first_scan : int, optional
        0-based first scan of a window (default 0).
    n_scans : int, optional
        Number of scans in the window (default: to the end).
    laser_source : {"auto", "npz", "zip"}
        Where the scans come from; "auto" takes the npz if it exists, else the zip.
    trees : bool
        Load ACFR's tree detections (``lidar_measurements.mat`` is then required).
    laser_time_offset : float
        Seconds added to every laser (and tree) time before merging, for latency studies; 0 keeps
        the recorded time stamps.
    input : {"laser", "trees"}
        What a scan's detections are. ``"laser"``: every raw beam return in range (one trunk gives
        several). ``"trees"``: ACFR's tree detections of ``lidar_measurements.mat``, one
        ``[range, bearing]`` of the trunk centre per tree, as the published filters use; the scans are
        then the 7248 rows of that file, timed by the h5 time vector (needs h5py, ``radarslam[data]``;
        without it, the first 7230 rows on the ASCII laser times), ``ranges_cm`` is empty, ``trees``
        is forced on and ``laser_source`` only supplies times. ``min_range``/``max_range`` select the
        detections in both modes.

    Returns
    -------
    VictoriaParkData

    Raises
    ------
    DataError
        A file that is missing, unreadable (truncated, corrupt), or lacks an expected variable,
        shape, finite value or increasing time; the message names the file.
    InputError
        Bad options.
    """
    root = Path(path)
    if not root.is_dir():
        raise DataError(f"{root}: dataset directory not found" + (" (it is a file)" if root.exists() else ""))
    max_range, min_range, laser_time_offset = _check_options(max_range, min_range, laser_source, laser_time_offset)
    if input not in INPUTS:
        raise InputError(f"input: expected one of {list(INPUTS)}, got {input!r}")
    trees = trees or input == "trees"
    laser_file, ranges_cm, laser_t = _read_laser(root, laser_source)
    tree_arrays, all_laser_t = None, None
    if trees:
        tree_arrays = _read_trees(root / FILE_TREES)
        all_laser_t = _read_tlsr_h5(root / FILE_TLSR, laser_t)
    if input == "trees":
        laser_t, ranges_cm = _tree_scan_times(root, laser_file, tree_arrays, laser_t, all_laser_t)
    n_total = laser_t.size
    dr_t, speed, steering = _read_dead_reckoning(root, laser_file, laser_t)
    gps_t, gps_x, gps_y = _read_gps(root)

    windowed = first_scan is not None or n_scans is not None
    s0, s1 = _window(first_scan, n_scans, n_total)            # scans s0 .. s1 - 1
    laser_t = laser_t + laser_time_offset
    ranges_cm = ranges_cm[s0:s1]
    scan_t = laser_t[s0:s1]
    scan_index = np.arange(s0, s1)
    if input == "trees":
        polars = _tree_polars(tree_arrays, s0, s1, min_range, max_range)
    else:
        polars = _laser_polars(ranges_cm, min_range, max_range)
    odo, events = _merge_events(dr_t, speed, steering, scan_t, scan_index, polars)
    gps = _gps_fixes(gps_t, gps_x, gps_y, scan_t if windowed else None)
    tree_det = None
    if tree_arrays is not None:
        tree_det = _tree_window(tree_arrays, laser_t, all_laser_t, laser_time_offset, s0, s1 if n_scans is not None else None)
    options = {
        "path": str(root), "max_range": max_range, "min_range": min_range, "first_scan": s0,
        "n_scans": s1 - s0, "laser_source": laser_file.name, "trees": trees,
        "laser_time_offset": laser_time_offset, "input": input,
        "times": FILE_TLSR if (input == "trees" and all_laser_t is not None) else laser_file.name,
    }
    return VictoriaParkData(events=events, laser_times=scan_t, scan_index=scan_index, ranges_cm=ranges_cm,
                            odometry=odo, gps=gps, trees=tree_det, noise=NOISE, vehicle=dict(VEHICLE),
                            options=options)


def _gps_fixes(gps_t, gps_x, gps_y, scan_t) -> GpsFixes:
    """All fixes, or with the window's scan times ``scan_t`` those within their span."""
    if scan_t is None:
        return GpsFixes(gps_t, gps_x, gps_y)
    g = (gps_t >= scan_t[0]) & (gps_t <= scan_t[-1])
    return GpsFixes(gps_t[g], gps_x[g], gps_y[g])


def _tree_scan_times(root, laser_file, tree_arrays, laser_t, all_laser_t) -> tuple[np.ndarray, np.ndarray]:
    """``input = "trees"``: the scans are the tree rows, on the full time vector when it is readable.
    Returns their times and empty ``ranges_cm``."""
    n_rows = tree_arrays[0].shape[0]
    t_rows = all_laser_t if all_laser_t is not None else laser_t
    n_rows = min(n_rows, t_rows.size)
    laser_t = t_rows[:n_rows].copy()
    ranges_cm = np.zeros((n_rows, 0), dtype=np.uint16)
    _increasing(root / (FILE_TLSR if all_laser_t is not None else laser_file.name), "TLsr", laser_t)
    return laser_t, ranges_cm


def _tree_polars(tree_arrays, s0, s1, min_range, max_range) -> list[np.ndarray]:
    """Detections of ``input = "trees"``: one [range, bearing] per tree, bearing in the scans'
    convention, nearest first within a row as ACFR's detector orders them (its column order)."""
    rng, brg = tree_arrays[0][s0:s1], tree_arrays[1][s0:s1] - math.pi / 2
    keep = (rng > 0) & (rng >= min_range) & (rng < max_range)
    return [np.column_stack([rng[i, keep[i]], brg[i, keep[i]]]) for i in range(s1 - s0)]


def _laser_polars(ranges_cm, min_range, max_range) -> list[np.ndarray]:
    """Detections of ``input = "laser"``: range in [min_range, max_range), bearing = k * 0.5 deg - 90 deg."""
    r = ranges_cm.astype(np.float64) / 100.0
    keep = (r >= min_range) & (r < max_range)
    bearings = np.arange(N_BEAMS) * BEAM_STEP - math.pi / 2
    rows, cols = np.nonzero(keep)
    polar_all = np.column_stack([r[rows, cols], bearings[cols]])
    splits = np.searchsorted(rows, np.arange(1, ranges_cm.shape[0]))
    return np.split(polar_all, splits)


def _merge_events(dr_t, speed, steering, scan_t, scan_index, polars) -> tuple[DeadReckoning, list[Event]]:
    """The odometry of the scans' span and the one event stream (the module docstring's "Stream").

    Odometry: DR samples k >= 1 with t_first_scan < t_k <= t_last_scan; odometry j goes before the
    first scan with t_scan >= t_odo."""
    k = np.nonzero((dr_t > scan_t[0]) & (dr_t <= scan_t[-1]))[0]
    k = k[k >= 1]
    odo = DeadReckoning(dr_t[k], speed[k], steering[k])
    dts = dr_t[k] - dr_t[k - 1]
    controls = np.column_stack([speed[k], steering[k]])
    n = scan_t.size
    before = np.searchsorted(scan_t, odo.t, side="left")      # scan position each odometry precedes
    bounds = np.searchsorted(before, np.arange(n + 1), side="left")
    events: list[Event] = []
    t_list, dt_list = odo.t.tolist(), dts.tolist()
    for i in range(n):
        for j in range(bounds[i], bounds[i + 1]):
            events.append(Odometry(t_list[j], dt_list[j], controls[j]))
        events.append(Scan(float(scan_t[i]), int(scan_index[i]), polars[i]))
    return odo, events


def _check_options(max_range, min_range, laser_source, offset) -> tuple[float, float, float]:
    from radarslam.core.validation import as_scalar

    min_range = as_scalar("min_range", min_range, low=0.0)
    max_range = as_scalar("max_range", max_range, low=min_range, low_open=True, high=NO_RETURN_M)
    offset = as_scalar("laser_time_offset", offset, low=-1.0, high=1.0)
    if laser_source not in ("auto", "npz", "zip"):
        raise InputError(f"laser_source: expected one of ['auto', 'npz', 'zip'], got {laser_source!r}")
    return max_range, min_range, offset


def _window(first_scan: int | None, n_scans: int | None, n_total: int) -> tuple[int, int]:
    s0 = 0 if first_scan is None else first_scan
    if isinstance(s0, bool) or not isinstance(s0, (int, np.integer)) or not 0 <= s0 < n_total:
        raise InputError(f"first_scan: expected an integer in [0, {n_total - 1}], got {first_scan!r}")
    if n_scans is None:
        return int(s0), n_total
    if isinstance(n_scans, bool) or not isinstance(n_scans, (int, np.integer)) or not 1 <= n_scans <= n_total - s0:
        raise InputError(f"n_scans: expected an integer in [1, {n_total - s0}] for first_scan={s0}, got {n_scans!r}")
    return int(s0), int(s0 + n_scans)


def _tree_window(arrays, laser_t, all_laser_t, offset, s0, s1) -> TreeDetections:
    rng, brg, dia = arrays
    n_rows = rng.shape[0]
    stop = n_rows if s1 is None else min(s1, n_rows)
    idx = np.arange(min(s0, n_rows), stop)
    t = np.full(idx.size, np.nan)
    src = all_laser_t + offset if all_laser_t is not None else laser_t
    known = idx < src.size
    t[known] = src[idx[known]]
    pad = rng[idx] == 0
    conv = np.where(pad, np.nan, brg[idx] - math.pi / 2)     # same convention as the scans
    return TreeDetections(index=idx, t=t, ranges=np.where(pad, np.nan, rng[idx]), bearings=conv,
                          diameters=np.where(pad, np.nan, dia[idx]))
