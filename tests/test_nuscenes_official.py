"""nuScenes read in its official layout (``radarslam.io.datasets.nuscenes``, docs/datasets.md
"nuScenes and RadarScenes in their official layouts").

Real bytes of the dataset (``../shared/data/nuscenes_official``, its SOURCE.md: three radar PCDs,
the v1.0-mini tables, scene-0061's CAN bus meta, vehicle_monitor and pose), and scene-0061 rebuilt
in the official layout, in a temporary folder, from its plain conversion
(``../shared/data/nuscenes_radar/scene-0061``) with the real tables and CAN bus files beside it:
read back, it is the plain conversion's event stream. The data's licence (CC BY-NC-SA 4.0) keeps
every file out of the repository: the tests read them where they are and write only to tmp.
"""

from __future__ import annotations

import hashlib
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from helpers import one_line_message, shared_data
from radarslam.core.errors import DataError, InputError, RadarSlamError
from radarslam.core.mounting import Mounting
from radarslam.core.types import Odometry, Scan
from radarslam.io.datasets.nuscenes import RADAR_CHANNELS, read_nuscenes
from radarslam.io.datasets.nuscenes import can_bus
from radarslam.io.datasets.nuscenes import tables as T
from radarslam.io.datasets.nuscenes.pcd import RADAR_FIELDS, radar_dtype, read_radar_pcd
from radarslam.io.recording.plain import read_plain
from radarslam.io.recording.stream import stream_events

SCENE = "scene-0061"
LOG = "n015-2018-07-24-11-22-45+0800"
#: First point (x, y, z, dyn_prop, id, rcs, vx, vy) of each real sweep, as nuscenes_official/SOURCE.md states it.
FIRST_POINTS = {"RADAR_FRONT": (2.2, -2.5, 0, 3, 0, -4.5, 0, 0), "RADAR_BACK_RIGHT": (4.2, 5.1, 0, 2, 0, -2.5, 8.25, 0),
                "RADAR_BACK_LEFT": (10.0, -3.5, 0, 1, 0, -3.5, 7.0, -0.25)}
CHANNEL_OF = {sid: ch for ch, (sid, _) in RADAR_CHANNELS.items()}


def _official() -> Path:
    return shared_data() / "nuscenes_official"


def _header(n: int, fields=RADAR_FIELDS) -> bytes:
    return ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
            f"FIELDS {' '.join(f[0] for f in fields)}\nSIZE {' '.join(str(f[2]) for f in fields)}\n"
            f"TYPE {' '.join(f[1] for f in fields)}\nCOUNT {' '.join('1' for _ in fields)}\n"
            f"WIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA binary\n").encode("ascii")


def write_radar_pcd(path: Path, rng, az, dop, rcs) -> None:
    """A radar sweep in the real 18-field layout: ``x, y`` of ``(rng, az)``, the RAW relative velocity
    ``(vx, vy)`` whose line-of-sight part is ``dop``, ego-compensated fields that disagree with it
    (a negative control), states the devkit's default filters would drop for some clusters, and the
    real files' zero padding after the points (125 records' worth of bytes, then 3726 more)."""
    n = rng.size
    rec = np.zeros(n, dtype=radar_dtype())
    c, s = np.cos(az), np.sin(az)
    rec["x"], rec["y"], rec["rcs"] = rng * c, rng * s, rcs
    rec["vx"], rec["vy"] = dop * c, dop * s
    rec["vx_comp"], rec["vy_comp"] = dop * c + 3.0, dop * s - 2.0
    rec["dyn_prop"], rec["id"] = 1, np.arange(n)
    rec["invalid_state"] = np.resize([0, 9, 16], n)          # 9, 16: dropped by RadarPointCloud's defaults
    rec["ambig_state"] = np.resize([3, 3, 1], n)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(_header(n) + rec.tobytes() + bytes((125 - n) * 43 + 3726))


# --- (a) the real radar sweeps ---------------------------------------------------------------------------


