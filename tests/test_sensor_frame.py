"""A scan measured from its own radar's pose (docs/method.md c.13, slam/sensor_frame.py): the lever
arm's Jacobian by central differences, the state transform and its inverse, the update it gives
against the lever arm in the measurement model, bit-identity for a zero mounting, and the view test
about the sensor."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.core.mounting import Mounting
from radarslam.core.types import Scan, Sensor
from radarslam.slam.driver import run_filter
from radarslam.models.radar import range_azimuth, range_azimuth_jacobians
from radarslam.simulation.scenario import generate_scenario
from radarslam.slam import sensor_frame as sf
from oracles import central_jacobian

MOUNTS = [(3.5, 0.0, 0.0), (2.4, 0.8, 1.54), (-0.56, -0.62, -3.07)]


def _fd(f, x, h=1e-6):
    return central_jacobian(f, x, h)


@pytest.mark.parametrize("mount", MOUNTS)
def test_the_lever_arm_jacobian_is_the_sensor_jacobian_times_G(mount):
    """d h(g(p), l) / dp by central differences equals H_s(g(p)) G(p), and d g^{-1} / ds is G^{-1}."""
    p, lm = np.array([3.0, -2.0, 0.7]), np.array([12.0, 5.0])
    a, b = sf.lever_column(p[2], mount[0], mount[1])
    G = np.array([[1.0, 0.0, a], [0.0, 1.0, b], [0.0, 0.0, 1.0]])
    np.testing.assert_allclose(_fd(lambda q: sf.sensor_pose(q, *mount), p), G, atol=1e-8)
    s = sf.sensor_pose(p, *mount)
    np.testing.assert_allclose(_fd(lambda q: sf.platform_pose(q, *mount), s), np.linalg.inv(G), atol=1e-8)
    Hs, Hl = range_azimuth_jacobians(s, lm)
    num = _fd(lambda q: range_azimuth(sf.sensor_pose(q, *mount), lm), p)
    np.testing.assert_allclose(num, Hs @ G, atol=1e-7)
    np.testing.assert_allclose(_fd(lambda q: range_azimuth(s, q), lm), Hl, atol=1e-7)


def _state(n_landmarks: int = 3, seed: int = 0):
    rng = np.random.default_rng(seed)
    n = 3 + 2 * n_landmarks
    A = rng.normal(size=(n, n))
    x = np.concatenate([[3.0, -2.0, 0.7], rng.uniform(-20, 20, 2 * n_landmarks)])
    return x, A @ A.T / n + np.eye(n) * 0.01


@pytest.mark.parametrize("mount", MOUNTS)
def test_to_sensor_is_G_P_Gt_and_to_platform_undoes_it(mount):
    x, P = _state()
    x1, P1 = x.copy(), P.copy()
    sf.state_to_sensor(x1, P1, Mounting(*mount))
    a, b = sf.lever_column(x[2], mount[0], mount[1])
    G = np.eye(x.size)
    G[0, 2], G[1, 2] = a, b
    np.testing.assert_allclose(x1[:3], sf.sensor_pose(x[:3], *mount), rtol=0, atol=1e-14)
    np.testing.assert_array_equal(x1[3:], x[3:])
    np.testing.assert_allclose(P1, G @ P @ G.T, rtol=1e-13, atol=1e-13)
    sf.state_to_platform(x1, P1, Mounting(*mount))
    np.testing.assert_allclose(x1, x, rtol=0, atol=1e-13)
    np.testing.assert_allclose(P1, P, rtol=0, atol=1e-12)


@pytest.mark.parametrize("mount", MOUNTS)
def test_an_update_about_the_sensor_equals_the_lever_arm_measurement_model(mount):
    """One EKF update of landmark 0 from a radar at ``mount``: through the transform (sensor pose,
    H_s, back) and with H_p = H_s G in the platform's state agree to second order in the update."""
    x, P = _state()
    lm = x[3:5]
    R = np.diag([0.5 ** 2, math.radians(1.0) ** 2])
    z = range_azimuth(sf.sensor_pose(x[:3], *mount), lm) + np.array([0.05, 0.002])

    def kalman(x, P, H, e):
        S = H @ P @ H.T + R
        K = P @ H.T @ np.linalg.inv(S)
        return x + K @ e, P - K @ S @ K.T

    def full_H(pose_block_H, Hl):
        H = np.zeros((2, x.size))
        H[:, :3], H[:, 3:5] = pose_block_H, Hl
        return H

    # the lever arm in the measurement model
    s = sf.sensor_pose(x[:3], *mount)
    Hs, Hl = range_azimuth_jacobians(s, lm)
    a, b = sf.lever_column(x[2], mount[0], mount[1])
    G = np.array([[1.0, 0.0, a], [0.0, 1.0, b], [0.0, 0.0, 1.0]])
    e = z - range_azimuth(s, lm)
    xb, Pb = kalman(x, P, full_H(Hs @ G, Hl), e)
    # through the transform
    xa, Pa = x.copy(), P.copy()
    sf.state_to_sensor(xa, Pa, Mounting(*mount))
    xa, Pa = kalman(xa, Pa, full_H(Hs, Hl), e)
    sf.state_to_platform(xa, Pa, Mounting(*mount))
    dx = np.abs(xb - x).max()
    assert np.abs(xa - xb).max() < 10 * dx ** 2 + 1e-12
    np.testing.assert_allclose(Pa, Pb, rtol=0, atol=max(10 * dx, 1e-12) * np.abs(P).max())
    # negative control: the same detection treated as seen from the platform origin is far off
    wrong = np.abs(kalman(x, P, full_H(*range_azimuth_jacobians(x[:3], lm)), z - range_azimuth(x[:3], lm))[0] - xb)
    if mount[:2] != (0.0, 0.0):
        assert wrong.max() > 100 * np.abs(xa - xb).max()


