"""The truth's anchor of a calibration (docs/method.md c.16.2) holds: the priors and the anchor are
Gaussian terms, not robust ones, and the truth's turn against the gyro fixes the gyro's bias. On
scene-0916 the sweeps pulled the gyro's bias to -1.01 deg/s (the truth says -0.04) and the wheel scale
to 1.0346 (the truth 1.0088 +- 0.0022), and the Singapore car's calibration carried that scale to
scene-0061."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import shared_data
from scipy.optimize._lsq.least_squares import IMPLEMENTED_LOSSES

from radarslam.egomotion.car_calibration import ROBUST_SCALE, robust_sweeps_loss


def test_the_loss_is_soft_l1_on_the_sweeps_and_squares_on_the_rest():
    z = np.linspace(0.0, 400.0, 9) ** 2
    rho = robust_sweeps_loss(5)(np.r_[z, z])
    c2 = ROBUST_SCALE ** 2
    soft = np.empty((3, z.size))
    IMPLEMENTED_LOSSES["soft_l1"](z / c2, soft, cost_only=False)   # scipy's own, at f_scale = ROBUST_SCALE
    np.testing.assert_allclose(rho[0, :5], c2 * soft[0, :5], rtol=1e-12)
    np.testing.assert_allclose(rho[1, :5], soft[1, :5], rtol=1e-12)
    np.testing.assert_allclose(rho[2, :5], soft[2, :5] / c2, rtol=1e-12)
    np.testing.assert_array_equal(rho[0, 5:], np.r_[z, z][5:])           # the priors and the anchor: squares
    np.testing.assert_array_equal(rho[1, 5:], 1.0)
    np.testing.assert_array_equal(rho[2, 5:], 0.0)
    h = 1e-3                                                              # rho' and rho'' by central differences
    zz = np.array([0.5, 7.0, 90.0])
    f = robust_sweeps_loss(3)
    np.testing.assert_allclose((f(zz + h)[0] - f(zz - h)[0]) / (2 * h), f(zz)[1], rtol=1e-6)
    np.testing.assert_allclose((f(zz + h)[1] - f(zz - h)[1]) / (2 * h), f(zz)[2], rtol=1e-5)


def test_the_truths_turn_fixes_the_gyros_bias_on_scene_0916():
    pytest.importorskip("numba")
    from radarslam.egomotion.car_calibration import calibrate_car
    from radarslam.egomotion.calibration_truth import truth_doppler_scale, truth_motion
    from radarslam.egomotion.rig import read_rig
    from radarslam.io.recording import read_recording

    path = shared_data() / "nuscenes_radar" / "scene-0916"
    rec, rig = read_recording(path), read_rig(path)
    anchor = truth_motion(rec.truth_t, rec.truth, np.column_stack([rec.odo_t, rec.odo]))
    assert abs(math.degrees(anchor[4])) < 0.2                             # a gyro within a fifth of a deg/s
    cal = calibrate_car(rig, np.random.default_rng(0), truth=(rec.truth_t, rec.truth))
    tol = 3.0 * math.hypot(anchor[5], cal.gyro_bias_std)
    assert abs(cal.gyro_bias_rad_s - anchor[4]) < tol                     # before: -1.01 deg/s, 6 tol away
    assert abs(cal.wheel_scale - anchor[2]) < 3 * math.hypot(anchor[3], cal.wheel_scale_std)   # before: 0.026 off
    g_truth = truth_doppler_scale(rig, np.random.default_rng(0), rec.truth_t, rec.truth)
    assert abs(cal.doppler_scale - g_truth[0]) < 3 * g_truth[1]           # before: 0.9692, 0.9938 by the truth
    rig_ref = calibrate_car(rig, np.random.default_rng(0))                 # negative control: no truth, no anchor
    assert abs(rig_ref.gyro_bias_rad_s - anchor[4]) > 5 * tol       # -1.09 deg/s


def test_the_truths_reference_recovers_a_doppler_scale_and_a_run_divides_it_out():
    """A synthetic drive whose radars read the speed 0.5% low (a 2-D radar's cos(el)): with the truth's
    reference the calibration finds it and the wheel scale together (they are 0.99 correlated through
    the sweeps alone), and a run with the calibration divides the Doppler column by it."""
    pytest.importorskip("numba")
    import dataclasses

    from car_drive import TRUE, drive, truth

    from radarslam.egomotion.car_calibration import apply_calibration, calibrate_car
    from radarslam.io.recording.stream import Recording

    true = {**TRUE, "doppler_scale": 0.995}
    rig = drive(seed=2, true=true)
    cal = calibrate_car(rig, np.random.default_rng(0), truth=truth())
    assert cal.reference == "truth"
    assert abs(cal.doppler_scale - 0.995) < 1e-3 and abs(cal.wheel_scale - TRUE["wheel_scale"]) < 1e-3
    assert abs(cal.thrust_angle_rad - TRUE["thrust_angle_rad"]) < math.radians(0.1)
    np.testing.assert_allclose(cal.yaw_offset_rad, TRUE["yaw_offset_rad"], rtol=0, atol=math.radians(0.1))
    rot = cal.parameter_values[cal.parameters.index("rotation_scale_minus_1")]
    assert abs(rot) < 3 * math.sqrt(np.array(cal.covariance)[cal.parameters.index("rotation_scale_minus_1")][
        cal.parameters.index("rotation_scale_minus_1")]) + 1e-3          # nothing to absorb here
    plain = calibrate_car(drive(seed=2), np.random.default_rng(0), truth=truth())   # negative control: no scale
    assert abs(plain.doppler_scale - 1.0) < 1e-3
    rec = Recording(rig.t, np.column_stack([rig.range_m, rig.azimuth]),
                    {"doppler_mps": rig.doppler.copy(), "sensor_id": rig.sensor.astype(float)},
                    rig.odometry[:, 0], rig.odometry[:, 1:], "unicycle")
    out = apply_calibration(rec, dataclasses.replace(cal, time_offset_s=(0.0,) * 5))
    np.testing.assert_allclose(out.channels["doppler_mps"], rec.channels["doppler_mps"] / cal.doppler_scale)
