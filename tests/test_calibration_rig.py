"""A car's calibration names the rig it was computed on (docs/recordings.md "Calibration"): applied to
a recording whose radars' nominal mountings differ beyond the calibration's own uncertainty, the run
refuses in one line naming the sensor and the difference; the same rig passes."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting
from radarslam.egomotion.car_calibration import (CarCalibration, apply_calibration, read_car_calibration,
                                                 write_car_calibration)
from radarslam.egomotion.same_rig import SAME_POSITION_M, check_same_rig

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data" / "nuscenes_radar"


def _calibration(mountings, yaw_std_deg=0.05):
    ids = tuple(range(len(mountings)))
    return CarCalibration(sensor_ids=ids, yaw_offset_rad=(0.0,) * len(ids),
                          yaw_offset_std=(math.radians(yaw_std_deg),) * len(ids), time_offset_s=(0.0,) * len(ids),
                          time_offset_std=(0.0,) * len(ids), mountings=tuple(mountings))


RIG = [(3.412, 0.0, 0.0035), (2.422, 0.8, 1.5422)]


def _sensors(rig):
    return {j: Mounting(x=x, y=y, yaw=yaw, sensor_id=j) for j, (x, y, yaw) in enumerate(rig)}


def test_the_same_rig_passes_and_a_turned_or_moved_radar_is_refused():
    cal = _calibration(RIG)
    check_same_rig(_sensors(RIG), cal)                                   # the same numbers
    # within 3 std of the yaw offset (0.05 deg): passes; beyond: refused, naming sensor 1 and the angle
    check_same_rig(_sensors([RIG[0], (2.422, 0.8, 1.5422 + math.radians(0.14))]), cal)
    with pytest.raises(InputError, match=r"--calibration: sensor 1: .* 0\.16 deg from its 88\.36 deg"):
        check_same_rig(_sensors([RIG[0], (2.422, 0.8, 1.5422 + math.radians(0.16))]), cal)
    with pytest.raises(InputError, match=r"sensor 0: .* 0\.020 m from its \(3\.412, 0\.000\) m"):
        check_same_rig(_sensors([(3.412, 0.02, 0.0035), RIG[1]]), cal)
    assert SAME_POSITION_M < 0.02
    # a wider calibration explains more: the same 0.16 deg passes a yaw std of 0.1 deg
    check_same_rig(_sensors([RIG[0], (2.422, 0.8, 1.5422 + math.radians(0.16))]), _calibration(RIG, 0.1))
    # a calibration that carries no rig is not checked
    check_same_rig(_sensors([(0.0, 0.0, 1.0), (0.0, 0.0, 2.0)]), dataclasses.replace(cal, mountings=()))


def test_the_rig_survives_the_file(tmp_path):
    cal = _calibration(RIG)
    write_car_calibration(tmp_path / "c.json", cal)
    back = read_car_calibration(tmp_path / "c.json")
    assert back.mountings == cal.mountings
    bad = dataclasses.replace(cal, mountings=cal.mountings[:1])
    write_car_calibration(tmp_path / "bad.json", bad)
    with pytest.raises(InputError, match=r"mountings: expected 2 values \(one per sensor_id\), got 1"):
        read_car_calibration(tmp_path / "bad.json")


@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/nuscenes_radar")
def test_the_other_cars_calibration_is_refused_on_a_real_recording():
    """The Boston car's rig (scene-0655) against the Singapore car's scene-0061: the left radar's
    nominal yaw is 2.32 deg apart; scene-0916, the same car as 0061, passes."""
    from radarslam.io.recording import read_recording

    boston = read_recording(SHARED / "scene-0655")
    cal = _calibration([(m.x, m.y, m.yaw) for _, m in sorted(boston.sensors.items())])
    cal = dataclasses.replace(cal, sensor_ids=tuple(sorted(boston.sensors)))
    with pytest.raises(InputError, match=r"--calibration: sensor 1: expected the calibration's rig, got a nominal yaw "
                                         r"2\.32 deg from its 90\.68 deg"):
        apply_calibration(read_recording(SHARED / "scene-0061"), cal)
    apply_calibration(read_recording(SHARED / "scene-0103"), cal)        # the Boston car's other drive


@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/nuscenes_radar")
@pytest.mark.parametrize("key", ["bias_thrust", "radar_yaw_states", "radar_time_states"])
def test_the_online_car_states_are_refused_under_the_automotive_profile(key, tmp_path):
    """docs/method.md c.13.3: on the given drives the car's online states make every run worse, so a
    recording run under --profile automotive refuses them in one line naming the key and the measured
    reason; filter.online_car_states = "allow" runs them, and another profile is not refused."""
    from helpers import first_seconds

    from radarslam.config import profile_config
    from radarslam.core.errors import ConfigError
    from radarslam.io.recording import read_recording
    from radarslam.runs.recording import run_recording
    from radarslam.runs.stream_run import refuse_online_car_states

    cfg = profile_config("automotive")
    on = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, odometry_bias="states", **{key: True}))
    rec = read_recording(first_seconds(SHARED / "scene-0103", 2.0, tmp_path / "rec"))
    with pytest.raises(ConfigError) as exc:
        run_recording(rec, on)
    msg = str(exc.value)
    assert msg.startswith(f"filter.{key}: refused under profile 'automotive'") and "\n" not in msg
    assert "0.47 -> 2.06 m" in msg and "filter.online_car_states = 'allow'" in msg
    refuse_online_car_states(dataclasses.replace(on, filter=dataclasses.replace(on.filter, online_car_states="allow")))
    assert "filter.car_states = 'consider'" in msg                          # held, not learnt: not refused (c.13.4)
    refuse_online_car_states(dataclasses.replace(on, filter=dataclasses.replace(on.filter, car_states="consider")))
    ref = profile_config("reference")                                      # another profile: not refused
    refuse_online_car_states(dataclasses.replace(ref, filter=dataclasses.replace(ref.filter, odometry_bias="states",
                                                                                 **{key: True})))
    refuse_online_car_states(cfg)                                           # the profile itself runs


@pytest.mark.skipif(not SHARED.is_dir(), reason="needs ../shared/data/nuscenes_radar")
def test_a_truth_calibrations_doppler_scale_replaces_the_configs():
    """docs/method.md c.16.5: under a calibration of reference truth (which brings its own Doppler
    scale) the run is the same whatever ``[sensor] doppler_scale`` says; under one of reference rig
    (no scale of its own) the setting applies, and the run differs (the negative control)."""
    import numpy as np

    from radarslam.config import profile_config
    from radarslam.io.recording import read_recording
    from radarslam.runs.recording import run_recording

    rec = read_recording(SHARED / "scene-0103")
    rig = [(m.x, m.y, m.yaw) for _, m in sorted(rec.sensors.items())]
    base = dataclasses.replace(_calibration(rig), sensor_ids=tuple(sorted(rec.sensors)))
    cfg = profile_config("automotive")
    scaled = dataclasses.replace(cfg, sensor=dataclasses.replace(cfg.sensor, doppler_scale=0.99))
    for reference, same in (("truth", True), ("rig", False)):
        cal = dataclasses.replace(base, reference=reference, doppler_scale=0.995 if reference == "truth" else 1.0)
        a, b = (run_recording(rec, c, calibration=cal).poses for c in (cfg, scaled))
        assert np.array_equal(a, b) is same, reference
        if not same:
            assert np.abs(a[:, :2] - b[:, :2]).max() > 0.01
