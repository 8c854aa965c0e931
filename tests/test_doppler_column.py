"""A recording's Doppler column checked against its odometry (egomotion/doppler_column.py, docs/recordings.md "Doppler").

Oracle: io/recording/synthetic.py's rig of three radars (front, rear, side) driving at 8 m/s and
0.1 rad/s with exact odometry, each detection given the exact static Doppler ``d = -u . w``,
``w = R(-yaw_m) (v - omega l_y, omega l_x)`` (c.10.1). The raw column's consensus is the odometry's
speed (ratio 1 to 1e-6); negated it is -1, zeroed 0, and an ego-compensated column (the static
world at 0 with 0.1 m/s noise) is within 0.1 of 0. On nuScenes scene-0061 the raw column passes,
the negated and the zeroed ones are refused in one line, and ``doppler_sign = -1`` runs the
negated one.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from radarslam.core.errors import InputError
from radarslam.egomotion.doppler_column import check_doppler_column, doppler_consensus, with_doppler_sign
from radarslam.io.recording.mounting import Mounting
from radarslam.io.recording.synthetic import synthetic_recording

from helpers import shared_data

SPEED, TURN = 8.0, 0.1
RIG = {0: Mounting(3.4, 0.0, 0.0, "test", 0, "front"), 1: Mounting(-0.6, 0.6, math.pi, "test", 1, "rear"),
       2: Mounting(2.4, -0.8, -math.pi / 2, "test", 2, "right")}


def _with_doppler(rec):
    """``rec`` with every detection's exact static Doppler (module docstring)."""
    sid = rec.channels["sensor_id"].astype(int)
    d = np.empty(rec.det_t.size)
    for s, m in RIG.items():
        k = sid == s
        wp = np.array([SPEED - TURN * m.y, TURN * m.x])                  # platform axes (c.10.1)
        c, sn = math.cos(m.yaw), math.sin(m.yaw)
        w = np.array([c * wp[0] + sn * wp[1], -sn * wp[0] + c * wp[1]])   # R(-yaw_m) w'
        az = rec.det_polar[k, 1]
        d[k] = -(np.cos(az) * w[0] + np.sin(az) * w[1])
    return dataclasses.replace(rec, channels={**rec.channels, "doppler_mps": d})


@pytest.fixture(scope="module")
def rec():
    return _with_doppler(synthetic_recording(duration_s=4.0, speed_mps=SPEED, turn_rate_rad_s=TURN, sensors=RIG,
                                             returns=2))


def _column(rec, d):
    return dataclasses.replace(rec, channels={**rec.channels, "doppler_mps": d})


def test_the_consensus_of_a_raw_column_is_the_odometrys_speed(rec):
    c = doppler_consensus(rec, None, np.random.default_rng(0))
    assert c.sweeps >= 100 and c.verdict == "raw"
    assert c.ratio == pytest.approx(1.0, abs=1e-6)
    assert c.doppler_mps == pytest.approx(SPEED, abs=1e-5) and c.odometry_mps == pytest.approx(SPEED, abs=1e-9)


def test_negated_zeroed_and_compensated_columns_read_as_such(rec):
    d = rec.channels["doppler_mps"]
    neg = doppler_consensus(_column(rec, -d), None, np.random.default_rng(0))
    assert neg.verdict == "negated" and neg.ratio == pytest.approx(-1.0, abs=1e-6)
    zero = doppler_consensus(_column(rec, np.zeros_like(d)), None, np.random.default_rng(0))
    assert zero.verdict == "compensated" and zero.ratio == 0.0
    comp = _column(rec, 0.1 * np.random.default_rng(5).standard_normal(d.size))
    c = doppler_consensus(comp, None, np.random.default_rng(0))
    assert c.verdict == "compensated" and abs(c.ratio) < 0.1
    with pytest.raises(InputError, match=r"^x/detections.csv: doppler_mps looks negated: the static Doppler "
                       r"consensus gives -8.0 m/s where the odometry says \+8.0 m/s \(\d+ moving scans\); set "
                       r"\[sensor\] doppler_sign = -1 or pass --doppler-sign -1$"):
        check_doppler_column(_column(rec, -d), None, "x/detections.csv")
    with pytest.raises(InputError, match=r"doppler_mps looks ego-compensated .*RadarScenes vr_compensated.*"
                       r"\+0.0 m/s where the odometry says \+8.0 m/s.*expected the raw radial velocity"):
        check_doppler_column(comp, None, "x/detections.csv")
    # the sign stated: the negated column is the raw one again
    assert check_doppler_column(with_doppler_sign(_column(rec, -d), -1), None).verdict == "raw"


