"""A multi-radar rig in the plain format: ``sensors.csv`` read into each
detection's own mounting, refused in one line when malformed; the ``label`` and ``scan`` columns
read apart from what reaches the filter; all of it written back bit for bit."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from radarslam.cli.main import main
from radarslam.core.errors import InputError
from radarslam.core.types import Scan
from radarslam.io.recording.mounting import Mounting, detections_to_platform
from radarslam.io.recording.plain import read_plain, write_plain
from radarslam.io.recording.stream import to_events

SENSORS = "sensor_id,x_m,y_m,yaw_rad,name\n0,3.5,0,0,front\n1,-1.0,0,3.14159,rear\n"
ODO = "t_s,speed_mps,yaw_rate_rad_s\n0,1,0\n0.1,1,0\n"
DET = "t_s,range_m,azimuth_rad,sensor_id\n0,5,0,1\n0,4,0.1,0\n0.1,5,0,1\n"


def _rec(tmp_path: Path, det: str = DET, sensors: str | None = SENSORS, odo: str = ODO) -> Path:
    d = tmp_path / "rec"
    d.mkdir(parents=True, exist_ok=True)
    (d / "detections.csv").write_text(det)
    (d / "odometry.csv").write_text(odo)
    if sensors is not None:
        (d / "sensors.csv").write_text(sensors)
    return d


def _platform(scan: Scan) -> np.ndarray:
    """A scan's detections about the platform origin: moved by its radar's mounting (``Scan.sensor``,
    docs/method.md c.13; the scan itself stays in the radar's frame)."""
    m = scan.sensor
    return scan.polar if m is None else detections_to_platform(scan.polar, Mounting(m.x, m.y, m.yaw))


def _at_zero(events) -> Scan:
    """The detections of every scan at t = 0 (one scan per sensor) as one, about the platform origin."""
    scans = [e for e in events if isinstance(e, Scan) and e.t == 0.0]
    return Scan(0.0, 1, np.concatenate([_platform(s) for s in scans]),
                {"sensor_id": np.concatenate([s.channels["sensor_id"] for s in scans])})


def test_a_rear_radars_reflector_lands_behind_the_car(tmp_path):
    """A rear radar (1 m behind the axle, looking back) sees a reflector 5 m ahead
    of it: 6 m behind the platform, not ahead. The front radar's at 3.5 + 4 m ahead."""
    rec = read_plain(_rec(tmp_path))
    assert set(rec.sensors) == {0, 1} and rec.sensors[1].name == "rear" and rec.sensors[0].x == 3.5
    first = _at_zero(to_events(rec, Mounting()))
    rear = first.polar[first.channels["sensor_id"] == 1][0]
    assert rear[0] == pytest.approx(6.0, abs=1e-4) and abs(abs(rear[1]) - math.pi) < 1e-4
    front = first.polar[first.channels["sensor_id"] == 0][0]
    x, y = front[0] * math.cos(front[1]), front[0] * math.sin(front[1])
    assert x == pytest.approx(3.5 + 4 * math.cos(0.1)) and y == pytest.approx(4 * math.sin(0.1))


def test_negative_control_the_single_mounting_puts_the_rear_reflector_ahead(tmp_path):
    """The old reading (sensors.csv ignored, one mounting for all) places it ahead: the test above fails on it."""
    rec = read_plain(_rec(tmp_path))
    rec.sensors = None
    first = _at_zero(to_events(rec, Mounting()))
    rear = first.polar[first.channels["sensor_id"] == 1][0]
    assert abs(rear[1]) < 1e-9 and rear[0] == 5.0


def test_a_single_sensor_at_zero_is_bit_identical_to_no_sensors_csv(tmp_path):
    det = "t_s,range_m,azimuth_rad,sensor_id\n0,5.25,0.3,0\n0.1,7.125,-0.2,0\n"
    a = to_events(read_plain(_rec(tmp_path / "a", det, None)), Mounting())
    b = to_events(read_plain(_rec(tmp_path / "b", det, "sensor_id,x_m,y_m,yaw_rad,name\n0,0,0,0,only\n")), Mounting())
    sa, sb = [e for e in a if isinstance(e, Scan)], [e for e in b if isinstance(e, Scan)]
    assert len(sa) == len(sb) and all(np.array_equal(p.polar, q.polar) for p, q in zip(sa, sb))


def test_one_sensor_needs_no_sensor_id_column(tmp_path):
    rec = read_plain(_rec(tmp_path, "t_s,range_m,azimuth_rad\n0,5,0\n",
                          "sensor_id,x_m,y_m,yaw_rad\n3,1.0,0,0\n"))
    ev = to_events(rec, Mounting())
    assert ev[0].sensor.x == 1.0 and ev[0].polar[0, 0] == 5.0       # in the radar's frame, its mounting beside
    assert _platform(ev[0])[0, 0] == pytest.approx(6.0) and rec.sensors[3].name == ""


def test_label_and_scan_columns_are_read_and_never_reach_the_filter(tmp_path):
    det = "t_s,range_m,azimuth_rad,sensor_id,label,scan\n0,5,0,1,11,0\n0,4,0.1,0,0,1\n0.1,5,0,1,11,2\n"
    rec = read_plain(_rec(tmp_path, det))
    assert rec.labels.tolist() == [11, 0, 11] and rec.det_scan.tolist() == [0, 1, 2]
    assert rec.labels.dtype == np.int64
    for e in to_events(rec, Mounting()):
        if isinstance(e, Scan):
            assert "label" not in (e.channels or {}) and "scan" not in (e.channels or {})


@pytest.mark.parametrize("npz", [False, True])
def test_sensors_labels_and_scans_are_written_back_bit_for_bit(tmp_path, npz):
    det = "t_s,range_m,azimuth_rad,sensor_id,label,scan\n0,5,0,1,11,0\n0,4,0.1,0,0,1\n0.1,5,0,1,11,2\n"
    sensors = 'sensor_id,x_m,y_m,yaw_rad,name,max_range_m,fov_deg\n0,3.5,0.25,0.1,"front, long",250,20\n' \
              "1,-1.0,0,3.14159,rear,80,150\n"
    rec = read_plain(_rec(tmp_path, det, sensors))
    out = tmp_path / "o.npz" if npz else tmp_path / "o"
    if not npz:
        out.mkdir()
    write_plain(rec, out)
    back = read_plain(out)
    assert back.labels.tolist() == rec.labels.tolist() and back.det_scan.tolist() == rec.det_scan.tolist()
    for k, m in rec.sensors.items():
        b = back.sensors[k]
        assert (b.x, b.y, b.yaw, b.name, b.max_range_m, b.fov_rad) == (m.x, m.y, m.yaw, m.name, m.max_range_m,
                                                                       m.fov_rad)
    assert rec.sensors[0].name == "front, long" and rec.sensors[1].fov_rad == pytest.approx(math.radians(150))


MALFORMED = {
    "missing_column": ("sensor_id,x_m,yaw_rad,name\n0,1,0,f\n", DET,
                       r"sensors.csv: missing column\(s\) y_m"),
    "duplicate_id": ("sensor_id,x_m,y_m,yaw_rad,name\n0,1,0,0,a\n1,0,0,0,b\n0,2,0,0,c\n", DET,
                     r"sensors.csv line 4 column sensor_id: expected each sensor once, got 0 again"),
    "nan": ("sensor_id,x_m,y_m,yaw_rad,name\n0,1,nan,0,a\n1,0,0,0,b\n", DET,
            r"sensors.csv line 2 column y_m: expected a finite number, got nan"),
    "degrees": ("sensor_id,x_m,y_m,yaw_rad,name\n0,1,0,0,a\n1,0,0,180,b\n", DET,
                r"sensors.csv line 3 column yaw_rad: expected radians .*degrees\?"),
    "not_an_id": ("sensor_id,x_m,y_m,yaw_rad,name\n0.5,1,0,0,a\n", DET,
                  r"sensors.csv line 2 column sensor_id: expected a whole number >= 0, got 0.5"),
    "fov": ("sensor_id,x_m,y_m,yaw_rad,name,fov_deg\n0,1,0,0,a,0\n1,0,0,0,b,90\n", DET,
            r"sensors.csv line 2 column fov_deg: expected a full opening angle in \(0, 360\]"),
    "range": ("sensor_id,x_m,y_m,yaw_rad,max_range_m\n0,1,0,0,-3\n1,0,0,0,5\n", DET,
              r"sensors.csv line 2 column max_range_m: expected a range > 0, got -3.0"),
    "unknown_sensor": (SENSORS, "t_s,range_m,azimuth_rad,sensor_id\n0,5,0,1\n0,4,0.1,7\n",
                       r"detections.csv line 3 column sensor_id: expected one of sensors.csv's 0, 1, got 7.0"),
    "no_sensor_column": (SENSORS, "t_s,range_m,azimuth_rad\n0,5,0\n",
                         r"detections.csv: expected a sensor_id column \(sensors.csv has 2 sensors: 0, 1\), got none"),
    "empty": ("sensor_id,x_m,y_m,yaw_rad\n", DET, r"sensors.csv: expected one row per radar, got none"),
    "label_not_whole": (SENSORS, "t_s,range_m,azimuth_rad,sensor_id,label\n0,5,0,1,11\n0,4,0.1,0,2.5\n",
                        r"detections.csv line 3 column label: expected a whole number >= 0, got 2.5"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED))
def test_malformed_sensors_are_refused_in_one_line_and_nothing_is_written(tmp_path, capsys, case):
    sensors, det, pattern = MALFORMED[case]
    d = _rec(tmp_path, det, sensors)
    out = tmp_path / "out"
    assert main(["run", "--recording", str(d), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and re.search(pattern, err), err
    assert not out.exists()


def test_malformed_npz_sensors_name_the_table_and_row(tmp_path):
    f = tmp_path / "r.npz"
    np.savez(f, **{"detections.t_s": np.zeros(2), "detections.range_m": np.ones(2),
                   "detections.azimuth_rad": np.zeros(2),
                   "detections.sensor_id": np.array([0, 5]), "odometry.t_s": np.array([0.0, 0.1]),
                   "odometry.speed_mps": np.ones(2), "odometry.yaw_rate_rad_s": np.zeros(2),
                   "sensors.sensor_id": np.array([0]), "sensors.x_m": np.ones(1), "sensors.y_m": np.zeros(1),
                   "sensors.yaw_rad": np.zeros(1), "sensors.name": np.array(["front"])})
    with pytest.raises(InputError, match=r"table detections row 2 column sensor_id: expected one of sensors.csv's 0"):
        read_plain(f)
