"""SLAM from a 3-D radar and a gyro alone (docs/method.md c.10.6) -- the
attitude, the levelling and gating against a synthetic tilted platform with an upside-down radar,
ROS 2 radar_msgs/RadarScan, the Doppler field names, and the real TI bag end to end with its checks."""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from conftest import require
from radarslam.cli.main import main
from radarslam.config import from_dict
from radarslam.io.recording.stream import Recording
from radarslam.models.attitude import exp_so3, headings, initial_attitude, integrate_attitude, levelling

TI_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "ti_mmwave_demo"
TI_BAG = TI_DIR / "ti_mmwave_rospkg_demo.bag"
HAVE_TI = TI_BAG.is_file() or bool(os.environ.get("CI"))
EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "recordings" / "ti_mmwave.toml"
G = 9.81


# ------------------------------------------------------------------------------------------------
# Attitude
# ------------------------------------------------------------------------------------------------
def test_exp_so3_and_initial_attitude_against_scipy():
    rng = np.random.default_rng(3)
    for w in [np.zeros(3), np.array([1e-13, 0, 0]), *rng.normal(size=(5, 3))]:
        np.testing.assert_allclose(exp_so3(w), Rotation.from_rotvec(w).as_matrix(), atol=1e-12)
    for f in rng.normal(size=(5, 3)) + [0, 0, 9.0]:
        R = initial_attitude(f)
        np.testing.assert_allclose(R.T @ [0, 0, 1], f / np.linalg.norm(f), atol=1e-12)   # up along f
        assert abs(math.atan2(R[1, 0], R[0, 0])) < 1e-12                                  # heading 0
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)


def _tilted_turn(roll, pitch, rate, n=2001, dt=0.005):
    """A body of fixed roll and pitch turning about the vertical at ``rate``: its gyro and accelerometer."""
    t = np.arange(n) * dt
    Rt = Rotation.from_euler("YX", [pitch, roll]).as_matrix()           # tilt: Ry(pitch) Rx(roll)
    gyro = np.tile(Rt.T @ [0, 0, rate], (n, 1))       # w_b with R_k = Rz(rate t) Rt, dR/dt = R [w_b]x
    accel = np.tile(Rt.T @ [0, 0, G], (n, 1))
    return t, gyro, accel, Rt


@pytest.mark.parametrize("tau", [0.5, 10.0])
def test_attitude_of_a_tilted_turning_body(tau):
    """Heading grows at the vertical rate (not the body z rate); tilt stays; levelled up is up."""
    t, gyro, accel, Rt = _tilted_turn(math.radians(-12.0), math.radians(8.0), 0.7)
    R = integrate_attitude(t, gyro, accel, tau_s=tau)
    psi = headings(R)
    np.testing.assert_allclose(psi, 0.7 * t, atol=1e-9)
    assert abs(gyro[0, 2] - 0.7) > 0.01                 # the body's z rate is not the vertical rate
    np.testing.assert_allclose(np.einsum("kji,j->ki", R, [0, 0, 1.0]), accel / G, atol=1e-9)
    L = levelling(R)
    np.testing.assert_allclose(L[-1], Rt, atol=1e-9)    # levelling undoes the tilt, keeps no heading


def test_attitude_recovers_from_a_wrong_start_with_its_time_constant():
    """Started 5 deg off (the first 0.5 s level a biased force), the tilt error decays as exp(-t / tau)."""
    t, gyro, accel, _ = _tilted_turn(0.0, 0.0, 0.0, n=4001)
    acc = accel.copy()
    acc[t <= 0.5] = [G * math.sin(math.radians(5.0)), 0.0, G * math.cos(math.radians(5.0))]
    R = integrate_attitude(t, gyro, acc, tau_s=2.0)
    tilt = np.degrees(np.arccos(np.clip(R[:, 2, 2], -1, 1)))
    k = np.searchsorted(t, [2.5, 4.5, 10.0])
    assert tilt[0] == pytest.approx(5.0, abs=1e-9)
    np.testing.assert_allclose(tilt[k], 5.0 * np.exp(-(t[k] - 0.5) / 2.0), rtol=0.05)   # small-angle decay
    with pytest.raises(Exception, match="time constant"):
        integrate_attitude(t, gyro, acc, tau_s=0.0)


