"""No silent degradation of a recording: detections grouped into scans as the
sensor made them, zero-range returns dropped with a count, an unwrapped truth yaw accepted, and
every shared recording run with every gate and odometry option (nothing ends in a traceback)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from helpers import first_seconds, shared_data
from radarslam.cli.main import main
from radarslam.core.types import Scan
from radarslam.io.recording import plain
from radarslam.io.recording.mounting import Mounting
from radarslam.io.recording.plain import read_plain, write_plain
from radarslam.io.recording.stream import Recording, stream_events

ODO = "t_s,speed_mps,yaw_rate_rad_s\n0,1,0\n1,1,0\n"


def _scans(rec):
    events, report = stream_events(rec, Mounting())
    return [e for e in events if isinstance(e, Scan)], report


def _rec(t, sid=None, scan=None, r=None):
    t = np.asarray(t, dtype=float)
    ch = {} if sid is None else {"sensor_id": np.asarray(sid, dtype=float)}
    polar = np.column_stack([np.full(t.size, 5.0) if r is None else r, np.linspace(-1, 1, t.size)])
    return Recording(t, polar, ch, np.array([0.0, 3.0]), np.ones((2, 2)), "unicycle", source="rec",
                     det_scan=None if scan is None else np.asarray(scan))


def test_two_sensors_at_one_time_are_two_scans():
    """A scan is one sensor's detections at one time: grouped by (t_s, sensor_id); the old grouping
    by time alone (the negative control: one sensor for all) made one scan of both radars."""
    scans, _ = _scans(_rec([0.1, 0.1, 0.1, 0.2], sid=[1, 0, 1, 0]))
    assert [(s.t, s.channels["sensor_id"].tolist()) for s in scans] == [(0.1, [0.0]), (0.1, [1.0, 1.0]), (0.2, [0.0])]
    old, _ = _scans(_rec([0.1, 0.1, 0.1, 0.2]))
    assert [s.polar.shape[0] for s in old] == [3, 1]


def test_detections_stamped_one_by_one_are_grouped_by_their_scan_column_or_warned_about():
    """The issue's 4427 one-detection scans: detections 0.1 ms apart. With a scan column they form
    their scans (at the mean time of each); without it, one warning line with the counts."""
    t = 0.1 * np.repeat(np.arange(20), 10) + 1e-4 * np.tile(np.arange(10), 20)
    alone, report = _scans(_rec(t))
    assert len(alone) == 200 and report.single_detection_scans == 200
    assert len(report.notes) == 1 and "200 of 200 scans hold one detection" in report.notes[0]
    grouped, report = _scans(_rec(t, scan=np.repeat(np.arange(20), 10)))
    assert len(grouped) == 20 and all(s.polar.shape[0] == 10 for s in grouped) and report.notes == []
    assert grouped[3].t == pytest.approx(0.3 + 4.5e-4)


def test_scan_column_is_read_from_the_plain_format(tmp_path):
    d = tmp_path / "r"
    d.mkdir()
    (d / "detections.csv").write_text("t_s,range_m,azimuth_rad,scan\n0.1,5,0,7\n0.1001,6,0,7\n0.2,5,0,8\n")
    (d / "odometry.csv").write_text(ODO)
    scans, _ = _scans(read_plain(d))
    assert [s.polar.shape[0] for s in scans] == [2, 1]


def test_zero_range_detections_are_dropped_and_counted(tmp_path):
    """Many drivers' invalid returns; they would become landmarks at the sensor (the negative
    control: the old stream kept them)."""
    rec = _rec([0.1, 0.1, 0.1, 0.2, 0.2], r=[0.0, 5.0, 0.0, 6.0, 7.0])
    scans, report = _scans(rec)
    assert report.zero_range == 2 and [s.polar.shape[0] for s in scans] == [1, 2]
    assert np.all(np.concatenate([s.polar[:, 0] for s in scans]) > 0)
    assert len(report.notes) == 1 and "2 of 5 detections at range 0" in report.notes[0]
    write_plain(rec, tmp_path)
    out = tmp_path / "out"
    assert main(["run", "--recording", str(tmp_path), "--backend", "python", "--out", str(out)]) == 0
    assert json.loads((out / "metrics.json").read_text())["zero_range_dropped"] == 2


def test_an_unwrapped_truth_yaw_is_accepted_and_wrapped(tmp_path):
    """7 rad after a full turn is radians, not degrees; azimuth, yaw rate and steering keep the check."""
    d = tmp_path / "r"
    d.mkdir()
    (d / "detections.csv").write_text("t_s,range_m,azimuth_rad\n0,5,0\n")
    (d / "odometry.csv").write_text(ODO)
    (d / "truth.csv").write_text("t_s,x_m,y_m,yaw_rad\n0,0,0,6.9\n1,1,0,7.0\n")
    rec = read_plain(d)
    np.testing.assert_allclose(rec.truth[:, 2], [6.9 - 2 * np.pi, 7.0 - 2 * np.pi], atol=1e-12)
    (d / "odometry.csv").write_text("t_s,speed_mps,yaw_rate_rad_s\n0,1,0\n1,1,7.0\n")
    with pytest.raises(plain.InputError, match="column yaw_rate_rad_s: expected radians"):
        read_plain(d)


def test_negative_control_the_old_angle_check_refuses_an_unwrapped_truth(tmp_path, monkeypatch):
    d = tmp_path / "r"
    d.mkdir()
    (d / "detections.csv").write_text("t_s,range_m,azimuth_rad\n0,5,0\n")
    (d / "odometry.csv").write_text(ODO)
    (d / "truth.csv").write_text("t_s,x_m,y_m,yaw_rad\n0,0,0,6.9\n1,1,0,7.0\n")
    monkeypatch.setattr(plain, "UNWRAPPED", ())
    with pytest.raises(plain.InputError, match="degrees"):
        read_plain(d)


# ------------------------------------------------------------------------------------------------
# Every shared recording, every gate and odometry option: a run, never a traceback
# ------------------------------------------------------------------------------------------------
RECORDINGS = [("nuscenes_radar/scene-0061", 10.0), ("nuscenes_radar/scene-0103", 10.0),
              ("nuscenes_radar/scene-0655", 10.0), ("nuscenes_radar/scene-0916", 10.0),
              ("radarscenes/sequence_105", 3.0)]
OPTIONS = {"default": "", "doppler_gate": "[filter]\ndoppler_gate = true\n",
           "doppler_odometry": "[filter]\nodometry = \"doppler\"\n"}


@pytest.fixture(scope="module")
def shared_recordings(tmp_path_factory):
    shared = shared_data()
    base = tmp_path_factory.mktemp("shared")
    return {name: first_seconds(shared / name, s, base / name.replace("/", "_")) for name, s in RECORDINGS}


@pytest.mark.parametrize("option", sorted(OPTIONS))
@pytest.mark.parametrize("name", [n for n, _ in RECORDINGS])
def test_every_shared_recording_runs_with_every_option(shared_recordings, tmp_path, capsys, name, option):
    """The issue's crash: scene-0655 and scene-0916 with filter.doppler_gate ended in a
    ZeroDivisionError (a scan's Doppler fit with no residual spread)."""
    cfg = tmp_path / "c.toml"
    cfg.write_text(OPTIONS[option])
    out = tmp_path / "out"
    assert main(["run", "--recording", str(shared_recordings[name]), "--config", str(cfg), "--backend", "python",
                 "--out", str(out)]) == 0, capsys.readouterr().err
    m = json.loads((out / "metrics.json").read_text())
    assert m["scans"] > 0 and np.isfinite(m["filter_seconds"])
