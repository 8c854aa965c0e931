"""The radar alone on a rig and the Doppler modes' gyro noise: the command line runs the radar alone on
a rig, the radar alone carries the rig's whole velocity, the gyro modes take the gyro's noise as a
density (docs/method.md c.10.5, c.10.5.1, c.12.2, c.2.2).

Oracles:
- what a rig observes (c.12.2): two radars at different positions give ``(v_x, v_y, omega)``,
  wherever the rear axle is; one radar needs ``l_x != 0`` (no sideslip, c.10.5.1);
- a rig of a front, a rear and a side radar on io/recording/synthetic.py's car at 8 m/s and
  0.1 rad/s with a thrust angle of -0.5 deg (``v_y = v tan(-0.5 deg)`` at the rear axle), each
  detection given its exact static Doppler: the radar alone's prediction input must be the car's
  ``(v, v_y, omega)`` at every scan after the first fit (1e-6); the no-sideslip yaw rate of the rear
  radar (l_x = -0.6 m) would be ``omega + v_y / l_x`` = +6.7 deg/s off;
- the gyro is a density (c.2.2): the heading variance its noise adds over 1 s is
  ``sigma^2 dt_0 * 1 s`` whether the second has 10 or 50 scan intervals.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from radarslam.config import RigSensorConfig, profile_config, validate
from radarslam.core.errors import ConfigError
from radarslam.core.types import Odometry, Scan
from radarslam.io.recording.mounting import Mounting
from radarslam.io.recording.synthetic import synthetic_recording

SPEED, TURN, THRUST = 8.0, 0.1, math.radians(-0.5)
VY = SPEED * math.tan(THRUST)
RIG = {0: Mounting(3.4, 0.0, 0.0, "test", 0, "front"), 1: Mounting(-0.6, 0.6, math.pi, "test", 1, "rear"),
       2: Mounting(2.4, -0.8, -math.pi / 2, "test", 2, "right")}


def _rig_recording(duration_s=3.0):
    """The rig's recording with every detection's exact static Doppler of the body velocity
    ``(SPEED, VY, TURN)`` at the rear axle (c.10.1: platform axes ``(v_x - omega l_y, v_y + omega l_x)``)."""
    rec = synthetic_recording(duration_s=duration_s, speed_mps=SPEED, turn_rate_rad_s=TURN, sensors=RIG, returns=2)
    sid = rec.channels["sensor_id"].astype(int)
    d = np.empty(rec.det_t.size)
    for s, m in RIG.items():
        k = sid == s
        wp = np.array([SPEED - TURN * m.y, VY + TURN * m.x])
        c, sn = math.cos(m.yaw), math.sin(m.yaw)
        w = np.array([c * wp[0] + sn * wp[1], -sn * wp[0] + c * wp[1]])
        d[k] = -(np.cos(rec.det_polar[k, 1]) * w[0] + np.sin(rec.det_polar[k, 1]) * w[1])
    return dataclasses.replace(rec, channels={**rec.channels, "doppler_mps": d})


def _alone(sensors=(), mount_x=0.0, backend="python"):
    cfg = profile_config("automotive")
    return validate(dataclasses.replace(
        cfg, filter=dataclasses.replace(cfg.filter, odometry="doppler", yaw_rate="doppler", backend=backend),
        sensor=dataclasses.replace(cfg.sensor, mount_x_m=mount_x),
        sensors=[RigSensorConfig(k, m.x, m.y, math.degrees(m.yaw), m.name) for k, m in sensors]))


def test_what_the_radar_alone_observes():
    from radarslam.slam.odometry_source import radar_alone_unobservable

    sensor = profile_config("automotive").sensor
    nuscenes = ((3.412, 0.0, 0.0), (2.422, 0.8, 1.54), (2.422, -0.8, -1.59), (-0.562, 0.628, 3.04),
                (-0.562, -0.618, -3.07))
    assert radar_alone_unobservable(nuscenes, sensor) is None
    assert radar_alone_unobservable(((0.0, 0.7, 1.5), (0.0, -0.7, -1.5)), sensor) is None   # both on the axle
    assert radar_alone_unobservable(((2.0, 0.0, 0.0),), sensor) is None                     # one, off the axle
    assert "got a rig of 2 radar(s), all at x = 0.0, y = 0.5" in radar_alone_unobservable(
        ((0.0, 0.5, 0.0), (0.0, 0.5, 3.1)), sensor)                                          # one position twice
    assert "got sensor.mount_x_m = 0.0 and no rig" in radar_alone_unobservable((), sensor)   # negative control


def test_the_filter_reads_the_rig_not_the_sensor_section():
    from radarslam.slam.filter import EkfSlam

    EkfSlam(_alone(sorted(RIG.items()), mount_x=0.0))          # [sensor] on the axle, the rig off it
    with pytest.raises(ConfigError, match=r"^filter.yaw_rate: 'doppler' needs the radar off the rear axle"):
        EkfSlam(_alone((), mount_x=0.0))


def test_the_cli_runs_the_radar_alone_on_a_rig(tmp_path, capsys, monkeypatch):
    """The compiled backend (the default) runs the radar alone on a recording's rig: its first-run
    rule builds the filter with the recording's rig, not from the config's ``[sensor]`` alone."""
    from radarslam.cli.main import main
    from radarslam.io.recording.plain import write_plain

    monkeypatch.setenv("RADARSLAM_BACKGROUND_COMPILE", "0")
    (tmp_path / "rec").mkdir()
    write_plain(_rig_recording(), tmp_path / "rec")
    (tmp_path / "x.toml").write_text('[filter]\nodometry = "doppler"\nyaw_rate = "doppler"\n')
    code = main(["run", "--recording", str(tmp_path / "rec"), "--profile", "automotive", "--config",
                 str(tmp_path / "x.toml"), "--out", str(tmp_path / "out")])
    assert code == 0, capsys.readouterr().err
    assert (tmp_path / "out" / "run.json").exists()


def _inputs(rec, cfg):
    """Every prediction input ``(u, U, dt)`` the radar alone takes over ``rec`` (the filter's
    event flow, slam/odometry_source.py)."""
    from radarslam.egomotion.rig_odometry import with_rig_velocity
    from radarslam.io.recording.stream import stream_events
    from radarslam.slam.filter import EkfSlam

    m = RIG[0]
    cfg = dataclasses.replace(cfg, sensor=dataclasses.replace(cfg.sensor, mount_x_m=m.x, mount_y_m=m.y))
    events, _ = stream_events(rec, m)
    events = with_rig_velocity(events, rec, cfg)
    slam = EkfSlam(cfg)
    src, out = slam._odometry, []
    for ev in events:
        if isinstance(ev, Odometry):
            src.accumulate(ev)
        elif isinstance(ev, Scan):
            if src.n:
                out.append(src.prediction_input(slam.Q)[:3])
                src.clear_interval()
            src.fit(ev, None)
    return out


def test_the_radar_alone_takes_the_rigs_three_unknown_fit():
    rec = _rig_recording()
    got = _inputs(rec, _alone(sorted(RIG.items()), mount_x=3.4))
    u = np.array([g[0] for g in got[3:]])                   # after the first fits
    assert u.shape[0] > 20
    np.testing.assert_allclose(u[:, 2], TURN, atol=1e-6)   # the no-sideslip rear radar: +0.116 rad/s off
    np.testing.assert_allclose(u[:, 1], VY, atol=1e-6)
    np.testing.assert_allclose(u[:, 0], SPEED, atol=1e-6)


def test_negative_control_the_no_sideslip_yaw_rate_of_a_rear_radar_is_off_by_vy_over_lx():
    rec = _rig_recording()
    rear = {1: RIG[1]}
    keep = rec.channels["sensor_id"] == 1
    one = dataclasses.replace(rec, det_t=rec.det_t[keep], det_polar=rec.det_polar[keep],
                              channels={k: v[keep] for k, v in rec.channels.items()}, sensors=rear)
    got = _inputs(one, _alone([(1, RIG[1])], mount_x=3.4))
    w = np.array([g[0][2] for g in got[3:]])
    np.testing.assert_allclose(w, TURN + VY / RIG[1].x, atol=1e-6)     # +6.7 deg/s: what defect 1 was
    assert math.degrees(VY / RIG[1].x) == pytest.approx(6.67, abs=0.01)


def _heading_var_per_second(intervals: int) -> float:
    """The heading variance the gyro's noise adds over 1 s of ``intervals`` scan intervals (each of
    one odometry reading), Doppler + gyro (``F_u``'s omega row is ``dt``, c.10.5)."""
    from radarslam.slam.odometry_source import DopplerOdometry

    cfg = profile_config("automotive")
    f = dataclasses.replace(cfg.filter, odometry="doppler", yaw_rate="gyro")
    src = DopplerOdometry(f)
    dt, total = 1.0 / intervals, 0.0
    for k in range(intervals):
        src.accumulate(Odometry(t=k * dt, dt=dt, control=np.array([5.0, 0.0]), gyro_rad_s=0.1))
        _, U, d, _ = src.prediction_input(np.zeros((3, 3)))
        total += U[2, 2] * d * d
        src.clear_interval()
    return total


def test_the_gyro_noise_is_a_density():
    cfg = profile_config("automotive").filter
    want = math.radians(cfg.gyro_std_deg_s) ** 2 * cfg.noise_interval_s * 1.0     # c.2.2: sigma^2 dt_0 T
    for n in (10, 50, 65):
        assert _heading_var_per_second(n) == pytest.approx(want, rel=1e-9)
    # per interval (the defect): 10 and 50 intervals would differ fivefold
    assert _heading_var_per_second(10) / _heading_var_per_second(50) == pytest.approx(1.0, rel=1e-9)