# ------------------------------------------------------------------------------------------------
# Levelling and gating: a tilted platform with an upside-down radar (analytic truth)
# ------------------------------------------------------------------------------------------------
MOUNT = {"mount_x_m": 0.03, "mount_y_m": 0.03, "mount_z_m": -0.06, "mount_roll_deg": 180.0,
         "mount_pitch_deg": 9.0, "mount_yaw_deg": -45.0}


def _synthetic(v_world=(1.0, 0.4), pitch=math.radians(10.0), n_scans=21, seed=5, mover=True):
    """A body pitched by ``pitch`` moving at ``v_world`` (no rotation) past static points at several
    heights, seen by the radar of MOUNT; one point per scan moves at 2 m/s."""
    from radarslam.egomotion.single_radar import mounting_3d
    from radarslam.runs.radar_alone import Imu

    rng = np.random.default_rng(seed)
    cfg = from_dict({"sensor": MOUNT})
    Rm, lever = mounting_3d(cfg.sensor)
    Rb = Rotation.from_euler("y", pitch).as_matrix()
    vw = np.array([v_world[0], v_world[1], 0.0])
    pts = np.column_stack([rng.uniform(-8, 8, 300), rng.uniform(-8, 8, 300), rng.uniform(-1.5, 1.5, 300)])
    t_all, polar, z, dop, heights, horiz, movers = [], [], [], [], [], [], []
    for k in range(n_scans):
        pos = vw * 0.1 * k
        rel = pts - pos
        ps = (Rb.T @ rel.T).T - lever
        ps = ps @ Rm                                     # R_m^T p  (sensor frame)
        front = (ps[:, 0] > 0.5) & (np.abs(np.arctan2(ps[:, 1], ps[:, 0])) < math.radians(60))
        ps, hv = ps[front], rel[front]
        u = ps / np.linalg.norm(ps, axis=1)[:, None]
        vs = Rm.T @ (Rb.T @ vw)
        d = -u @ vs
        m = np.zeros(d.size, bool)
        m[0] = mover
        d[m] += 2.0
        movers.append(m)
        t_all.append(np.full(d.size, 0.1 * k))
        polar.append(np.column_stack([np.hypot(ps[:, 0], ps[:, 1]), np.arctan2(ps[:, 1], ps[:, 0])]))
        z.append(ps[:, 2]), dop.append(d), heights.append(hv[:, 2]), horiz.append(np.hypot(hv[:, 0], hv[:, 1]))
    rec = Recording(np.concatenate(t_all), np.concatenate(polar), {"z_m": np.concatenate(z),
                    "doppler_mps": np.concatenate(dop)}, np.empty(0), np.empty((0, 2)), "unicycle", source="synthetic")
    ti = np.arange(0.0, 0.1 * n_scans + 0.2, 0.005) - 0.1
    imu = Imu(ti, np.zeros((ti.size, 3)), np.tile(Rb.T @ [0, 0, G], (ti.size, 1)))
    static = ~np.concatenate(movers)
    return rec, imu, np.concatenate(heights)[static], np.concatenate(horiz)[static]


def _radar_alone_config(**sensor):
    return from_dict({"filter": {"odometry": "doppler", "motion_model": "body-velocity", "doppler_std_floor_mps": 0.01},
                      "sensor": {**MOUNT, **sensor}})