def _config(backend: str = "numba"):
    cfg = profile_config("apsipa")
    return dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, backend=backend))


def test_a_zero_mounting_is_bit_identical_to_no_sensor():
    cfg = profile_config("apsipa")
    sc = generate_scenario(cfg, np.random.default_rng(2), compiled=False)
    with_sensor = [dataclasses.replace(e, sensor=Sensor(0.0, 0.0, 0.0)) if isinstance(e, Scan) else e
                   for e in sc.events]
    a = run_filter(_config("python"), sc.events)
    b = run_filter(_config("python"), with_sensor)
    np.testing.assert_array_equal(a.poses, b.poses)
    np.testing.assert_array_equal(a.pose_covs, b.pose_covs)
    np.testing.assert_array_equal(a.n_landmarks, b.n_landmarks)


def test_the_view_test_is_the_sensors_own():
    """A landmark behind the car is not 'missed' by a forward radar whose field of view excludes it:
    its M/N window is not charged. Negative control: the same scans with no field of view of their
    own (the filter's 360 deg about the platform) remove it."""
    from radarslam.slam.filter import EkfSlam
    from tests.helpers import quiet_config

    cfg = quiet_config()
    lc = cfg.landmarks
    back = np.array([-6.0, 0.0])
    rng = np.random.default_rng(0)
    pts = back + rng.uniform(-0.3, 0.3, (8, 2))
    polar = np.column_stack([np.hypot(pts[:, 0], pts[:, 1]), np.arctan2(pts[:, 1], pts[:, 0])])
    results = {}
    for name, fov in (("own view", math.radians(120.0)), ("platform view", None)):
        slam = EkfSlam(cfg)
        slam.update(Scan(0.0, 1, polar))                      # a rear view creates the landmark
        assert slam.state.n_landmarks == 1
        for k in range(2, 2 + 3 * lc.removal_window):         # then only the forward radar reports, empty
            slam.update(Scan(0.1 * k, k, np.empty((0, 2)), sensor=Sensor(0.0, 0.0, 0.0, None, fov)))
        results[name] = slam.state.n_landmarks
    assert results == {"own view": 1, "platform view": 0}