def test_a_car_at_rest_is_not_judged(rec):
    still = dataclasses.replace(rec, odo=rec.odo * np.array([0.0, 1.0]))
    assert check_doppler_column(_column(still, -still.channels["doppler_mps"]), None).verdict == "unknown"


def test_scene_0061_negated_or_zeroed_is_refused_by_the_run(tmp_path):
    from radarslam.config import profile_config
    from radarslam.runs.recording import checked_doppler, effective_mounting
    from radarslam.io.recording import read_recording

    src = shared_data() / "nuscenes_radar" / "scene-0061"
    rec = read_recording(src)
    cfg = profile_config("automotive")
    m = effective_mounting(rec, cfg)
    assert checked_doppler(rec, cfg, m) is rec                          # raw: as before, no word
    neg = with_doppler_sign(rec, -1)
    with pytest.raises(InputError, match=r"scene-0061/detections.csv: doppler_mps looks negated: the static "
                       r"Doppler consensus gives -\d\.\d m/s where the odometry says \+\d\.\d m/s"):
        checked_doppler(neg, cfg, m)
    with pytest.raises(InputError, match="doppler_mps looks ego-compensated"):
        checked_doppler(_column(rec, np.zeros_like(rec.channels["doppler_mps"])), cfg, m)
    signed = dataclasses.replace(cfg, sensor=dataclasses.replace(cfg.sensor, doppler_sign=-1))
    back = checked_doppler(neg, signed, m)
    np.testing.assert_array_equal(back.channels["doppler_mps"], rec.channels["doppler_mps"])


def test_the_cli_refuses_a_negated_column_in_one_line_and_takes_doppler_sign(tmp_path, capsys):
    from radarslam.cli.main import main
    from radarslam.io.recording.plain import write_plain

    rec = synthetic_recording(duration_s=3.0, speed_mps=SPEED, turn_rate_rad_s=TURN, sensors=RIG, returns=2)
    rec = _with_doppler(rec)
    rec = _column(rec, -rec.channels["doppler_mps"])
    (tmp_path / "rec").mkdir()
    write_plain(rec, tmp_path / "rec")
    args = ["run", "--recording", str(tmp_path / "rec"), "--profile", "automotive", "--backend", "python"]
    assert main(args + ["--out", str(tmp_path / "a")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "detections.csv: doppler_mps looks negated" in err[0] and "--doppler-sign -1" in err[0]
    assert not (tmp_path / "a" / "run.json").exists()
    assert main(args + ["--doppler-sign", "-1", "--out", str(tmp_path / "b")]) == 0
    assert (tmp_path / "b" / "run.json").exists()


def test_a_scaled_column_is_divided_by_its_doppler_scale(rec):
    """``[sensor] doppler_scale`` (docs/method.md c.16.5): a column reading 0.99 of the radial speed,
    divided by 0.99 when read, is the exact column again, and its consensus the odometry's speed;
    left at 1 (the negative control) it reads 1% low. Out of range: refused in one line."""
    from radarslam.config import profile_config
    from radarslam.runs.recording import checked_doppler

    exact = rec.channels["doppler_mps"]
    low = _column(rec, 0.99 * exact)
    cfg = profile_config()
    fixed = checked_doppler(low, dataclasses.replace(cfg, sensor=dataclasses.replace(cfg.sensor, doppler_scale=0.99)),
                            None)
    np.testing.assert_allclose(fixed.channels["doppler_mps"], exact, rtol=1e-12)
    assert doppler_consensus(fixed, None, np.random.default_rng(0)).ratio == pytest.approx(1.0, abs=1e-6)
    assert doppler_consensus(checked_doppler(low, cfg, None), None, np.random.default_rng(0)).ratio == \
        pytest.approx(0.99, abs=1e-6)
    for bad in (0.0, -1.0, math.nan):
        with pytest.raises(InputError, match=r"^sensor.doppler_scale: expected a finite number > 0, got "):
            from radarslam.egomotion.doppler_column import with_doppler_scale
            with_doppler_scale(low, bad)
