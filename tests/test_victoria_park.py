"""The Victoria Park loader on the real files, its conventions, and damaged copies of the files.

The data live outside the repository (``../shared/data/victoria_park``). Without them these tests
skip locally but FAIL under CI (``CI`` set), where the directory is part of the environment.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from radarslam.core.errors import DataError, InputError
from radarslam.core.types import Odometry, Scan
from radarslam.io.datasets import get_dataset, list_datasets, register_dataset
from radarslam.io.datasets import victoria_park as vp
from radarslam.models.ackermann import AckermannModel

FILES = [vp.FILE_NPZ, vp.FILE_ZIP, vp.FILE_DR, vp.FILE_GPS, vp.FILE_TREES, vp.FILE_TLSR]

# Numbers documented in SOURCE.md.
N_SCANS, T_FIRST, T_LAST = 7230, 0.852, 1545.182
N_GPS, T_GPS_FIRST, T_GPS_LAST = 4466, (20967 - 20967) / 1000, (1570193 - 20967) / 1000
T_DR_FIRST, T_DR_LAST = (21940 - 20967) / 1000, (1570540 - 20967) / 1000


@pytest.fixture(scope="module")
def data_dir(victoria_park_dir) -> Path:
    return victoria_park_dir


@pytest.fixture(scope="module")
def full(data_dir):
    return vp.load_victoria_park(data_dir)


def _odometry(d):
    return [e for e in d.events if isinstance(e, Odometry)]


def _scan_positions(d) -> list[int]:
    """Positions of the scans in ``d.events`` (by type: events hold arrays, so no ``list.index``)."""
    return [i for i, e in enumerate(d.events) if isinstance(e, Scan)]


# --------------------------------------------------------------------------------------------
# Registry
# --------------------------------------------------------------------------------------------
def test_registry(monkeypatch):
    assert "victoria-park" in list_datasets()
    assert get_dataset("victoria-park") is vp.load_victoria_park
    with pytest.raises(InputError, match="victoria-park"):
        get_dataset("no-such-set")
    import radarslam.io.datasets as ds

    monkeypatch.setattr(ds, "_DATASETS", ds._DATASETS.copy())   # leave the real registry alone
    register_dataset("toy", lambda path: path)
    assert get_dataset("toy")("p") == "p" and "toy" in list_datasets()
    register_dataset("lazy", "radarslam.io.datasets.victoria_park:load_victoria_park")
    assert get_dataset("lazy") is vp.load_victoria_park
    for bad in [("", len), ("x", 3), ("x", "no-colon")]:
        with pytest.raises(InputError):
            register_dataset(*bad)


def test_package_import_is_light():
    code = ("import sys, radarslam.io.datasets as d; d.list_datasets(); "
            "assert 'matplotlib' not in sys.modules and 'scipy' not in sys.modules, sorted(sys.modules)")
    subprocess.run([sys.executable, "-c", code], check=True)


# --------------------------------------------------------------------------------------------
# The full load
# --------------------------------------------------------------------------------------------
def test_scan_count_and_times(full):
    scans = full.scans
    assert len(scans) == N_SCANS
    assert scans[0].t == T_FIRST and scans[-1].t == T_LAST
    assert [s.index for s in scans] == list(range(N_SCANS))
    assert np.array_equal(full.laser_times, [s.t for s in scans])
    # Scan period: the LMS runs at ~4.7 Hz here (213-215 ms).
    assert np.all(np.abs(np.diff(full.laser_times) - 0.214) <= 0.0011)


def test_events_are_time_ordered_with_odometry_first(full):
    t = np.array([e.t for e in full.events])
    assert np.all(np.diff(t) >= 0)
    kinds = [isinstance(e, Scan) for e in full.events]
    assert kinds[0] and kinds[-1]                      # the stream starts and ends with a scan
    for i, e in enumerate(full.events[1:-1], start=1):
        if isinstance(e, Scan):
            prev, nxt = full.events[i - 1], full.events[i + 1]
            assert prev.t <= e.t and nxt.t > e.t


def test_dead_reckoning_time_base(full, data_dir):
    odo = _odometry(full)
    # 61,945 DR samples, every 25 ms from 0.973 s; those in (0.852, 1545.182] with a predecessor.
    assert len(odo) == 61_768
    assert odo[0].t == pytest.approx(T_DR_FIRST + 0.025, abs=1e-9) and odo[-1].t == pytest.approx(1545.173, abs=1e-9)
    assert np.allclose([o.dt for o in odo], 0.025, atol=1e-9)
    assert full.odometry.t[0] > T_DR_FIRST and full.odometry.t[-1] < T_DR_LAST
    # The ASCII DRS.txt is on the ASCII time base by construction: every event time must be one of
    # its time stamps, with the same speed (SOURCE.md: within 0.0005).
    with zipfile.ZipFile(data_dir / vp.FILE_ZIP) as zf:
        drs = np.array(zf.read("DRS.txt").split(), dtype=float).reshape(-1, 3)
    t = np.array([o.t for o in odo])
    inside = t <= drs[-1, 0]
    j = np.searchsorted(drs[:, 0], t[inside])
    assert np.max(np.abs(drs[j, 0] - t[inside])) < 1e-9
    assert np.max(np.abs(drs[j, 1] - np.array([o.control[0] for o in odo])[inside])) <= 5e-4 + 1e-12


def test_gps(full, data_dir):
    g = full.gps
    assert g.t.size == N_GPS and g.t[0] == T_GPS_FIRST and g.t[-1] == pytest.approx(T_GPS_LAST, abs=1e-9)
    assert np.all(np.diff(g.t) > 0)
    # GPS.txt (ASCII time base) holds 948 of the fixes as (t, La - La0, Lo - Lo0): x is Lo, y is La.
    with zipfile.ZipFile(data_dir / vp.FILE_ZIP) as zf:
        gtxt = np.array(zf.read("GPS.txt").split(), dtype=float).reshape(-1, 3)
    j = np.searchsorted(g.t, gtxt[:, 0])
    assert np.max(np.abs(g.t[j] - gtxt[:, 0])) < 1e-9
    assert np.max(np.abs(g.y[j] - g.y[0] - gtxt[:, 1])) < 0.006
    assert np.max(np.abs(g.x[j] - g.x[0] - gtxt[:, 2])) < 0.006


def test_detections(full, data_dir):
    with np.load(data_dir / vp.FILE_NPZ) as z:
        cm = z["LASER"]
    r = cm / 100.0
    expected = (r >= 1.0) & (r < 30.0)
    polar = np.vstack([s.polar for s in full.scans])
    assert polar.shape == (int(expected.sum()), 2) == (314_459, 2)
    assert polar[:, 0].min() >= 1.0 and polar[:, 0].max() < 30.0
    # Bearing = k * 0.5 deg - 90 deg: beam 0 right (-pi/2), beam 180 ahead (0), beam 360 left (pi/2).
    k = np.rint((polar[:, 1] + math.pi / 2) / math.radians(0.5)).astype(int)
    assert np.allclose(polar[:, 1], np.radians(0.5 * k) - math.pi / 2, atol=1e-12)
    assert k.min() >= 0 and k.max() <= 360
    s = full.scans[1234]
    ks = np.nonzero((r[1234] >= 1.0) & (r[1234] < 30.0))[0]
    assert np.allclose(s.polar[:, 0], r[1234, ks]) and np.allclose(s.polar[:, 1], np.radians(0.5 * ks) - math.pi / 2)
    # The car's own body: beams 0-11 read 0.82-0.95 m in every scan; min_range removes it.
    assert np.all((r[:, :12] > 0.8) & (r[:, :12] < 1.0))
    # No return: 83% of the beams are >= 80 m.
    assert 0.82 < np.mean(r >= 80.0) < 0.84


def test_trees(full):
    tr = full.trees
    assert tr.ranges.shape == tr.bearings.shape == tr.diameters.shape == (7248, 18)
    valid = tr.valid
    assert valid.sum() == 52_946
    d = tr.diameters[valid]
    assert np.mean((d >= 0.1) & (d <= 1.0)) > 0.95           # 96.5%
    assert 0.35 < np.median(d) < 0.5                        # 0.42 m
    b = tr.bearings[valid]
    assert b.min() >= -math.pi / 2 and b.max() <= math.pi / 2
    assert np.array_equal(tr.index, np.arange(7248))
    assert np.array_equal(tr.t[:N_SCANS], full.laser_times)
    try:
        import h5py  # noqa: F401
    except ImportError:
        assert np.all(np.isnan(tr.t[N_SCANS:]))
    else:
        assert tr.t[N_SCANS] == 1545.395 and tr.t[-1] == 1549.027
    assert tr.row(0).shape == (int(valid[0].sum()), 3)


def test_tree_rows_are_the_laser_scans(full):
    """Each ACFR detection (trunk centre) lies d/2 behind a raw beam of the same row, not of a neighbour."""
    r = full.ranges_cm / 100.0
    tr = full.trees
    for offset, lo, hi in [(0, 0.99, 1.0), (1, 0.0, 0.2), (-1, 0.0, 0.2)]:
        hits = []
        for i in range(100, 7000, 7):
            j = i + offset
            for rng, brg, dia in tr.row(i):
                k = int(round((brg + math.pi / 2) / math.radians(0.5)))
                near = r[j, max(k - 1, 0):k + 2]
                hits.append(np.min(np.abs(near - (rng - dia / 2))) < 0.1)
        assert lo <= np.mean(hits) <= hi, offset


def _dead_reckoning(d, model=None):
    """Integrate the odometry events; the pose at every event time (t, x, y, phi_unwrapped)."""
    m = model or AckermannModel(**d.vehicle)
    pose = np.zeros(3)
    out = [(d.events[0].t, 0.0, 0.0, 0.0)]
    turns = 0.0
    for e in d.events:
        if isinstance(e, Odometry):
            nxt = m.step(pose, e.control, e.dt)
            turns += (nxt[2] - pose[2] + math.pi) % (2 * math.pi) - math.pi
            pose = nxt
            out.append((e.t, pose[0], pose[1], turns))
    return np.array(out)


def test_bearing_sign_by_consecutive_scans(data_dir):
    """Trees of consecutive scans, placed by dead reckoning, coincide only with CCW bearings."""
    d = vp.load_victoria_park(data_dir, n_scans=3000)
    dr = _dead_reckoning(d)
    tr = d.trees
    x, y, phi = (np.interp(tr.t, dr[:, 0], dr[:, c]) for c in (1, 2, 3))

    def world(i, sign):
        ok = tr.valid[i] & (tr.ranges[i] < 20.0)
        rng, a = tr.ranges[i, ok], phi[i] + sign * tr.bearings[i, ok]
        return np.column_stack([x[i] + rng * np.cos(a), y[i] + rng * np.sin(a)])

    med = {}
    for sign in (1, -1):
        dist = []
        for i in range(len(tr.index) - 1):
            p, q = world(i, sign), world(i + 1, sign)
            if len(p) and len(q):
                dist.extend(np.min(np.linalg.norm(p[:, None] - q[None], axis=2), axis=1))
        med[sign] = np.median(dist)
    assert med[1] < 0.1 and med[-1] > 0.25, med             # measured 0.07 m vs 0.51 m


def _fit_rmse(A, B, reflect):
    """RMS residual of the least-squares rotation (or reflection) + translation taking A to B."""
    a, b = A - A.mean(0), B - B.mean(0)
    U, _, Vt = np.linalg.svd(a.T @ b)
    D = np.diag([1.0, -1.0 if (np.linalg.det(Vt.T @ U.T) > 0) == reflect else 1.0])
    R = Vt.T @ D @ U.T
    return float(np.sqrt(np.mean(np.sum((a @ R.T - b) ** 2, axis=1))))


def test_gps_frame_is_right_handed_with_left_positive_steering(full):
    """Dead reckoning (alpha > 0 turns left) fits GPS (x = Lo, y = La) by a rotation, not a mirror."""
    dr = _dead_reckoning(full)
    g = full.gps
    sel = (g.t > dr[0, 0]) & (g.t < 120.0)                  # 2 minutes: before the DR drift dominates
    A = np.column_stack([np.interp(g.t[sel], dr[:, 0], dr[:, 1]), np.interp(g.t[sel], dr[:, 0], dr[:, 2])])
    proper, mirror = _fit_rmse(A, g.xy[sel], False), _fit_rmse(A, g.xy[sel], True)
    assert proper < 3.0 and mirror > 10.0, (proper, mirror)  # measured 1.5 m vs 14.5 m


# --------------------------------------------------------------------------------------------
# Windows, sources, speed
# --------------------------------------------------------------------------------------------
def _same_events(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert type(x) is type(y) and x.t == y.t
        if isinstance(x, Scan):
            assert x.index == y.index and np.array_equal(x.polar, y.polar)
        else:
            assert x.dt == y.dt and np.array_equal(x.control, y.control)


@pytest.mark.parametrize("first,n", [(None, 500), (3000, 200), (7229, 1)])
def test_window_is_a_slice_of_the_full_load(full, data_dir, first, n):
    w = vp.load_victoria_park(data_dir, first_scan=first, n_scans=n)
    s0 = first or 0
    pos = _scan_positions(full)
    _same_events(w.events, full.events[pos[s0]:pos[s0 + n - 1] + 1])
    assert isinstance(w.events[0], Scan) and w.events[0].index == s0
    assert np.array_equal(w.laser_times, full.laser_times[s0:s0 + n])
    g = (full.gps.t >= w.laser_times[0]) & (full.gps.t <= w.laser_times[-1])
    assert np.array_equal(w.gps.t, full.gps.t[g]) and np.array_equal(w.gps.x, full.gps.x[g])
    assert np.array_equal(w.trees.index, np.arange(s0, s0 + n))
    assert np.array_equal(w.trees.diameters, full.trees.diameters[s0:s0 + n], equal_nan=True)
    if first is None:
        assert len(w.scans) == 500 and w.laser_times[-1] == pytest.approx(107.453)


def test_zip_fallback_equals_npz(full, data_dir, tmp_path):
    z = vp.load_victoria_park(data_dir, laser_source="zip")
    _same_events(z.events, full.events)
    for f in (vp.FILE_ZIP, vp.FILE_DR, vp.FILE_GPS, vp.FILE_TREES):   # no npz: "auto" takes the zip
        os.symlink(data_dir / f, tmp_path / f)
    auto = vp.load_victoria_park(tmp_path, n_scans=50)
    assert auto.options["laser_source"] == vp.FILE_ZIP
    _same_events(auto.events, full.events[:_scan_positions(full)[49] + 1])


def test_options_and_noise(full, data_dir):
    assert full.options["max_range"] == 30.0 and full.options["min_range"] == 1.0
    assert full.noise.range_std == 0.05 and full.noise.bearing_std == pytest.approx(math.radians(0.5))
    assert full.vehicle == {"L": 2.83, "H": 0.76, "a": 0.95, "b": 0.5}
    near = vp.load_victoria_park(data_dir, n_scans=100, max_range=10.0, trees=False)
    assert near.trees is None
    assert max(s.polar[:, 0].max(initial=0) for s in near.scans) < 10.0
    for kw in [dict(n_scans=0), dict(first_scan=N_SCANS), dict(first_scan=-1), dict(first_scan=7000, n_scans=231),
               dict(max_range=100.0), dict(max_range=0.5), dict(laser_source="txt"), dict(n_scans=1.5)]:
        with pytest.raises(InputError):
            vp.load_victoria_park(data_dir, **kw)


# --------------------------------------------------------------------------------------------
# Damaged copies
# --------------------------------------------------------------------------------------------
@pytest.fixture
def copy_dir(data_dir, tmp_path) -> Path:
    out = tmp_path / "vp"
    out.mkdir()
    for f in FILES:
        if (data_dir / f).exists():
            shutil.copyfile(data_dir / f, out / f)
    return out


def _truncate(path: Path, frac: float = 0.5) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * frac)])


def _savemat(path: Path, **arrays) -> None:
    import scipy.io

    scipy.io.savemat(path, arrays)


def _mat(path: Path) -> dict:
    import scipy.io

    with open(path, "rb") as fh:
        return {k: v for k, v in scipy.io.loadmat(fh).items() if not k.startswith("__")}


def _raises(root: Path, fname: str, what: str, **kw):
    with pytest.raises(DataError, match=re.escape(fname)) as exc:
        vp.load_victoria_park(root, **kw)
    assert re.search(what, str(exc.value)), str(exc.value)


@pytest.mark.parametrize("fname", [vp.FILE_NPZ, vp.FILE_DR, vp.FILE_GPS, vp.FILE_TREES])
@pytest.mark.parametrize("frac", [0.5, 0.999])
def test_truncated_file(copy_dir, fname, frac):
    _truncate(copy_dir / fname, frac)
    _raises(copy_dir, fname, "truncated or corrupt")


def test_truncated_zip(copy_dir):
    (copy_dir / vp.FILE_NPZ).unlink()
    _truncate(copy_dir / vp.FILE_ZIP, 0.9)
    _raises(copy_dir, vp.FILE_ZIP, "truncated or corrupt")


def test_corrupt_zip_member(copy_dir):
    (copy_dir / vp.FILE_NPZ).unlink()
    with zipfile.ZipFile(copy_dir / vp.FILE_ZIP, "w") as zf:
        zf.writestr("LASER.txt", "0.5\t1.0\t2.0\n")          # one short record
    _raises(copy_dir, vp.FILE_ZIP, r"records of 362 numbers")
    with zipfile.ZipFile(copy_dir / vp.FILE_ZIP, "w") as zf:
        zf.writestr("DRS.txt", "")
    _raises(copy_dir, vp.FILE_ZIP, r"missing member 'LASER.txt'")


@pytest.mark.parametrize("fname", [vp.FILE_DR, vp.FILE_GPS, vp.FILE_TREES])
def test_missing_file(copy_dir, fname):
    (copy_dir / fname).unlink()
    _raises(copy_dir, fname, "file not found")


def test_missing_laser_and_directory(copy_dir, data_dir, tmp_path):
    (copy_dir / vp.FILE_NPZ).unlink()
    (copy_dir / vp.FILE_ZIP).unlink()
    _raises(copy_dir, vp.FILE_NPZ, re.escape(vp.FILE_ZIP))
    _raises(tmp_path / "nowhere", "nowhere", "directory not found")
    # trees=False does not need lidar_measurements.mat
    (copy_dir / vp.FILE_TREES).unlink()
    shutil.copyfile(data_dir / vp.FILE_NPZ, copy_dir / vp.FILE_NPZ)
    assert vp.load_victoria_park(copy_dir, n_scans=5, trees=False).trees is None


def test_wrong_variable(copy_dir):
    m = _mat(copy_dir / vp.FILE_DR)
    m["velocity"] = m.pop("speed")
    _savemat(copy_dir / vp.FILE_DR, **m)
    _raises(copy_dir, vp.FILE_DR, r"missing variable\(s\) \['speed'\]")


def test_wrong_shapes_and_values(copy_dir):
    dr, gps = copy_dir / vp.FILE_DR, copy_dir / vp.FILE_GPS
    m0, g0 = _mat(dr), _mat(gps)

    g = dict(g0, La_m=g0["La_m"][:-1])
    _savemat(gps, **g)
    _raises(copy_dir, vp.FILE_GPS, r"'La_m': expected 4466 values")
    _savemat(gps, **g0)

    m = dict(m0, speed=m0["speed"].copy())
    m["speed"][100] = np.nan
    _savemat(dr, **m)
    _raises(copy_dir, vp.FILE_DR, r"'speed': expected finite values, got nan at index \(100,\)")

    m = dict(m0, time=m0["time"].copy())
    m["time"][[10, 11]] = m["time"][[11, 10]]
    _savemat(dr, **m)
    _raises(copy_dir, vp.FILE_DR, r"'time': expected strictly increasing times")

    _savemat(dr, **dict(m0, time=m0["time"] / 1000.0))       # seconds, not ms: wrong time base
    _raises(copy_dir, vp.FILE_DR, r"does not overlap")

    _savemat(dr, **dict(m0, steering=np.degrees(m0["steering"])))
    _raises(copy_dir, vp.FILE_DR, r"'steering': expected radians")

    _savemat(dr, **dict(m0, speed=np.zeros((3, 3))))
    _raises(copy_dir, vp.FILE_DR, r"'speed': expected a numeric vector")


def test_bad_laser_npz(copy_dir, data_dir):
    with np.load(data_dir / vp.FILE_NPZ) as z:
        laser, t = z["LASER"], z["TLsr"]
    npz = copy_dir / vp.FILE_NPZ
    np.savez_compressed(npz, LASER=laser[:, :360], TLsr=t)
    _raises(copy_dir, vp.FILE_NPZ, r"'LASER': expected integer cm of shape \(N, 361\)")
    np.savez_compressed(npz, LASER=laser, TLsr=t[:-1])
    _raises(copy_dir, vp.FILE_NPZ, r"'TLsr': expected \(7230,\) times")
    np.savez_compressed(npz, LASER=laser)
    _raises(copy_dir, vp.FILE_NPZ, r"missing array\(s\) \['TLsr'\]")
    t2 = t.copy()
    t2[5] = t2[4]
    np.savez_compressed(npz, LASER=laser, TLsr=t2)
    _raises(copy_dir, vp.FILE_NPZ, r"strictly increasing")


def test_bad_trees(copy_dir):
    path = copy_dir / vp.FILE_TREES
    m0 = _mat(path)
    _savemat(path, **dict(m0, lidar_signatures=m0["lidar_signatures"][:, :17]))
    _raises(copy_dir, vp.FILE_TREES, r"'lidar_signatures': expected a numeric 2-D array")
    _savemat(path, **dict(m0, lidar_bearings=m0["lidar_bearings"] * 2.0))
    _raises(copy_dir, vp.FILE_TREES, r"expected radians in \[0, pi\]")


@pytest.mark.parametrize("cut", ["end", "start"])
def test_odometry_that_does_not_cover_the_scans_is_refused(copy_dir, cut):
    """Dead reckoning that ends 100 s before the last scan (or starts 100 s after the first) would
    leave scans without motion: refused, naming the file and both spans."""
    dr = copy_dir / vp.FILE_DR
    m = _mat(dr)
    t = m["time"].ravel()
    keep = t < t[-1] - 100_000 if cut == "end" else t > t[0] + 100_000      # ms
    _savemat(dr, **{k: v.ravel()[keep] if v.size == t.size else v for k, v in m.items()})
    _raises(copy_dir, vp.FILE_DR, r"expected odometry over the whole laser span")


# ------------------------------------------------------------------ the tree-detection input mode
def test_tree_input_mode_scans_are_acfr_detections(data_dir, full):
    """--input trees: one scan per row of lidar_measurements.mat, its detections the tree centres
    in range, on the same times and bearing convention as the tree table of the laser mode."""
    t = vp.load_victoria_park(data_dir, input="trees", max_range=80.0)
    scans = t.scans
    have_h5 = t.options["times"] == vp.FILE_TLSR
    assert len(scans) == (7248 if have_h5 else N_SCANS)
    assert t.ranges_cm.shape == (len(scans), 0) and t.trees is not None
    assert sum(s.polar.shape[0] for s in scans) == (52_946 if have_h5 else int(full.trees.valid[:N_SCANS].sum()))
    for i in (0, 1234, len(scans) - 1):
        assert scans[i].index == i and scans[i].t == pytest.approx(full.trees.t[i])
        np.testing.assert_array_equal(scans[i].polar, full.trees.row(i)[:, :2])
    # the odometry covers the tree times and precedes each scan, as in the laser mode
    assert all(isinstance(e, (Odometry, Scan)) for e in t.events)
    times = [e.t for e in t.events]
    assert times == sorted(times)


def test_tree_input_mode_range_window_and_bad_input(data_dir, full):
    w = vp.load_victoria_park(data_dir, input="trees", first_scan=100, n_scans=50, max_range=20.0)
    assert [s.index for s in w.scans] == list(range(100, 150))
    for s in w.scans:
        ref = full.trees.row(s.index)
        ref = ref[(ref[:, 0] >= 1.0) & (ref[:, 0] < 20.0)]
        np.testing.assert_array_equal(s.polar, ref[:, :2])
    with pytest.raises(InputError, match=r"^input: expected one of \['laser', 'trees'\], got 'radar'$"):
        vp.load_victoria_park(data_dir, input="radar")
