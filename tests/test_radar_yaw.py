"""The yaw rate from the radar alone (docs/method.md c.10.5.1).

A radar off the rear axle (lever arm ``l``) measures ``w' = [v - omega l_y, omega l_x]`` (platform
axes) under no sideslip: ``omega = w'_y / l_x``. Tested: the map and its covariance against an
analytic oracle, central differences and Monte Carlo; the estimator on simulated scans (mounted
radar, b.4.3) against the true yaw rate within its stated std; the simulator's mounting against the
same scene seen from the origin; the refused combinations (negative control: ``l_x = 0``); the
body-velocity model's unobservable direction; the filter end to end.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.config import from_dict
from radarslam.core.errors import ConfigError
from radarslam.core.types import Scan, Sensor
from radarslam.models.doppler import fit_ego_velocity, mounted_directions, sensor_velocity
from radarslam.slam.odometry_source import platform_input

MOUNT = (3.7, 0.4, math.radians(20.0))


def test_platform_input_recovers_speed_and_yaw_rate_exactly():
    for v, omega in [(4.0, 0.32), (-1.5, -0.8), (0.0, 0.5), (7.0, 0.0)]:
        w = sensor_velocity(v, 0.0, omega, *MOUNT)
        u, U = platform_input(w, np.zeros((2, 2)), MOUNT, None, 0.0)
        np.testing.assert_allclose(u, [v, 0.0, omega], atol=1e-12)
        assert np.all(U == 0.0)
    # with the gyro, the lateral speed is free: v = R(yaw_m) w - omega x l
    w = sensor_velocity(3.0, -0.6, 0.25, *MOUNT)
    u, _ = platform_input(w, np.zeros((2, 2)), MOUNT, 0.25, 0.0)
    np.testing.assert_allclose(u, [3.0, -0.6, 0.25], atol=1e-12)


def test_platform_input_covariance_against_differences_and_monte_carlo():
    rng = np.random.default_rng(5)
    w0 = sensor_velocity(4.0, 0.0, 0.3, *MOUNT)
    C = np.array([[0.04 ** 2, 3e-4], [3e-4, 0.03 ** 2]])
    for yaw_rate, yaw_var in [(None, 0.0), (0.3, math.radians(0.1) ** 2)]:
        _, U = platform_input(w0, C, MOUNT, yaw_rate, yaw_var)
        # the map is linear: its Jacobian by central differences gives U = J C J^T
        h = 1e-6
        J = np.column_stack([(platform_input(w0 + h * e, C, MOUNT, yaw_rate, yaw_var)[0]
                              - platform_input(w0 - h * e, C, MOUNT, yaw_rate, yaw_var)[0]) / (2 * h)
                             for e in np.eye(2)])
        extra = np.zeros((3, 3))
        if yaw_rate is not None:
            g = (platform_input(w0, C, MOUNT, yaw_rate + h, yaw_var)[0]
                 - platform_input(w0, C, MOUNT, yaw_rate - h, yaw_var)[0]) / (2 * h)
            extra = yaw_var * np.outer(g, g)
        np.testing.assert_allclose(U, J @ C @ J.T + extra, rtol=1e-6, atol=1e-14)
        # Monte Carlo: 40,000 draws of w (and the gyro); sample covariance within 3% on the diagonal
        ws = rng.multivariate_normal(w0, C, 40_000)
        gs = np.zeros(40_000) if yaw_rate is None else yaw_rate + math.sqrt(yaw_var) * rng.standard_normal(40_000)
        us = np.array([platform_input(w, C, MOUNT, None if yaw_rate is None else g, yaw_var)[0]
                       for w, g in zip(ws, gs)])
        S = np.cov(us.T)
        d = np.diag(U) > 0
        np.testing.assert_allclose(np.diag(S)[d], np.diag(U)[d], rtol=0.03)
    # sigma_omega = sigma(w'_y) / l_x: the yaw rate's std falls as 1 / l_x
    s = [math.sqrt(platform_input(w0, C, (lx, 0.0, 0.0), None, 0.0)[1][2, 2]) for lx in (1.0, 2.0, 4.0)]
    np.testing.assert_allclose(s, [0.03, 0.015, 0.0075], rtol=1e-12)


def test_body_velocity_model_leaves_a_direction_unobservable():
    """Three unknowns, two equations: (delta v_x, delta v_y, delta omega) = (l_y, -l_x, 1) t leaves the
    sensor velocity unchanged, so no single radar fixes omega without the no-sideslip constraint."""
    lx, ly, yaw = MOUNT
    for t in (0.1, -0.7, 2.0):
        np.testing.assert_allclose(sensor_velocity(4.0 + ly * t, -0.3 - lx * t, 0.2 + t, *MOUNT),
                                   sensor_velocity(4.0, -0.3, 0.2, *MOUNT), atol=1e-12)


def _mounted(lx=3.7, **extra):
    return from_dict({"trajectory": {"n_steps": 60}, "radar": {"doppler": True}, "sensor": {"mount_x_m": lx},
                      "filter": {"odometry": "doppler", "yaw_rate": "doppler", **extra}})


def test_yaw_rate_from_simulated_scans_within_its_stated_std():
    """A radar 3.7 m ahead of the rear axle (a front bumper): the yaw rate of each simulated scan
    (b.4.3: measured from the radar, Doppler 0.1 m/s) against the truth, normalised by the stated
    std: mean within 0.15, std within [0.9, 1.3], at most 1% beyond 3.5 sigma (300 scans, fixed seeds)."""
    from radarslam.simulation.scenario import generate_scenario

    cfg = _mounted()
    rng = np.random.default_rng(0)
    z, sd = [], []
    for seed in range(5):
        sc = generate_scenario(cfg, np.random.default_rng(np.random.SeedSequence(seed)))
        scans = [e for e in sc.events if isinstance(e, Scan)]
        for k, scan in enumerate(scans):
            assert scan.sensor == Sensor(3.7, 0.0, 0.0)     # in the radar's own frame (docs/method.md c.13)
            e = fit_ego_velocity(mounted_directions(scan.polar), scan.channels["doppler_mps"], rng)
            u, U = platform_input(e.v, e.cov, (3.7, 0.0, 0.0), None, 0.0)
            omega = sc.truth.controls[min(k + 1, len(scans) - 1), 1]
            z.append((u[2] - omega) / math.sqrt(U[2, 2]))
            sd.append(math.sqrt(U[2, 2]))
    z = np.array(z)
    assert z.size == 300
    assert abs(z.mean()) < 0.15 and 0.9 < z.std() < 1.3 and np.mean(np.abs(z) > 3.5) <= 0.01
    assert 0.004 < np.median(sd) < 0.012          # about 0.4 deg/s: sigma(w'_y) ~ 0.028 m/s over 3.7 m


def test_simulated_mounting_moves_the_radar_not_the_scene():
    """The mounted radar's detections (in its own frame, Scan.sensor, docs/method.md c.13) lie on the
    same cars, and its Doppler is the mounted sensor's velocity along the directions from the radar
    (residual std about the Doppler noise and the direction noise)."""
    from radarslam.core.mounting import Mounting, detections_to_platform

    from radarslam.simulation.scenario import generate_scenario

    cfg = _mounted()
    sc = generate_scenario(cfg, np.random.default_rng(np.random.SeedSequence(3)))
    scans = [e for e in sc.events if isinstance(e, Scan)]
    res = []
    for k, scan in enumerate(scans):
        src = sc.truth.sources[k]
        v, omega = sc.truth.controls[min(k + 1, len(scans) - 1)]
        U = mounted_directions(scan.polar[src >= 0])
        res.append(scan.channels["doppler_mps"][src >= 0] + U @ sensor_velocity(v, 0.0, omega, 3.7, 0.0, 0.0))
    res = np.concatenate(res)
    assert 0.09 < res.std() < 0.2 and abs(res.mean()) < 0.02
    # negative control: directions from the platform origin (the lever arm ignored) are wrong
    bad = []
    for k, scan in enumerate(scans):
        src = sc.truth.sources[k]
        v, omega = sc.truth.controls[min(k + 1, len(scans) - 1)]
        U = mounted_directions(detections_to_platform(scan.polar[src >= 0], Mounting(3.7, 0.0, 0.0)))
        bad.append(scan.channels["doppler_mps"][src >= 0] + U @ sensor_velocity(v, 0.0, omega, 3.7, 0.0, 0.0))
    assert np.concatenate(bad).std() > 3 * res.std()


def test_refused_combinations_name_the_key():
    from radarslam.slam.filter import EkfSlam

    with pytest.raises(ConfigError, match=r"^filter.yaw_rate: 'doppler' needs the radar off the rear axle.*"
                                          r"sensor.mount_x_m = 0.0 and no rig$"):
        EkfSlam(_mounted(lx=0.0))                                        # negative control: l_x = 0
    for odometry in ("odometer", "both"):
        with pytest.raises(ConfigError, match=rf"^filter.yaw_rate: 'doppler' expected with filter.odometry "
                                              rf"'doppler'.*got filter.odometry '{odometry}'$"):
            EkfSlam(_mounted(odometry=odometry))


def test_radar_alone_end_to_end_against_the_odometer():
    """Three trials of the car park (No extent) with the radar 3.7 m ahead: the radar alone (no
    odometer, no gyro) within 1.3x of the odometer's position and heading avg. RMSE; negative
    control: the Doppler noise 100x (10 m/s) makes it at least 2x worse."""
    import dataclasses

    from radarslam.slam.driver import run_filter
    from radarslam.metrics.pose import avg_rmse, pose_errors
    from radarslam.simulation.scenario import generate_scenario

    def run(cfg, filt):
        pos, head = [], []
        for seed in range(1, 4):
            sc = generate_scenario(cfg, np.random.default_rng(np.random.SeedSequence(seed)))
            rec = run_filter(dataclasses.replace(cfg, filter=filt), sc.events)
            p, h = pose_errors(rec.poses, sc.truth.poses)
            pos.append(p)
            head.append(h)
        return avg_rmse(np.array(pos)), avg_rmse(np.array(head))

    cfg = from_dict({"radar": {"doppler": True}, "sensor": {"mount_x_m": 3.7}})
    alone = dataclasses.replace(cfg.filter, odometry="doppler", yaw_rate="doppler")
    p_odo, h_odo = run(cfg, cfg.filter)
    p_alone, h_alone = run(cfg, alone)
    assert p_alone < 1.3 * p_odo and h_alone < 1.3 * h_odo
    noisy = dataclasses.replace(cfg, radar=dataclasses.replace(cfg.radar, doppler_std_mps=10.0))
    p_bad, h_bad = run(noisy, alone)
    assert p_bad > 2 * p_alone