@pytest.mark.parametrize("gate", [False, True])
def test_the_fused_engine_takes_scans_from_their_own_radars_in_each_form(gate):
    """The car park's scans seen by three radars in turn (front, left turned 88 deg, rear turned
    -176 deg, each with its own field of view): the compiled engine, its steps form and the Python
    reference give the same associations and landmark counts and poses and covariances to 1e-9."""
    pytest.importorskip("numba")
    from radarslam.core.mounting import detections_to_sensor

    cfg = profile_config("apsipa")
    if gate:
        cfg = dataclasses.replace(cfg, radar=dataclasses.replace(cfg.radar, doppler=True),
                                  filter=dataclasses.replace(cfg.filter, doppler_gate=True))
    sc = generate_scenario(cfg, np.random.default_rng(4), compiled=False)
    events, k = [], 0
    for e in sc.events:
        if isinstance(e, Scan):
            m = MOUNTS[k % 3]
            k += 1
            e = dataclasses.replace(e, polar=detections_to_sensor(e.polar, Mounting(*m)) if e.polar.size else e.polar,
                                    sensor=Sensor(*m, max_range_m=25.0, fov_rad=math.radians(150.0)))
        events.append(e)
    py = run_filter(dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, backend="python")), events)
    fu = run_filter(cfg, events)
    orch = run_filter(cfg, events, engine="fused-steps")
    assert (py.engine, fu.engine, orch.engine) == ("fused-python", "fused", "fused-steps")
    for other in (py, orch):
        np.testing.assert_array_equal(other.n_associated, fu.n_associated)
        np.testing.assert_array_equal(other.n_landmarks, fu.n_landmarks)
        np.testing.assert_allclose(fu.poses, other.poses, rtol=0, atol=1e-9)
        np.testing.assert_allclose(fu.pose_covs, other.pose_covs, rtol=0, atol=1e-9)


def _nis_and_rmse(rec, cfg):
    from radarslam.runs.recording import run_recording

    run = run_recording(rec, cfg)
    r = run.record
    return float(r.nis_sum.sum() / r.nis_count.sum()), run.metrics["position_rmse_m"]


def test_a_radar_ahead_gives_the_nis_and_accuracy_of_the_same_drive_at_the_axle():
    """Point reflectors, exact odometry, radar noise drawn about the sensor (0.5 m,
    1 deg, the default R). A radar 3.5 m ahead and one at the axle give the same mean NIS (2 when
    consistent) and mean position RMSE within 1.3x of each other over eight seeds (measured 0.395 and
    0.388 m; single seeds scatter 0.13-0.96 m). Negative control: the same ahead-radar detections moved
    to the platform frame with R about the axle raise the NIS and the error.

    Measured from the truth's first pose with the simulator's std (0.15 m, 0.15 m, 1 deg). With the truth's default std (0.05 m, 0.05 m,
    0.1 deg, docs/method.md b.5.1) both errors fall, to 0.178 m (axle) and 0.256 m (ahead): 1.44x, an
    open question of its own, not this test's.

    Run on the default engine (the fused one, on the session's compiled cache; 1 s for the 24 drives
    against 14 s on the Python reference): the same means to 1e-12 (measured: NIS 1.84991, 1.86119, 4.13800,
    RMSE 0.395368, 0.387860, 1.372445 m on both), and test_the_fused_engine_takes_scans_from_their_own_radars_in_
    each_form holds the forms to 1e-9 on mounted radars."""
    from radarslam.core.mounting import detections_to_platform
    from radarslam.io.recording.synthetic import synthetic_recording

    cfg = _config()
    cfg = dataclasses.replace(cfg, landmarks=dataclasses.replace(cfg.landmarks, associator="batch"),
                              filter=dataclasses.replace(cfg.filter, truth_pose_std=list(cfg.filter.initial_pose_std)))
    out = {}
    for name, m in (("axle", Mounting()), ("ahead", Mounting(3.5, 0.0, 0.0)), ("old", Mounting(3.5, 0.0, 0.0))):
        nis, rmse = [], []
        for seed in range(8):
            rec = synthetic_recording(duration_s=20.0, speed_mps=5.0, turn_rate_rad_s=0.05, sensors={0: m},
                                      range_std_m=0.5, azimuth_std_rad=math.radians(1.0), lateral_m=3.0,
                                      rng=np.random.default_rng(seed))
            if name == "old":
                rec.det_polar = detections_to_platform(rec.det_polar, m)
                rec.sensors = {0: Mounting(sensor_id=0)}
            a, b = _nis_and_rmse(rec, cfg)
            nis.append(a)
            rmse.append(b)
        out[name] = (float(np.mean(nis)), float(np.mean(rmse)))
    (nis_axle, rmse_axle), (nis_ahead, rmse_ahead), (nis_old, rmse_old) = out["axle"], out["ahead"], out["old"]
    assert 1.6 < nis_axle < 2.6 and 1.6 < nis_ahead < 2.6, out
    assert abs(nis_ahead - nis_axle) < 0.3, out
    assert rmse_ahead < 1.3 * rmse_axle and rmse_axle < 1.3 * rmse_ahead, out
    assert nis_old > nis_ahead + 0.5 and rmse_old > 1.5 * rmse_ahead, out
