"""Ego-motion from Doppler (docs/method.md c.10), the simulator's Doppler and moving cars
(b.4.3), the per-detection moving test, and the real TI bag end to end (the moving-object gate and
its negative control: tests/test_moving_objects.py)."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from conftest import require
from radarslam.config import Config, from_dict
from radarslam.models.doppler import directions, fit_ego_velocity, moving_mask

TI_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "ti_mmwave_demo"
TI_BAG = TI_DIR / "ti_mmwave_rospkg_demo.bag"
HAVE_TI = TI_BAG.is_file() or bool(os.environ.get("CI"))
CHI2_3SIGMA = {2: chi2.ppf(0.9973, 2), 3: chi2.ppf(0.9973, 3)}


def synthetic_scan(rng, v, n=60, outliers=0.0, moving_share=0.5, noise=0.1, z=False):
    """One scan of ``n`` detections seen from a sensor moving at ``v``: a fraction ``outliers`` of them
    are not static, ``moving_share`` of those one car moving at 3 m/s (consistent among themselves),
    the rest uniform in +-5 m/s. Returns ``(U, doppler, is_outlier)``."""
    dim = len(v)
    polar = np.column_stack([rng.uniform(2, 20, n), rng.uniform(-np.pi, np.pi, n)])
    U = directions(polar, rng.uniform(-2, 2, n) if z else None)
    d = -U @ v + noise * rng.standard_normal(n)
    n_out = int(round(outliers * n))
    out = np.zeros(n, bool)
    out[:n_out] = True
    n_mov = int(round(moving_share * n_out))
    w = np.zeros(dim)
    w[:2] = 3.0 * np.array([math.cos(1.0), math.sin(1.0)])
    d[:n_mov] = U[:n_mov] @ (w - v) + noise * rng.standard_normal(n_mov)
    d[n_mov:n_out] = rng.uniform(-5, 5, n_out - n_mov)
    return U, d, out


def _nees(e, v):
    r = e.v - v
    return float(r @ np.linalg.solve(e.cov, r))


@pytest.mark.parametrize("z", [False, True])
def test_fit_recovers_the_velocity_within_3_sigma_with_40_percent_outliers(z):
    rng = np.random.default_rng(1)
    v = np.array([4.0, -0.5, 0.2]) if z else np.array([4.0, -0.5])
    hits, valid = 0, 0
    for _ in range(300):
        U, d, out = synthetic_scan(rng, v, outliers=0.4, z=z)
        e = fit_ego_velocity(U, d, rng, iterations=80 if z else 50)
        valid += e.valid
        hits += e.valid and _nees(e, v) <= CHI2_3SIGMA[len(v)]
        if e.valid:
            assert not e.inliers[out].all()
    assert valid == 300
    assert hits / 300 >= 0.97            # 3-sigma region: 99.7% nominal


def test_breakdown_beyond_the_consensus_is_graceful():
    """60% unstructured outliers are still handled (RANSAC needs a consensus, not a majority); at 85%
    almost no scan (<= 2%) and at 90% none yields a valid fit (the consensus is below 30% of the
    scan): the fit says it has none (NaN) rather than give a confident wrong velocity."""
    rng = np.random.default_rng(2)
    v = np.array([3.0, 0.4])
    ok60 = [fit_ego_velocity(*synthetic_scan(rng, v, outliers=0.6, moving_share=0.0)[:2], rng) for _ in range(200)]
    assert np.mean([e.valid and _nees(e, v) <= CHI2_3SIGMA[2] for e in ok60]) >= 0.95
    bad = [fit_ego_velocity(*synthetic_scan(rng, v, outliers=0.85, moving_share=0.0)[:2], rng) for _ in range(500)]
    assert np.mean([e.valid for e in bad]) <= 0.02
    worse = [fit_ego_velocity(*synthetic_scan(rng, v, outliers=0.9, moving_share=0.0)[:2], rng) for _ in range(500)]
    assert not any(e.valid for e in worse)
    assert np.all(np.isnan(worse[0].v)) and np.all(np.isnan(worse[0].cov))


def test_covariance_against_monte_carlo():
    """Fixed geometry, fresh noise: the spread of the estimates equals the reported covariance."""
    rng = np.random.default_rng(3)
    v = np.array([2.0, 1.0])
    U = directions(np.column_stack([rng.uniform(2, 20, 40), rng.uniform(-1.2, 1.2, 40)]))   # a +-70 deg radar
    est, covs = [], []
    for _ in range(3000):
        e = fit_ego_velocity(U, -U @ v + 0.1 * rng.standard_normal(40), rng)
        est.append(e.v), covs.append(e.cov)
    emp, rep = np.cov(np.array(est).T), np.mean(covs, axis=0)
    np.testing.assert_allclose(np.diag(emp) / np.diag(rep), 1.0, atol=0.1)
    assert abs(emp[0, 1] - rep[0, 1]) < 0.1 * math.sqrt(rep[0, 0] * rep[1, 1])
    nees = [float((x - v) @ np.linalg.solve(c, x - v)) for x, c in zip(est, covs)]
    # with s^2 estimated from n - 2 = 38 dof the NEES is Hotelling's T^2, mean 2 * 38 / 36 = 2.11, and
    # the 3-sigma consensus drops the tails (s^2 about 3% low): about 2.17 expected
    assert 1.95 < np.mean(nees) < 2.4


def test_zero_velocity_false_alarms_near_nominal_and_detects_0_3_mps():
    rng = np.random.default_rng(4)
    still = [fit_ego_velocity(*synthetic_scan(rng, np.zeros(2), n=40, outliers=0.1, moving_share=0.0)[:2], rng,
                              zero_probability=0.99) for _ in range(2000)]
    false_alarm = 1.0 - np.mean([e.at_rest for e in still])
    assert 0.003 <= false_alarm <= 0.03         # nominal 0.01
    slow = [fit_ego_velocity(*synthetic_scan(rng, np.array([0.3, 0.0]), n=40, outliers=0.1, moving_share=0.0)[:2],
                             rng) for _ in range(500)]
    assert np.mean([not e.at_rest for e in slow]) >= 0.99


def test_moving_mask_flags_the_moving_car_and_about_1_percent_of_the_static_world():
    rng = np.random.default_rng(5)
    v = np.array([4.0, 0.0])
    flagged_out, flagged_in, n_out, n_in = 0, 0, 0, 0
    for _ in range(300):
        U, d, out = synthetic_scan(rng, v, outliers=0.3, moving_share=1.0)
        e = fit_ego_velocity(U, d, rng)
        m = moving_mask(U, d, e, 0.99)
        flagged_out += m[out].sum()
        flagged_in += m[~out].sum()
        n_out, n_in = n_out + out.sum(), n_in + (~out).sum()
    assert flagged_out / n_out >= 0.9
    assert flagged_in / n_in <= 0.03


def test_sensor_velocity_with_lever_arm_and_yaw_against_finite_differences():
    """v_s = R(-yaw) (v + omega x l): the velocity of the mounted point, by differencing its position."""
    from radarslam.models.doppler import sensor_velocity

    v, w, l, yaw, dt = 3.0, 0.5, np.array([1.2, -0.4]), 0.7, 1e-6
    def sensor_pos(t):
        th = w * t
        c, s = math.cos(th), math.sin(th)
        return np.array([v * t, 0.0]) + np.array([c * l[0] - s * l[1], s * l[0] + c * l[1]])
    vw = (sensor_pos(dt) - sensor_pos(-dt)) / (2 * dt)                    # world = platform frame at t = 0
    c, s = math.cos(yaw), math.sin(yaw)
    np.testing.assert_allclose(sensor_velocity(v, 0.0, w, l[0], l[1], yaw), [c * vw[0] + s * vw[1],
                                                                             -s * vw[0] + c * vw[1]], atol=1e-6)


# ------------------------------------------------------------------ the simulator (b.4.3)
def test_simulated_doppler_matches_the_static_world_and_leaves_the_draws_alone():
    from radarslam.simulation.scenario import generate_scenario

    base = from_dict({"trajectory": {"n_steps": 60}})
    dop = from_dict({"trajectory": {"n_steps": 60}, "radar": {"doppler": True}})
    mov = from_dict({"trajectory": {"n_steps": 60}, "radar": {"doppler": True}, "world": {"moving_vehicles": 3}})
    a, b, c = (generate_scenario(cfg, np.random.default_rng(np.random.SeedSequence(11))) for cfg in (base, dop, mov))
    for s0, s1 in zip(a.scans, b.scans):
        assert np.array_equal(s0.polar, s1.polar) and s0.channels is None
    assert np.array_equal(a.truth.poses, c.truth.poses) and np.array_equal(a.odometry, c.odometry)
    res, n_moving = [], 0
    for k, (s0, s2) in enumerate(zip(a.scans, c.scans)):
        src = c.truth.sources[k]
        fixed = src >= -1
        np.testing.assert_array_equal(np.sort(s0.polar, axis=0), np.sort(s2.polar[fixed], axis=0))
        n_moving += int((src <= -2).sum())
        vel = c.truth.controls[min(k + 1, len(c.scans) - 1)]
        U = directions(s2.polar[src >= 0])
        res.append(s2.channels["doppler_mps"][src >= 0] + U @ np.array([vel[0], 0.0]))
    res = np.concatenate(res)
    assert n_moving > 0
    # 0.1 m/s of Doppler noise and the azimuth noise (1 deg at 4 m/s) of the direction used here
    assert 0.09 < res.std() < 0.13 and abs(res.mean()) < 0.01


# ------------------------------------------------------------------ bags
def test_int16_doppler_field_is_read_as_its_values(tmp_path):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.bag_write import _Msgs, _open_writer, _typestore

    m = _Msgs(_typestore("ros1"), True)
    PF = m.T["sensor_msgs/msg/PointField"]
    dt = np.dtype({"names": ["x", "y", "v"], "formats": ["<f4", "<f4", "<i2"], "offsets": [0, 4, 10], "itemsize": 16})
    arr = np.zeros(3, dtype=dt)
    arr["x"], arr["y"], arr["v"] = [3.0, 4.0, 5.0], [1.0, -1.0, 0.5], [-300, 7, 12000]
    fields = [PF(name="x", offset=0, datatype=7, count=1), PF(name="y", offset=4, datatype=7, count=1),
              PF(name="doppler", offset=10, datatype=3, count=1)]
    cloud = m.T["sensor_msgs/msg/PointCloud2"](header=m.header(10**9, "radar", 0), height=1, width=3, fields=fields,
                                               is_bigendian=False, point_step=16, row_step=48,
                                               data=np.frombuffer(arr.tobytes(), np.uint8), is_dense=True)
    path = tmp_path / "int16.bag"
    with _open_writer(path, "ros1") as w:
        conn = w.add_connection("/radar", "sensor_msgs/msg/PointCloud2", typestore=m.ts)
        w.write(conn, 10**9, m.serialize(cloud, "sensor_msgs/msg/PointCloud2"))
    rec = read_bag(path, "/radar", None)
    np.testing.assert_array_equal(rec.channels["doppler_mps"], [-300.0, 7.0, 12000.0])
    np.testing.assert_allclose(rec.det_polar[:, 0], np.hypot([3, 4, 5], [1, -1, 0.5]), rtol=1e-6)


def test_mounting_quaternion_and_roll_pitch_yaw_agree():
    from radarslam.egomotion.single_radar import mounting_3d

    q = from_dict({"sensor": {"mount_quaternion": [0.91868123, -0.38694684, -0.07175711, -0.03388005]}}).sensor
    e = from_dict({"sensor": {"mount_roll_deg": -179.6102, "mount_pitch_deg": 9.0945,
                              "mount_yaw_deg": -45.6505}}).sensor
    np.testing.assert_allclose(mounting_3d(q)[0], mounting_3d(e)[0], atol=1e-5)


TI_CONFIG = """
[filter]
doppler_threshold_mps = 0.2
doppler_iterations = 100
doppler_std_floor_mps = 0.036

