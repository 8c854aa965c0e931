"""scripts/car_error_sources.py: its "prediction only" form confirms no landmark, so that the filter's
pose is its own dead reckoning, and each part of a calibration keeps its group of values and only it.

Oracle: io/recording/synthetic.py's car (exact odometry, reflectors returning six detections a scan
with 0.1 m / 0.005 rad noise, seed 1) run under the automotive profile with the odometer and without
the Doppler gate (the synthetic recording has no Doppler column): without a map its pose is the
odometry's dead reckoning to rounding, which is exact here (< 1e-9 m); the same run with the map
(the negative control) confirms landmarks and moves off it by the map's noise (> 1 mm).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from radarslam.egomotion.car_calibration import CarCalibration
from radarslam.io.recording.synthetic import synthetic_recording
from radarslam.runs.recording import run_recording

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))

import car_error_sources  # noqa: E402

PLAIN = {"filter": {"doppler_gate": False, "odometry": "odometer"}}


def test_prediction_only_is_the_dead_reckoning():
    rec = synthetic_recording(duration_s=4.0, returns=6, range_std_m=0.1, azimuth_std_rad=0.005,
                              rng=np.random.default_rng(1))
    no_map = run_recording(rec, car_error_sources._config({**PLAIN, **car_error_sources.NO_MAP})).metrics
    mapped = run_recording(rec, car_error_sources._config(PLAIN)).metrics
    assert no_map["landmarks_final"] == 0 and no_map["position_rmse_m"] < 1e-9, no_map["position_rmse_m"]
    assert no_map["dead_reckoning"]["position_rmse_m"] < 1e-9
    assert mapped["landmarks_final"] > 5 and mapped["position_rmse_m"] > 1e-3, mapped["position_rmse_m"]


def test_each_part_keeps_its_group_only():
    cal = CarCalibration(thrust_angle_rad=0.01, wheel_scale=1.02, gyro_bias_rad_s=0.003, sensor_ids=(0, 1),
                         yaw_offset_rad=(0.02, -0.02), time_offset_s=(0.05, -0.01), doppler_scale=0.995)
    parts = car_error_sources._parts(cal)
    assert parts["own calibration"] is cal
    yaw, clocks, car = parts["own: yaw only"], parts["own: clocks only"], parts["own: car only"]
    assert yaw.yaw_offset_rad == (0.02, -0.02) and yaw.time_offset_s == (0.0, 0.0)
    assert clocks.time_offset_s == (0.05, -0.01) and clocks.yaw_offset_rad == (0.0, 0.0)
    for p in (yaw, clocks):
        assert (p.thrust_angle_rad, p.wheel_scale, p.doppler_scale) == (0.0, 1.0, 1.0)
    assert (car.thrust_angle_rad, car.wheel_scale, car.doppler_scale) == (0.01, 1.02, 0.995)
    assert car.yaw_offset_rad == (0.0, 0.0) and car.time_offset_s == (0.0, 0.0)