@pytest.mark.parametrize("channel", sorted(FIRST_POINTS))
def test_the_real_sweeps_parse_with_their_padding_ignored(channel):
    path = next((_official() / "pcd").glob(f"*__{channel}__*.pcd"))
    cloud = read_radar_pcd(path)
    assert cloud.size == 125 and cloud.dtype.names == tuple(f[0] for f in RADAR_FIELDS)
    first = cloud[0]
    assert tuple(float(first[k]) for k in ("x", "y", "z", "dyn_prop", "id", "rcs", "vx", "vy")) == pytest.approx(
        FIRST_POINTS[channel], abs=1e-6)
    assert np.all(cloud["z"] == 0) and np.all(np.isfinite(cloud["x"]))
    raw = path.read_bytes()
    start = raw.index(b"DATA binary\n") + len(b"DATA binary\n")
    assert (start, len(raw) - start - 125 * 43) == (370, 3726)              # the padding is really there
    assert raw[start + 125 * 43:] == bytes(3726)


def test_a_pcd_of_another_layout_is_refused_naming_the_file(tmp_path):
    real = next((_official() / "pcd").glob("*__RADAR_FRONT__*.pcd")).read_bytes()
    lidar = tmp_path / "lidar.pcd"
    lidar.write_bytes(_header(2, (("x", "F", 4), ("y", "F", 4), ("z", "F", 4), ("intensity", "F", 4))) + bytes(32))
    with pytest.raises(DataError) as e:
        read_radar_pcd(lidar)
    one_line_message(e, str(lidar), "expected the nuScenes radar PCD layout", "got FIELDS x y z intensity")
    renamed = tmp_path / "renamed.pcd"                                      # one field's name changed
    renamed.write_bytes(real.replace(b" vx_comp ", b" vz "))
    with pytest.raises(DataError) as e:
        read_radar_pcd(renamed)
    one_line_message(e, str(renamed), "vy vz vy_comp")
    resized = tmp_path / "resized.pcd"                                      # one field's SIZE changed
    resized.write_bytes(real.replace(b"SIZE 4 4 4 1 2", b"SIZE 4 4 4 1 4"))
    with pytest.raises(DataError) as e:
        read_radar_pcd(resized)
    one_line_message(e, str(resized), "SIZE 4 4 4 1 4")


def test_a_truncated_or_ascii_sweep_is_refused_naming_the_file(tmp_path):
    real = next((_official() / "pcd").glob("*__RADAR_BACK_LEFT__*.pcd")).read_bytes()
    cut = tmp_path / "cut.pcd"
    cut.write_bytes(real[:370 + 100 * 43])
    with pytest.raises(DataError) as e:
        read_radar_pcd(cut)
    one_line_message(e, str(cut), "125 points of 43 bytes (5375 bytes)", "got 4300 bytes")
    ascii_ = tmp_path / "ascii.pcd"
    ascii_.write_bytes(real.replace(b"DATA binary", b"DATA ascii"))
    with pytest.raises(DataError) as e:
        read_radar_pcd(ascii_)
    one_line_message(e, str(ascii_), "DATA ascii")
    with pytest.raises(DataError) as e:
        read_radar_pcd(tmp_path / "absent.pcd")
    one_line_message(e, "absent.pcd")


def test_a_sweep_of_fewer_points_than_its_padding_reads_those_points(tmp_path):
    path = tmp_path / "s.pcd"
    write_radar_pcd(path, np.array([10.0, 20.0]), np.array([0.1, -0.4]), np.array([-3.0, 2.0]), np.array([5.0, -1.5]))
    assert path.stat().st_size == len(_header(2)) + 125 * 43 + 3726
    cloud = read_radar_pcd(path)
    assert cloud.size == 2 and list(cloud["id"]) == [0, 1]


# --- (b) the real v1.0-mini tables -------------------------------------------------------------------------


