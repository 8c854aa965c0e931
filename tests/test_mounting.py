"""One mounting type from the readers to the filter (core/mounting.py): the readers'
mountings are the scans' ``Scan.sensor``, the config's ``[sensor]`` and ``[[sensors]]`` are converted by
its constructors, the former names still import with a DeprecationWarning and give the same numbers,
and a recording run says which radar its one mounting is (metrics.json, config.toml)."""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest

from radarslam.config import RigSensorConfig, SensorConfig, profile_config, to_toml
from radarslam.core.errors import InputError
from radarslam.core.mounting import ORIGIN, Mounting, detections_to_platform, detections_to_sensor
from radarslam.core.types import Scan, Sensor
from radarslam.io.recording.stream import stream_events
from radarslam.io.recording.synthetic import synthetic_recording
from radarslam.slam import sensor_frame as sf

RIG = {0: Mounting(3.4, 0.0, 0.0, "test", 0, "front"), 1: Mounting(-0.6, 0.6, math.pi, "test", 1, "rear")}


def test_the_readers_mounting_is_the_scans_sensor():
    import radarslam.io.recording.mounting as io_mounting

    assert io_mounting.Mounting is Mounting
    rec = synthetic_recording(duration_s=2.0, sensors=RIG)
    events, _ = stream_events(rec, Mounting())
    scans = [e for e in events if isinstance(e, Scan)]
    assert {id(s.sensor) for s in scans} == {id(RIG[0]), id(RIG[1])}        # the reader's objects themselves
    # the former Sensor type's constructor (its argument order) gives the same type
    s = Sensor(1.0, 2.0, 0.5, 30.0, 1.2, 7)
    assert s == Mounting(1.0, 2.0, 0.5, sensor_id=7, max_range_m=30.0, fov_rad=1.2) and type(s) is Mounting
    np.testing.assert_array_equal(Mounting.stack(RIG.values()), [[3.4, 0.0, 0.0], [-0.6, 0.6, math.pi]])


def test_the_config_states_one_mounting_converted_in_one_place():
    from radarslam.io.recording.sensors import sensors_from_config

    sensor = SensorConfig(mount_x_m=1.5, mount_y_m=-0.4, mount_yaw_deg=20.0, mount_z_m=0.3)
    m = Mounting.from_config(sensor)
    assert (m.x, m.y, m.yaw, m.source) == (1.5, -0.4, math.radians(20.0), "config")
    back = m.sensor_config(SensorConfig(mount_z_m=0.3))
    assert back == dataclasses.replace(sensor, mount_yaw_deg=math.degrees(math.radians(20.0)))
    cfg = dataclasses.replace(profile_config("automotive"), sensor=sensor,
                              sensors=[RigSensorConfig(0, 3.4, 0.0, 0.0, "front"),
                                       RigSensorConfig(1, -0.6, 0.6, 175.0, "rear", 80.0, 150.0)])
    est = cfg.estimator
    assert est.mounting == m
    assert est.rig == tuple(sensors_from_config(cfg.sensors).values())
    assert est.rig[1].fov_rad == math.radians(150.0) and est.rig[1].max_range_m == 80.0


