"""Each radar's yaw offset as a state (docs/method.md c.13.1, ``filter.radar_yaw_states``): the frame
change is exact (dense ``G P G^T`` and its inverse), the rig's zero mean holds, the options refuse what
they cannot do, and on a simulated three-radar rig among point landmarks with known offsets the
filter recovers them (the filter without the states as the negative control)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from consistency_bounds import nees_band
from test_odometry_bias import DT, INPUT_STD, _controls, _point_config, _world

from radarslam.config import RigSensorConfig
from radarslam.core.angles import wrap_pi
from radarslam.core.errors import ConfigError
from radarslam.core.types import Odometry, Scan, Sensor
from radarslam.models.motion import UnicycleModel
from radarslam.slam import EkfSlam
from radarslam.slam.radar_yaw import enter_yaw, leave_yaw

#: Three radars: front, rear-left, rear-right (x, y, yaw), and their true yaw offsets (sum 0, deg).
RIG = [(3.5, 0.0, 0.0), (-0.5, 0.8, math.radians(110.0)), (-0.5, -0.8, math.radians(-110.0))]
OFFSETS_DEG = np.array([1.5, -2.0, 0.5])


def test_enter_and_leave_are_the_exact_frame_change(rng):
    """``enter_yaw`` is ``x <- G x``, ``P <- G P G^T`` with ``G = I + e_2 e_i^T``; ``leave_yaw`` undoes it."""
    n, i = 9, 6
    x = rng.normal(size=n)
    A = rng.normal(size=(n, n))
    P = A @ A.T
    G = np.eye(n)
    G[2, i] = 1.0
    x1, P1 = x.copy(), P.copy()
    enter_yaw(x1, P1, 2, i)
    np.testing.assert_allclose(x1, G @ x, rtol=1e-15)
    np.testing.assert_allclose(P1, G @ P @ G.T, rtol=1e-13, atol=1e-13)
    leave_yaw(x1, P1, 2, i)
    np.testing.assert_allclose(x1, x, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(P1, P, rtol=1e-12, atol=1e-12)


def _rig_config(on: bool, reference: str = "rig"):
    cfg = _point_config("unicycle", "states")
    sensors = [RigSensorConfig(j, x, y, math.degrees(yaw)) for j, (x, y, yaw) in enumerate(RIG)]
    f = replace(cfg.filter, radar_yaw_states=on, radar_yaw_reference=reference, fused=False,
                bias_scale_std=0.0, bias_scale_drift_per_rt_s=0.0, bias_turn_rate_std_deg_s=0.0,
                bias_turn_rate_drift_deg_s_per_rt_s=0.0, max_range_m=40.0, field_of_view_deg=120.0)
    return replace(cfg, filter=f, sensors=sensors)


def test_options_and_refusals():
    """One state per radar after the model's, named by sensor id, with their mean held at 0 under the
    rig reference (and free under none); refused without the bias block or a rig; the fused engine
    runs them."""
    slam = EkfSlam(_rig_config(True))
    assert slam.bias_model.names[-3:] == ("yaw_offset_0", "yaw_offset_1", "yaw_offset_2")
    idx = [slam.bias_model.yaw_index(j) for j in range(3)]
    assert idx == [5, 6, 7] and slam.bias_model.yaw_index(9) is None
    ones = np.zeros(slam.x.size)
    ones[idx] = 1.0
    assert ones @ slam.P @ ones < 1e-10                              # the rig's mean: held
    assert slam.P[5, 5] == pytest.approx(math.radians(1.0) ** 2 * 2 / 3, rel=1e-6)
    free = EkfSlam(_rig_config(True, "none"))
    assert ones @ free.P @ ones == pytest.approx(3 * math.radians(1.0) ** 2)
    cfg = _rig_config(True)
    with pytest.raises(ConfigError, match="filter.radar_yaw_states: expected filter.odometry_bias 'states'"):
        EkfSlam(replace(cfg, filter=replace(cfg.filter, odometry_bias="none")))
    with pytest.raises(ConfigError, match="filter.radar_yaw_states: expected a rig of radars"):
        EkfSlam(replace(cfg, sensors=[]))
    with pytest.raises(ConfigError, match="filter.bias_tau_s: expected 0 with"):
        EkfSlam(replace(cfg, filter=replace(cfg.filter, bias_tau_s=5.0)))


def _rig_run(seed: int):
    """The point drive of c.11.4 seen by the three radars in turn (a scan every 4 odometry steps, each
    from the next radar), each radar turned by its true offset from its stated yaw; exact odometry
    statistics (white noise of INPUT_STD)."""
    rng = np.random.default_rng(seed)
    landmarks = _world(seed)
    model = UnicycleModel()
    pose = np.zeros(3)
    events, poses = [], []
    for k, u in enumerate(_controls("unicycle")):
        if k % 4 == 0:
            j = (k // 4) % len(RIG)
            x, y, yaw = RIG[j]
            c, s = math.cos(pose[2]), math.sin(pose[2])
            sp = np.array([pose[0] + c * x - s * y, pose[1] + s * x + c * y])
            d = landmarks - sp
            r = np.hypot(d[:, 0], d[:, 1])
            phi = wrap_pi(np.arctan2(d[:, 1], d[:, 0]) - pose[2] - yaw - math.radians(OFFSETS_DEG[j]))
            seen = (r >= 1.0) & (r <= 40.0) & (np.abs(phi) <= math.radians(60.0))
            polar = np.column_stack([r[seen], phi[seen]]) + rng.standard_normal((int(seen.sum()), 2)) * [0.1, math.radians(1.0)]
            events.append(Scan(t=k * DT, index=k // 4, polar=polar, sensor=Sensor(x, y, yaw, sensor_id=j)))
            poses.append(pose.copy())
        events.append(Odometry(t=(k + 1) * DT, dt=DT, control=u + rng.standard_normal(2) * INPUT_STD))
        pose = model.step(pose, u, DT)
    return events, np.array(poses)


def _track(cfg, events, poses):
    slam = EkfSlam(cfg)
    err, nees, k = [], [], 0
    for ev in events:
        if slam.process(ev) is None:
            continue
        e = slam.pose - poses[k]
        e[2] = math.remainder(e[2], 2.0 * math.pi)
        err.append(math.hypot(e[0], e[1]))
        nees.append(float(e @ np.linalg.solve(slam.pose_cov, e)))
        k += 1
    return np.array(err), np.array(nees), slam


@pytest.mark.parametrize("seed", [0, 1])
def test_yaw_offsets_are_learnt_on_a_simulated_rig(seed):
    """Each radar's offset within 3.5 of its stds of the truth (EKF-SLAM's own overconfidence, about
    1.2-1.7x in the pose NEES here, widens the 3 a consistent filter would need; seeds 0-5 measured in
    docs/method.md c.13.1: |z| at most 2.98), every std below a third of the 1 deg prior; the pose NEES
    (3 dof) averaged over the run's 300 scans within the two-sided 95% band of one run's per-scan
    NEES, chi2(3) = [0.22, 9.35] (the scans of one run are correlated: the per-scan band is the time
    average's conservative band, tests/consistency_bounds.py; measured 6.7 and 4.6 on seeds 0 and 1).
    Negative controls: the filter told the radar 10 times more precise than it is (range and azimuth
    stds / 10; the simulation keeps 0.1 m and 1 deg) lies above the band (measured 65 and 17); the
    filter without the states has a NEES at least 1.5 times as large (1.67-3.8x over seeds 0-5)."""
    events, poses = _rig_run(seed)
    _, nees1, slam = _track(_rig_config(True), events, poses)
    _, nees0, _ = _track(_rig_config(False), events, poses)
    idx = [slam.bias_model.yaw_index(j) for j in range(3)]
    est, std = np.degrees(slam.x[idx]), np.degrees(np.sqrt(np.diag(slam.P)[idx]))
    assert np.all(np.abs(est - OFFSETS_DEG) < 3.5 * std) and np.all(std < 1.0 / 3), (est, std)
    lo, hi = nees_band(3, 1)
    assert lo <= nees1.mean() <= hi and nees0.mean() > 1.5 * nees1.mean(), (nees1.mean(), nees0.mean(), lo, hi)
    on = _rig_config(True)
    sharp = replace(on, filter=replace(on.filter, range_std_m=on.filter.range_std_m / 10,
                                       azimuth_std_deg=on.filter.azimuth_std_deg / 10))
    _, nees_sharp, _ = _track(sharp, events, poses)
    assert nees_sharp.mean() > hi, (nees_sharp.mean(), hi)