def test_the_real_tables_hold_scene_0061_with_its_39_samples():
    folder = _official() / "v1.0-mini"
    scenes = T.load_table(folder, "scene")
    assert len(scenes) == 10
    scene = T.find_scene(scenes, SCENE, folder)
    assert scene["token"] == "cc8c0bf57f984915a77078b10eb33198" and scene["nbr_samples"] == 39
    samples = T.scene_samples(T.load_table(folder, "sample"), scene, folder)
    assert len(samples) == 39
    assert samples[0]["token"] == scene["first_sample_token"] and samples[-1]["token"] == scene["last_sample_token"]
    assert all(s["scene_token"] == scene["token"] for s in samples)
    ts = np.array([s["timestamp"] for s in samples])
    assert np.all(np.diff(ts) > 0) and 19.0 < (ts[-1] - ts[0]) / 1e6 < 19.5
    log = next(g for g in T.load_table(folder, "log") if g["token"] == scene["log_token"])
    assert (log["logfile"], log["location"]) == (LOG, "singapore-onenorth")
    with pytest.raises(InputError) as e:
        T.find_scene(scenes, "scene-9999", folder)
    msg = one_line_message(e, "--scene", "'scene-9999'", "scene-0061", "scene-1100")
    assert all(s["name"] in msg for s in scenes)


# --- (c) scene-0061 rebuilt in the official layout from its plain conversion -------------------------------


def _token(*parts) -> str:
    return hashlib.md5("/".join(map(str, parts)).encode()).hexdigest()


def _calibrations(folder: Path, plain_sensors) -> dict[str, dict]:
    """Per channel, a real calibrated_sensor record of the plain scene's mounting (its yaw printed to 6 decimals)."""
    channel = {s["token"]: s["channel"] for s in T.load_table(folder, "sensor")}
    out = {}
    for cs in T.load_table(folder, "calibrated_sensor"):
        ch = channel[cs["sensor_token"]]
        if ch in RADAR_CHANNELS and ch not in out:
            m = plain_sensors[RADAR_CHANNELS[ch][0]]
            w, _, _, z = cs["rotation"]
            if cs["translation"][:2] == [m.x, m.y] and round(2 * math.atan2(z, w), 6) == m.yaw:
                out[ch] = cs
    assert sorted(out) == sorted(RADAR_CHANNELS)
    return out


def _sample_data(plain, t0: int, samples: list[dict], cals: dict[str, dict]) -> tuple[list[dict], list[dict]]:
    """``sample_data`` and ``ego_pose`` records of every plain sweep (key frames: each sample's nearest
    sweep per channel), chained per radar by prev/next; each ego pose the plain truth at the sweep."""
    s_ts = np.array([s["timestamp"] for s in samples])
    sid = plain.channels["sensor_id"]
    yaw = np.unwrap(plain.truth[:, 2])
    records, poses = [], []
    for k in sorted(CHANNEL_OF):
        ch = CHANNEL_OF[k]
        ts = t0 + np.round(np.unique(plain.det_t[sid == k]) * 1e6).astype(np.int64)
        near = np.argmin(np.abs(ts[:, None] - s_ts[None, :]), axis=1)
        key = {int(np.argmin(np.abs(ts - s))) for s in s_ts}
        toks = [_token(ch, t) for t in ts.tolist()]
        for i, t in enumerate(ts.tolist()):
            folder = "samples" if i in key else "sweeps"
            records.append({"token": toks[i], "sample_token": samples[near[i]]["token"],
                            "ego_pose_token": _token("ego", ch, t), "calibrated_sensor_token": cals[ch]["token"],
                            "timestamp": t, "fileformat": "pcd",
                            "is_key_frame": i in key, "height": 0, "width": 0,
                            "filename": f"{folder}/{ch}/{LOG}__{ch}__{t}.pcd",
                            "prev": toks[i - 1] if i else "", "next": toks[i + 1] if i + 1 < len(toks) else ""})
            ts_s = (t - t0) / 1e6
            x, y, a = (float(np.interp(ts_s, plain.truth_t, v)) for v in (plain.truth[:, 0], plain.truth[:, 1], yaw))
            poses.append({"token": _token("ego", ch, t), "timestamp": t, "translation": [x, y, 0.0],
                          "rotation": [math.cos(a / 2), 0.0, 0.0, math.sin(a / 2)]})
    return records, poses