def test_levelled_velocity_heights_and_gates_against_the_truth():
    from radarslam.core.types import Odometry, Scan
    from radarslam.runs.radar_alone import level_recording

    rec, imu, heights, horiz = _synthetic()
    cfg = _radar_alone_config(elevation_gate_deg=10.0, gyro_bias_from_rest=False)
    lev = level_recording(rec, imu, cfg, np.random.default_rng(0))
    assert lev.valid.all() and not lev.at_rest.any()
    c, s = math.cos(lev.boresight_yaw), math.sin(lev.boresight_yaw)
    body = np.column_stack([c * lev.v[:, 0] - s * lev.v[:, 1], s * lev.v[:, 0] + c * lev.v[:, 1], lev.v[:, 2]])
    np.testing.assert_allclose(body, np.tile([1.0, 0.4, 0.0], (lev.t.size, 1)), atol=1e-9)   # the tilt removed
    assert lev.boresight_yaw == pytest.approx(math.radians(-45.0), abs=1e-9)
    assert lev.n_moving.tolist() == [1] * lev.t.size                                  # the mover, only it
    scans = [e for e in lev.events if isinstance(e, Scan)]
    odos = [e for e in lev.events if isinstance(e, Odometry)]
    assert len(scans) == 21 and len(odos) == 20 and all(o.gyro_rad_s == 0.0 for o in odos)
    np.testing.assert_allclose(scans[3].ego.v, lev.v[3, :2])
    assert scans[3].ego.cov.shape == (2, 2)
    # heights in the levelled frame are the world heights (relative to the IMU), the gate keeps |el| <= 10 deg
    kept_h = np.concatenate([sc.channels["z_m"] for sc in scans])
    kept_r = np.concatenate([sc.polar[:, 0] for sc in scans])
    assert np.all(np.abs(np.degrees(np.arctan2(kept_h, kept_r))) <= 10.0 + 1e-9)
    el = np.degrees(np.arctan2(heights, horiz))
    assert int(lev.n_kept.sum()) == int(np.sum(np.abs(el) <= 10.0)) > 100
    np.testing.assert_allclose(np.sort(kept_h), np.sort(heights[np.abs(el) <= 10.0]), atol=1e-9)
    # a height band and no gate: exactly the points within it
    lev2 = level_recording(rec, imu, _radar_alone_config(height_min_m=-0.5, height_max_m=0.25,
                                                         gyro_bias_from_rest=False), np.random.default_rng(0))
    assert int(lev2.n_kept.sum()) == int(np.sum((heights >= -0.5) & (heights <= 0.25)))


def test_negative_control_a_yaw_only_mounting_of_the_upside_down_radar_is_wrong():
    """The same data with the roll left out: the velocity comes out mirrored, far from the truth."""
    from radarslam.runs.radar_alone import level_recording

    rec, imu, _, _ = _synthetic(mover=False)
    lev = level_recording(rec, imu, _radar_alone_config(mount_roll_deg=0.0, gyro_bias_from_rest=False),
                          np.random.default_rng(0))
    c, s = math.cos(lev.boresight_yaw), math.sin(lev.boresight_yaw)
    vx, vy = c * lev.v[:, 0] - s * lev.v[:, 1], s * lev.v[:, 0] + c * lev.v[:, 1]
    assert np.min(np.hypot(vx - 1.0, vy - 0.4)) > 0.3


def test_rest_bias_is_the_gyro_mean_before_the_first_motion():
    from radarslam.runs.radar_alone import Imu, rest_bias
    from radarslam.models.doppler import EgoVelocity

    def fit(rest):
        return EgoVelocity(np.zeros(2), np.eye(2), np.ones(3, bool), 0.1, 0.0, rest, True)

    st = np.arange(40) * 0.1
    fits = [fit(k < 20 or k >= 35) for k in range(40)]
    t = np.arange(0, 4, 0.005)
    gyro = np.column_stack([np.where(t < 2.0, 0.01, 1.0), np.zeros(t.size), np.full(t.size, -0.007)])
    b, note = rest_bias(Imu(t, gyro, np.zeros((t.size, 3))), st, fits)
    np.testing.assert_allclose(b, [0.01, 0.0, -0.007], atol=1e-12)
    assert "0.00-2.00 s" in note
    b, note = rest_bias(Imu(t, gyro, np.zeros((t.size, 3))), st, [fit(k < 5) for k in range(40)])
    assert not b.any() and "none subtracted" in note                    # 0.5 s of rest is too short


def test_radar_alone_configuration_is_refused_in_one_line():
    from radarslam.core.errors import ConfigError
    from radarslam.runs.radar_alone import check_radar_alone_config

    with pytest.raises(ConfigError, match=r"filter.motion_model: expected 'body-velocity'"):
        check_radar_alone_config(from_dict({"filter": {"odometry": "doppler"}}))
    with pytest.raises(ConfigError, match=r"sensor.height_min_m: expected below"):
        from_dict({"sensor": {"height_min_m": 1.0, "height_max_m": 0.5}})