def test_the_former_names_warn_and_give_the_same_numbers():
    import radarslam.io.recording.mounting as io_mounting
    import radarslam.slam.doppler_gate as gate

    rng = np.random.default_rng(0)
    polar = np.column_stack([rng.uniform(1, 20, 20), rng.uniform(-3, 3, 20)])
    m = Mounting(0.7, -0.4, 0.3)
    with pytest.warns(DeprecationWarning, match="detections_to_platform"):
        old = io_mounting.to_platform
    np.testing.assert_array_equal(old(polar, m), detections_to_platform(polar, m))
    with pytest.warns(DeprecationWarning, match="detections_to_sensor"):
        old = io_mounting.to_sensor
    np.testing.assert_array_equal(old(polar, m), detections_to_sensor(polar, m))

    A = rng.normal(size=(5, 5))
    x, P = np.array([3.0, -2.0, 0.7, 4.0, 5.0]), A @ A.T
    xa, Pa, xb, Pb = x.copy(), P.copy(), x.copy(), P.copy()
    with pytest.warns(DeprecationWarning, match="state_to_sensor"):
        sf.to_sensor(xa, Pa, (0.7, -0.4, 0.3))               # the former (x, y, yaw) tuple
    sf.state_to_sensor(xb, Pb, m)
    np.testing.assert_array_equal(xa, xb)
    np.testing.assert_array_equal(Pa, Pb)
    with pytest.warns(DeprecationWarning, match="state_to_platform"):
        sf.to_platform(xa, Pa, (0.7, -0.4, 0.3))
    sf.state_to_platform(xb, Pb, m)
    np.testing.assert_array_equal(xa, xb)
    with pytest.warns(DeprecationWarning, match="state_to_sensor_kernel"):
        assert sf.to_sensor_xyz is sf.state_to_sensor_kernel
    with pytest.warns(DeprecationWarning, match="scan_mounting"):
        mount_of = sf.mount_of
    assert mount_of(m) == (0.7, -0.4, 0.3) and mount_of(Mounting()) is None and mount_of(None) is None
    assert sf.scan_mounting(m) is m and sf.scan_mounting(ORIGIN) is None
    with pytest.warns(DeprecationWarning, match="Mounting.from_config"):
        old = gate.mounting
    sensor = SensorConfig(mount_x_m=1.5, mount_y_m=-0.4, mount_yaw_deg=20.0)
    f = Mounting.from_config(sensor)
    assert old(sensor) == (f.x, f.y, f.yaw)
    assert gate.DopplerGate(profile_config("automotive").filter, (f.x, f.y, f.yaw)).mounting == Mounting(f.x, f.y, f.yaw)
    with pytest.raises(AttributeError):
        sf.no_such_name


def test_a_mounting_of_another_form_is_refused_in_one_line():
    with pytest.raises(InputError, match=r"^mounting: expected a Mounting or \(x m, y m, yaw rad\), got 'front'$"):
        Mounting.coerce("front")


def test_a_recording_run_says_which_radar_its_one_mounting_is(tmp_path):
    """Under a rig the config's [sensor] holds the radar of the most detections, for the steps that take
    one mounting: metrics.json's mounting and a comment on config.toml's [sensor] say which, and how
    many scans (none here: each from its own radar, docs/method.md c.13) took it."""
    from radarslam.runs.recording import effective_mounting, with_mounting
    from radarslam.runs.recording_outputs import mounting_metrics

    rec = synthetic_recording(duration_s=2.0, sensors=RIG)
    rec.channels["sensor_id"] = np.where(np.arange(rec.det_t.size) % 3 == 0, 0.0, 1.0)   # sensor 1 the most
    cfg = profile_config("automotive")
    m = effective_mounting(rec, cfg)
    assert m is RIG[1]
    events, _ = stream_events(rec, m)
    out = mounting_metrics(rec, m, events)
    assert out["chosen"] == "sensor 1 (rear), the radar of the most detections of the rig's 2"
    assert out["single_mounting_scans"] == 0 and out["sensors"] == {"0": "front", "1": "rear"}
    text = to_toml(with_mounting(cfg, m), notes={"sensor": "mount_*: " + out["chosen"]})
    assert "[sensor]\n# mount_*: sensor 1 (rear), the radar of the most detections" in text
    back = tomllib.loads(text)["sensor"]
    assert (back["mount_x_m"], back["mount_y_m"], math.radians(back["mount_yaw_deg"])) == pytest.approx(
        (-0.6, 0.6, math.pi), abs=1e-15)
    one = synthetic_recording(duration_s=2.0)
    events, _ = stream_events(one, Mounting())
    got = mounting_metrics(one, effective_mounting(one, cfg), events)
    assert got["chosen"] == "the config's [sensor]" and got["single_mounting_scans"] == len(
        [e for e in events if isinstance(e, Scan)])