def _can_bus(can: Path, plain, t0: int) -> None:
    """zoe_veh_info and ms_imu written from the plain odometry (rear wheels RL, RR about its speed,
    front wheels off it; an IMU message before and after the wheels' span), the real meta,
    vehicle_monitor and pose files beside them."""
    can.mkdir()
    for msg in ("meta", "vehicle_monitor", "pose"):
        (can / f"{SCENE}_{msg}.json").symlink_to(_official() / "can_bus" / f"{SCENE}_{msg}.json")
    ut = t0 + np.round(plain.odo_t * 1e6).astype(np.int64)
    rpm = plain.odo[:, 0] / can_bus.RPM_TO_MPS
    wheels = [{"FL_wheel_speed": 1.2 * r, "FR_wheel_speed": 0.8 * r, "RL_wheel_speed": 1.01 * r,
               "RR_wheel_speed": 0.99 * r, "odom_speed": 0.0, "utime": u} for u, r in zip(ut.tolist(), rpm.tolist())]
    imu_t = [int(ut[0]) - 10_000, *ut.tolist(), int(ut[-1]) + 10_000]
    imu_w = [0.5, *plain.odo[:, 1].tolist(), -0.5]
    imu = [{"linear_accel": [0.0, 0.0, 9.81], "q": [1.0, 0.0, 0.0, 0.0], "rotation_rate": [0.01, -0.02, w], "utime": u}
           for u, w in zip(imu_t, imu_w)]
    (can / f"{SCENE}_zoe_veh_info.json").write_text(json.dumps(wheels))
    (can / f"{SCENE}_ms_imu.json").write_text(json.dumps(imu))


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """``(dataroot, plain Recording, t0_us)``: scene-0061 in the official layout in a temporary folder."""
    plain = read_plain(shared_data() / "nuscenes_radar" / SCENE)
    real = _official() / "v1.0-mini"
    pose = json.loads((_official() / "can_bus" / f"{SCENE}_pose.json").read_text())
    t0 = pose[0]["utime"] - round(plain.truth_t[0] * 1e6)           # the plain scene's time zero, from the real pose
    root = tmp_path_factory.mktemp("nuscenes")
    tables = root / "v1.0-mini"
    tables.mkdir()
    for name in ("scene", "sample", "sensor", "calibrated_sensor", "log"):
        (tables / f"{name}.json").symlink_to(real / f"{name}.json")
    sc = T.find_scene(T.load_table(real, "scene"), SCENE, real)
    samples = T.scene_samples(T.load_table(real, "sample"), sc, real)
    records, poses = _sample_data(plain, t0, samples, _calibrations(real, plain.sensors))
    (tables / "sample_data.json").write_text(json.dumps(records))
    (tables / "ego_pose.json").write_text(json.dumps(poses))
    sid = plain.channels["sensor_id"]
    for r in records:
        ch = r["filename"].split("/")[1]
        rows = (plain.det_t == (r["timestamp"] - t0) / 1e6) & (sid == RADAR_CHANNELS[ch][0])
        write_radar_pcd(root / r["filename"], plain.det_polar[rows, 0], plain.det_polar[rows, 1],
                        plain.channels["doppler_mps"][rows], plain.channels["rcs"][rows])
    _can_bus(root / "can_bus", plain, t0)
    return root, plain, t0


def test_the_rebuilt_scene_chains_from_the_first_samples_key_frames(scene):
    root, plain, t0 = scene
    records = json.loads((root / "v1.0-mini" / "sample_data.json").read_text())
    sc = T.find_scene(T.load_table(root / "v1.0-mini", "scene"), SCENE, root / "v1.0-mini")
    firsts = [r for r in records if r["prev"] == ""]
    assert len(firsts) == 5 and all(r["is_key_frame"] and r["sample_token"] == sc["first_sample_token"] for r in firsts)
    assert t0 == 1532402927635538 == min(r["timestamp"] for r in records)   # the first sweep: RADAR_BACK_RIGHT
    assert len(records) == 1263 and sum(r["is_key_frame"] for r in records) == 5 * 39