# ------------------------------------------------------------------------------------------------
# Real drivers' fields: RadarScan, the Doppler field names, INT8
# ------------------------------------------------------------------------------------------------
def _write(path: Path, fmt: str, topic: str, msgtype: str, msgs, typestore) -> Path:
    from radarslam.io.recording.bag_write import _open_writer

    with _open_writer(path, fmt) as w:
        conn = w.add_connection(topic, msgtype, typestore=typestore)
        for ns, msg in msgs:
            w.write(conn, ns, bytes(typestore.serialize_cdr(msg, msgtype)))
    return path


@pytest.mark.parametrize("fmt", ["mcap", "sqlite3"])
def test_ros2_radar_scan_is_read_directly(tmp_path, fmt):
    """RadarScan returns become range r cos(el), azimuth, height r sin(el), Doppler and amplitude."""
    require("rosbags")
    from rosbags.typesys import Stores, get_typestore

    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.radar_scan import RADAR_SCAN, register_radar_msgs

    ts = get_typestore(Stores.ROS2_HUMBLE)
    assert RADAR_SCAN not in ts.types                      # the stock typestore lacks it
    register_radar_msgs(ts)
    T = ts.types
    rng = np.random.default_rng(2)
    rows, msgs = [], []
    for k in range(3):
        r = rng.uniform(1, 20, 4 + k)
        az, el = rng.uniform(-1.2, 1.2, r.size), rng.uniform(-0.4, 0.4, r.size)
        dv, amp = rng.normal(size=r.size), rng.uniform(0, 40, r.size)
        rows.append(np.column_stack([r, az, el, dv, amp]).astype(np.float32).astype(float))
        RR = T["radar_msgs/msg/RadarReturn"]
        ret = [RR(range=float(a), azimuth=float(b), elevation=float(c), doppler_velocity=float(d), amplitude=float(e))
               for a, b, c, d, e in rows[-1]]
        ns = 1_700_000_000 * 10**9 + k * 10**8
        hdr = T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9),
                                       frame_id="radar")
        msgs.append((ns, T[RADAR_SCAN](header=hdr, returns=ret)))
    bag = _write(tmp_path / "scan", fmt, "/radar/scan", RADAR_SCAN, msgs, ts)
    rec = read_bag(bag, "/radar/scan", None)
    R = np.concatenate(rows)
    np.testing.assert_allclose(rec.det_polar[:, 0], R[:, 0] * np.cos(R[:, 2]), rtol=1e-12)
    np.testing.assert_allclose(rec.det_polar[:, 1], R[:, 1], atol=1e-12)
    np.testing.assert_allclose(rec.channels["z_m"], R[:, 0] * np.sin(R[:, 2]), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(rec.channels["doppler_mps"], R[:, 3])
    np.testing.assert_array_equal(rec.channels["rcs"], R[:, 4])
    np.testing.assert_allclose(rec.scan_times(), [0.0, 0.1, 0.2])
    from radarslam.core.errors import InputError

    with pytest.raises(InputError, match="RadarScan carries its Doppler in doppler_velocity"):
        read_bag(bag, "/radar/scan", None, doppler_field="velocity")


@pytest.mark.parametrize("name", ["velocity", "doppler", "v_doppler_mps", "v_r", "VrelRad", "doppler_velocity",
                                  "radial_velocity", "radar_relative_radial_velocity"])
def test_every_common_doppler_name_is_recognised(tmp_path, name):
    """FLOAT32 x, y, padding, then the Doppler as INT8 under each common name."""
    require("rosbags")
    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.bag_write import _Msgs, _open_writer, _typestore

    m = _Msgs(_typestore("ros1"), True)
    PF = m.T["sensor_msgs/msg/PointField"]
    dt = np.dtype({"names": ["x", "y", "v"], "formats": ["<f4", "<f4", "<i1"], "offsets": [0, 4, 11], "itemsize": 12})
    arr = np.zeros(3, dtype=dt)
    arr["x"], arr["y"], arr["v"] = [3.0, 4.0, 5.0], [1.0, -1.0, 0.5], [-128, 7, 127]
    fields = [PF(name="x", offset=0, datatype=7, count=1), PF(name="y", offset=4, datatype=7, count=1),
              PF(name=name, offset=11, datatype=1, count=1)]
    cloud = m.T["sensor_msgs/msg/PointCloud2"](header=m.header(10**9, "radar", 0), height=1, width=3, fields=fields,
                                               is_bigendian=False, point_step=12, row_step=36,
                                               data=np.frombuffer(arr.tobytes(), np.uint8), is_dense=True)
    path = tmp_path / "f.bag"
    with _open_writer(path, "ros1") as w:
        conn = w.add_connection("/radar", "sensor_msgs/msg/PointCloud2", typestore=m.ts)
        w.write(conn, 10**9, m.serialize(cloud, "sensor_msgs/msg/PointCloud2"))
    rec = read_bag(path, "/radar", None)
    np.testing.assert_array_equal(rec.channels["doppler_mps"], [-128.0, 7.0, 127.0])


# ------------------------------------------------------------------------------------------------
# The real TI bag, end to end
# ------------------------------------------------------------------------------------------------
TI_ARGS = ["run", "--recording", str(TI_BAG), "--radar-topic", "/ti_mmwave/radar_scan_pcl"]


def test_radar_alone_without_the_imu_topic_is_refused_in_one_line(tmp_path, capsys):
    require("rosbags")
    out = tmp_path / "out"
    assert main(["run", "--recording", str(tmp_path), "--radar-topic", "/r", "--config", str(EXAMPLE),
                 "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--imu-topic" in err and not out.exists()


@pytest.mark.skipif(not HAVE_TI, reason="../shared/data/ti_mmwave_demo absent")
def test_real_ti_bag_slam_end_to_end_and_its_checks(tmp_path):
    """The full 40 s bag (412 scans) through the example config: the issue's checks, the files."""
    require("rosbags")
    out = tmp_path / "ti"
    assert main(TI_ARGS + ["--imu-topic", "/sensor_platform/imu", "--config", str(EXAMPLE), "--out", str(out)]) == 0
    s = json.loads((out / "summary.json").read_text())
    c = s["checks"]
    assert s["scans"] == 412 and c["valid_fraction"]["value"] >= 0.99
    assert c["at_rest_fraction_0-13 s"]["value"] == 1.0 and c["at_rest_fraction_34-40 s"]["value"] == 1.0
    assert 1.0 <= c["walking_speed_median_mps"]["value"] <= 1.5
    assert c["accel_correlation"]["value"] >= 0.95 and s["accel"]["windows"] >= 350
    assert s["all_pass"]
    assert 0.2 <= s["lateral_speed_median_mps"] <= 0.5                 # the 0.35 m/s, body frame
    dr, tr = s["gyro_dead_reckoning"], s["trajectory"]
    assert abs(dr["turn_deg"] - 358.0) <= 5.0 and dr["end_start_m"] <= 0.5 and 20.0 <= dr["path_m"] <= 26.0
    assert abs(tr["turn_deg"] - dr["turn_deg"]) <= 10.0 and tr["end_start_m"] <= 1.5
    assert s["landmarks_final"] >= 1 and s["detections_moving"] > 0
    tum = np.loadtxt(out / "trajectory_tum.txt")
    assert tum.shape == (412, 8) and np.all(np.isfinite(tum))
    ego = np.genfromtxt(out / "ego_velocity.csv", delimiter=",", names=True)
    assert ego.size == 412 and np.all(np.isfinite(ego["cov_xx_m2s2"])) and np.all(ego["speed_std_mps"] < 0.1)
    rows = (out / "map.csv").read_text().strip().splitlines()
    assert len(rows) == 1 + s["landmarks_final"]
    from radarslam.viz import have_matplotlib

    if have_matplotlib():
        assert (out / "map.png").stat().st_size > 10_000 and (out / "speed_yaw.png").stat().st_size > 10_000