[sensor]
mount_x_m = 0.03
mount_y_m = 0.03
mount_z_m = -0.06
mount_quaternion = [0.91868123, -0.38694684, -0.07175711, -0.03388005]
"""


@pytest.mark.skipif(not HAVE_TI, reason="../shared/data/ti_mmwave_demo absent")
def test_real_ti_bag_ego_motion_end_to_end(tmp_path):
    """Velocity for >= 99% of scans; at rest over 0-13 s and 34-40 s; walking 1.0-1.5 m/s."""
    require("rosbags")
    from radarslam.cli.main import main

    cfg = tmp_path / "ti.toml"
    cfg.write_text(TI_CONFIG)
    out = tmp_path / "out"
    assert main(["run", "--recording", str(TI_BAG), "--radar-topic", "/ti_mmwave/radar_scan_pcl",
                 "--imu-topic", "/sensor_platform/imu", "--config", str(cfg), "--out", str(out)]) == 0
    d = np.genfromtxt(out / "ego_velocity.csv", delimiter=",", names=True)
    t, rest, speed = d["t_s"], d["at_rest"] > 0, d["speed_mps"]
    assert t.size == 412 and d["valid"].mean() >= 0.99
    assert rest[t <= 13.0].all() and rest[(t >= 34.0)].all()
    walk = (t >= 15.0) & (t <= 32.0)
    assert not rest[walk].any()
    assert 1.0 <= np.median(speed[walk]) <= 1.5
    smooth = np.array([np.median(speed[(t >= x - 0.5) & (t <= x + 0.5)]) for x in t[walk]])
    assert np.mean((smooth >= 1.0) & (smooth <= 1.5)) >= 0.9
    assert np.all(np.isfinite(d["cov_xx_m2s2"])) and np.all(d["speed_std_mps"] < 0.1)
    if (out / "speed.png").exists() or not _have_mpl():
        return
    raise AssertionError("speed.png not written although matplotlib is installed")


def _have_mpl() -> bool:
    from radarslam.viz import have_matplotlib

    return have_matplotlib()