def test_the_official_layout_reads_to_the_plain_conversion(scene):
    root, plain, t0 = scene
    rec = read_nuscenes(root, SCENE)                                        # the one version folder: v1.0-mini
    assert rec.t0_ns == t0 * 1000 and rec.notes == [] and "v1.0-mini scene-0061" in rec.source
    # detections: the same times, sensors and order; the values to the PCD's float32
    np.testing.assert_array_equal(rec.det_t, plain.det_t)
    np.testing.assert_array_equal(rec.channels["sensor_id"], plain.channels["sensor_id"])
    assert rec.det_t.size == 126749 and np.bincount(rec.channels["sensor_id"].astype(int)).tolist() == [
        int(np.sum(plain.channels["sensor_id"] == k)) for k in range(5)]
    np.testing.assert_allclose(rec.det_polar[:, 0], plain.det_polar[:, 0], rtol=2e-7, atol=0)
    np.testing.assert_allclose(rec.det_polar[:, 1], plain.det_polar[:, 1], rtol=0, atol=3e-7)
    np.testing.assert_allclose(rec.channels["doppler_mps"], plain.channels["doppler_mps"], rtol=3e-7, atol=1e-7)
    np.testing.assert_array_equal(rec.channels["rcs"], plain.channels["rcs"])   # 0.5 dBsm steps: exact in float32
    # the raw (vx, vy), not the compensated fields written beside them (3, -2 m/s off)
    comp = plain.channels["doppler_mps"] + 3 * np.cos(plain.det_polar[:, 1]) - 2 * np.sin(plain.det_polar[:, 1])
    assert np.median(np.abs(rec.channels["doppler_mps"] - comp)) > 1.0
    # odometry: one row per IMU message within the wheels' span, the rear wheels' mean, the gyro's z
    np.testing.assert_array_equal(rec.odo_t, plain.odo_t)
    np.testing.assert_allclose(rec.odo, plain.odo, rtol=1e-12, atol=1e-15)
    assert rec.odo_kind == plain.odo_kind == "unicycle"
    # truth: the real 50 Hz CAN bus pose, which truth.csv printed to 4 (x, y) and 7 (yaw) decimals
    np.testing.assert_array_equal(rec.truth_t, plain.truth_t)
    assert np.max(np.abs(rec.truth[:, :2] - plain.truth[:, :2])) <= 5e-5 + 1e-9
    assert np.max(np.abs(rec.truth[:, 2] - plain.truth[:, 2])) <= 5e-8 + 1e-12
    # mountings: the real calibrated_sensor records, which sensors.csv printed to 4 (x, y) and 6 (yaw) decimals
    assert sorted(rec.sensors) == sorted(plain.sensors) == [0, 1, 2, 3, 4]
    for k, m in rec.sensors.items():
        p = plain.sensors[k]
        assert (m.x, m.y, m.sensor_id, m.name) == (p.x, p.y, p.sensor_id, p.name)
        assert abs(m.yaw - p.yaw) <= 5e-7


def _same_events(a: list, b: list) -> None:
    assert [type(e) for e in a] == [type(e) for e in b]
    for x, y in zip(a, b):
        assert x.t == y.t
        if isinstance(x, Odometry):
            assert x.dt == y.dt and x.gyro_rad_s == pytest.approx(y.gyro_rad_s, abs=1e-15)
            np.testing.assert_allclose(x.control, y.control, rtol=1e-12, atol=1e-15)
        else:
            assert isinstance(x, Scan) and x.index == y.index and x.polar.shape == y.polar.shape
            np.testing.assert_allclose(x.polar, y.polar, rtol=3e-7, atol=3e-7)
            assert x.channels.keys() == y.channels.keys()
            for c in x.channels:
                np.testing.assert_allclose(x.channels[c], y.channels[c], rtol=3e-7, atol=1e-7)
            assert (x.sensor.x, x.sensor.y, x.sensor.sensor_id) == (y.sensor.x, y.sensor.y, y.sensor.sensor_id)
            assert x.sensor.yaw == pytest.approx(y.sensor.yaw, abs=5e-7)


def test_the_event_stream_is_the_plain_conversions(scene):
    root, plain, _ = scene
    ev, report = stream_events(read_nuscenes(root, SCENE, version="v1.0-mini"), Mounting())
    ev_plain, report_plain = stream_events(plain, Mounting())
    assert (report.scans, report.detections, report.dropped_scans["count"]) == (
        report_plain.scans, report_plain.detections, report_plain.dropped_scans["count"])
    assert report.scans > 1200 and sum(isinstance(e, Odometry) for e in ev) > 1800
    _same_events(ev, ev_plain)


def test_without_the_can_bus_pose_the_truth_is_ego_pose_at_the_sweeps(scene, tmp_path):
    root, plain, _ = scene
    copy = tmp_path / "root"
    copy.mkdir()
    for p in root.iterdir():
        if p.name != "can_bus":
            (copy / p.name).symlink_to(p)
    (copy / "can_bus").mkdir()
    for p in (root / "can_bus").iterdir():
        if not p.name.endswith("_pose.json"):
            (copy / "can_bus" / p.name).symlink_to(p.resolve())
    rec = read_nuscenes(copy, SCENE)
    assert len(rec.notes) == 1 and "ego_pose.json" in rec.notes[0] and "\n" not in rec.notes[0]
    sweep_t = np.unique(plain.det_t)
    np.testing.assert_array_equal(rec.truth_t, sweep_t)
    for j in (0, 1):
        np.testing.assert_allclose(rec.truth[:, j], np.interp(sweep_t, plain.truth_t, plain.truth[:, j]), atol=1e-9)


def test_the_real_can_bus_meta_agrees_with_the_odometry_rule(scene):
    """scene-0061's real meta (message counts and utime spans of the IMU and the wheel messages)
    against its plain odometry.csv: one row per IMU message inside the wheels' span, on the time
    base of the first radar sweep."""
    _, plain, t0 = scene
    meta = json.loads((_official() / "can_bus" / f"{SCENE}_meta.json").read_text())
    imu, wheel = meta["MS_IMU"], meta["ZOE_VEH_INFO"]
    assert imu["var_stats"]["utime"]["min"] < wheel["var_stats"]["utime"]["min"] <= t0 + plain.odo_t[0] * 1e6
    assert imu["var_stats"]["utime"]["max"] <= wheel["var_stats"]["utime"]["max"]
    assert plain.odo_t.size == imu["message_count"] - 1 == 1898             # the first IMU message only is outside
    assert plain.odo_t[-1] == (imu["var_stats"]["utime"]["max"] - t0) / 1e6
    assert plain.truth_t.size == meta["POSE"]["message_count"] == 938


def test_odometry_interpolates_the_rear_wheels_at_the_imu_and_keeps_its_span(tmp_path):
    rpm = np.array([100.0, 200.0, 400.0])
    wheels = [{"RL_wheel_speed": r + 10, "RR_wheel_speed": r - 10, "FL_wheel_speed": 0.0, "FR_wheel_speed": 0.0,
               "utime": u} for r, u in zip(rpm, (1_000_000, 1_020_000, 1_030_000))]
    imu = [{"rotation_rate": [9.0, 9.0, w], "utime": u}
           for w, u in ((0.1, 995_000), (0.2, 1_005_000), (0.3, 1_025_000), (0.4, 1_030_000), (0.5, 1_031_000))]
    (tmp_path / "s_zoe_veh_info.json").write_text(json.dumps(wheels))
    (tmp_path / "s_ms_imu.json").write_text(json.dumps(imu))
    t, odo = can_bus.odometry(tmp_path, "s", 990_000)
    np.testing.assert_allclose(t, [0.015, 0.035, 0.040])                  # the IMU's times inside the wheels' span
    np.testing.assert_allclose(odo[:, 0], np.array([125.0, 300.0, 400.0]) * 2 * math.pi * 0.305 / 60, rtol=1e-14)
    np.testing.assert_array_equal(odo[:, 1], [0.2, 0.3, 0.4])
    imu[2]["utime"] = 1_005_000
    (tmp_path / "s_ms_imu.json").write_text(json.dumps(imu))
    with pytest.raises(DataError) as e:
        can_bus.odometry(tmp_path, "s", 0)
    one_line_message(e, "s_ms_imu.json message 2", "increasing utime")


# --- (d) refusals -------------------------------------------------------------------------------------------


def _tables_only(tmp_path: Path, can=True) -> Path:
    root = tmp_path / "root"
    (root / "v1.0-mini").mkdir(parents=True)
    for p in (_official() / "v1.0-mini").iterdir():
        (root / "v1.0-mini" / p.name).symlink_to(p)
    if can:
        (root / "can_bus").mkdir()
    return root


def test_a_dataroot_without_can_bus_is_refused_naming_it(tmp_path):
    root = _tables_only(tmp_path, can=False)
    with pytest.raises(DataError) as e:
        read_nuscenes(root, SCENE)
    one_line_message(e, str(root / "can_bus"), "CAN bus expansion", "no such folder")


def test_an_unknown_scene_is_refused_listing_the_scenes(tmp_path):
    with pytest.raises(InputError) as e:
        read_nuscenes(_tables_only(tmp_path), "scene-0062")
    one_line_message(e, "--scene", "'scene-0062'", "scene-0061, scene-0103, scene-0553")


def test_a_scene_without_radar_sweeps_is_refused_naming_the_file(tmp_path):
    root = _tables_only(tmp_path)
    (root / "v1.0-mini" / "sample_data.json").write_text("[]")
    with pytest.raises(DataError) as e:
        read_nuscenes(root, SCENE)
    one_line_message(e, str(root / "v1.0-mini" / "sample_data.json"), "radar sweeps", "got none")
    with pytest.raises(DataError) as e:
        read_nuscenes(root, SCENE, version="v1.0-trainval")
    one_line_message(e, "--version v1.0-trainval", "no such folder")


def test_a_missing_sweep_file_is_refused_naming_it(scene, tmp_path):
    root, _, _ = scene
    copy = tmp_path / "root"
    shutil.copytree(root, copy, symlinks=True)
    victim = sorted((copy / "sweeps" / "RADAR_FRONT_LEFT").iterdir())[7]
    victim.unlink()
    with pytest.raises(DataError) as e:
        read_nuscenes(copy, SCENE)
    one_line_message(e, str(victim))


# --- (f) the command line ---------------------------------------------------------------------------------


def _run(argv, capsys):
    from radarslam.cli.main import main

    code = main(argv)
    return code, capsys.readouterr().err.strip()


def test_the_cli_refuses_a_bad_dataroot_inone_line_message(tmp_path, capsys):
    out = tmp_path / "out"
    code, err = _run(["run", "--dataset", "nuscenes", str(tmp_path / "nope"), "--scene", SCENE, "--out", str(out)],
                     capsys)
    assert code == 1 and len(err.splitlines()) == 1 and str(tmp_path / "nope") in err and "no such directory" in err
    code, err = _run(["run", "--dataset", "nuscenes", str(_tables_only(tmp_path, can=False)), "--scene", SCENE,
                      "--out", str(out)], capsys)
    assert code == 1 and len(err.splitlines()) == 1 and "can_bus" in err
    code, err = _run(["run", "--dataset", "nuscenes", str(tmp_path), "--out", str(out)], capsys)
    assert code == 1 and err.endswith("--scene: expected with --dataset nuscenes (e.g. --scene scene-0061), got none")
    code, err = _run(["run", "--dataset", "victoria-park", str(tmp_path), "--scene", SCENE, "--out", str(out)], capsys)
    assert code == 1 and "--scene: expected with --dataset nuscenes DATAROOT, got --dataset victoria-park" in err
    code, err = _run(["run", "--dataset", "nuscene", str(tmp_path), "--out", str(out)], capsys)
    assert code == 1 and "['nuscenes', 'radarscenes', 'victoria-park']" in err
    assert not out.exists()


def test_the_cli_reads_the_scene_into_the_recording_run(scene, tmp_path, capsys, monkeypatch):
    """``--dataset nuscenes DATAROOT --scene`` reaches the recording run with the reader's Recording
    (stopped there: the filter is not run here)."""
    import radarslam.cli.recording as cli_recording

    root, plain, _ = scene
    seen = []
    real_read = cli_recording._read

    def read_and_stop(args, rig=None):
        seen.append(real_read(args, rig))
        raise RadarSlamError("stopped before the filter")

    monkeypatch.setattr(cli_recording, "_read", read_and_stop)
    code, err = _run(["run", "--dataset", "nuscenes", str(root), "--scene", SCENE, "--version", "v1.0-mini",
                      "--profile", "automotive", "--out", str(tmp_path / "out")], capsys)
    assert code == 1 and err.endswith("stopped before the filter") and len(seen) == 1
    np.testing.assert_array_equal(seen[0].det_t, plain.det_t)
    assert seen[0].sensors[3].name == "rear_left" and seen[0].source == read_nuscenes(root, SCENE).source
