"""RadarScenes read in its official layout (``radarslam.io.datasets.radarscenes``, docs/datasets.md
"nuScenes and RadarScenes in their official layouts").

Sequence 105 is written, in a temporary folder, in the dataset's own layout (``data/sensors.json``,
``data/sequence_105/scenes.json`` and ``radar_data.h5`` with its ``radar_data`` and ``odometry``
tables) from its plain conversion (``../shared/data/radarscenes/sequence_105``), and read back: the
plain conversion's event stream, from the raw ``vr`` (the ego-compensated ``vr_compensated`` written
beside it, 5 m/s off, never reaches it). The data's licence keeps every file out of the repository.
"""

from __future__ import annotations

import json
import sys

import numpy as np
import pytest

from helpers import one_line_message, shared_data
from radarslam.core.errors import DataError, InputError
from radarslam.core.mounting import Mounting
from radarslam.core.types import Odometry
from radarslam.io.recording.plain import read_plain
from radarslam.io.recording.stream import stream_events

h5py = pytest.importorskip("h5py")

from radarslam.io.datasets.radarscenes import read_radarscenes  # noqa: E402

#: An epoch for the sequence's microsecond timestamps (RadarScenes': arbitrary per sequence).
EPOCH_US = 1_523_455_000_000_000
RADAR_DTYPE = np.dtype([("timestamp", "<u8"), ("sensor_id", "u1"), ("range_sc", "<f8"), ("azimuth_sc", "<f8"),
                        ("rcs", "<f8"), ("vr", "<f8"), ("vr_compensated", "<f8"), ("x_cc", "<f4"), ("y_cc", "<f4"),
                        ("x_seq", "<f4"), ("y_seq", "<f4"), ("uuid", "S32"), ("track_id", "S32"), ("label_id", "u1")])
ODOMETRY_DTYPE = np.dtype([("timestamp", "<u8"), ("x_seq", "<f8"), ("y_seq", "<f8"), ("yaw_seq", "<f8"),
                           ("vx", "<f8"), ("yaw_rate", "<f8")])


def write_sequence(root, plain, name: str = "sequence_105", radar_fields=None) -> None:
    """``plain`` in the RadarScenes layout under ``root/data``. The odometry table holds the plain
    rows and, between each two, a row at their mean time (not paired with any scan); each scan of
    scenes.json is paired with its nearest plain row, as the plain conversion's export paired them."""
    data = root / "data"
    folder = data / name
    folder.mkdir(parents=True)
    (data / "sensors.json").write_text(json.dumps(
        {f"radar_{k + 1}": {"id": k + 1, "x": m.x, "y": m.y, "yaw": m.yaw} for k, m in plain.sensors.items()}))
    ts = EPOCH_US + np.round(plain.det_t * 1e6).astype(np.int64)
    radar = np.zeros(plain.det_t.size, dtype=RADAR_DTYPE)
    radar["timestamp"], radar["sensor_id"] = ts, plain.channels["sensor_id"].astype(np.uint8) + 1
    radar["range_sc"], radar["azimuth_sc"] = plain.det_polar[:, 0], plain.det_polar[:, 1]
    radar["rcs"], radar["vr"] = plain.channels["rcs"], plain.channels["doppler_mps"]
    radar["vr_compensated"] = plain.channels["doppler_mps"] + 5.0           # a negative control: never read
    radar["label_id"] = plain.labels
    radar["track_id"] = np.where(plain.labels == 11, b"", b"00000000000000000000000000000001")
    ot = EPOCH_US + np.round(plain.odo_t * 1e6).astype(np.int64)
    odo = np.zeros(2 * ot.size - 1, dtype=ODOMETRY_DTYPE)
    odo["timestamp"][0::2], odo["vx"][0::2], odo["yaw_rate"][0::2] = ot, plain.odo[:, 0], plain.odo[:, 1]
    odo["timestamp"][1::2] = (ot[:-1] + ot[1:]) // 2
    odo["vx"][1::2], odo["yaw_rate"][1::2] = 0.5 * (plain.odo[:-1, 0] + plain.odo[1:, 0]), -1.0
    if radar_fields is not None:
        radar = radar[list(radar_fields)]
    with h5py.File(folder / "radar_data.h5", "w") as f:
        f.create_dataset("radar_data", data=radar)
        f.create_dataset("odometry", data=odo)
    scan_ts, starts = np.unique(ts, return_index=True)
    ends = np.r_[starts[1:], ts.size]
    j = np.clip(np.searchsorted(ot, scan_ts), 1, ot.size - 1)
    near = np.where(scan_ts - ot[j - 1] <= ot[j] - scan_ts, j - 1, j)
    scenes = {str(t): {"sensor_id": int(radar["sensor_id"][a]), "odometry_index": int(2 * n),
                       "odometry_timestamp": int(ot[n]), "radar_indices": [int(a), int(b)], "image_name": f"{t}.jpg"}
              for t, a, b, n in zip(scan_ts.tolist(), starts, ends, near)}
    (folder / "scenes.json").write_text(json.dumps({"sequence_name": name, "category": "train",
                                                    "first_timestamp": int(scan_ts[0]),
                                                    "last_timestamp": int(scan_ts[-1]), "scenes": scenes}))


@pytest.fixture(scope="module")
def plain():
    return read_plain(shared_data() / "radarscenes" / "sequence_105")


@pytest.fixture(scope="module")
def dataset(plain, tmp_path_factory):
    root = tmp_path_factory.mktemp("radarscenes")
    write_sequence(root, plain)
    return root


def test_the_official_layout_reads_to_the_plain_conversion(plain, dataset):
    rec = read_radarscenes(dataset, 105)
    assert rec.det_t.size == 1_071_716 and np.unique(rec.det_t).size == 6478
    np.testing.assert_array_equal(rec.det_t, plain.det_t)
    np.testing.assert_array_equal(rec.det_polar, plain.det_polar)
    assert rec.channels.keys() == plain.channels.keys() == {"doppler_mps", "rcs", "sensor_id"}
    for c in rec.channels:
        np.testing.assert_array_equal(rec.channels[c], plain.channels[c])
    np.testing.assert_array_equal(rec.labels, plain.labels)
    assert np.mean(rec.labels == 11) > 0.97                               # the static world, as SOURCE.md says
    np.testing.assert_array_equal(rec.odo_t, plain.odo_t)                 # only the rows the scans are paired with
    np.testing.assert_array_equal(rec.odo, plain.odo)
    assert rec.odo.shape == (5368, 2) and rec.odo_kind == "unicycle"
    assert rec.truth is None and plain.truth is None and rec.t0_ns == EPOCH_US * 1000
    assert sorted(rec.sensors) == [0, 1, 2, 3]
    for k, m in rec.sensors.items():
        p = plain.sensors[k]
        assert (m.x, m.y, m.yaw, m.sensor_id, m.name) == (p.x, p.y, p.yaw, p.sensor_id, p.name)
    # the raw radial velocity, never the compensated one written beside it
    assert np.all(rec.channels["doppler_mps"] != plain.channels["doppler_mps"] + 5.0)


def test_the_event_stream_is_the_plain_conversions(plain, dataset):
    ev, report = stream_events(read_radarscenes(dataset, "sequence_105"), Mounting())
    ev_plain, report_plain = stream_events(plain, Mounting())
    assert (report.scans, report.detections, report.dropped_scans, report.zero_range) == (
        report_plain.scans, report_plain.detections, report_plain.dropped_scans, report_plain.zero_range)
    assert report.scans > 6400
    assert [type(e) for e in ev] == [type(e) for e in ev_plain]
    for a, b in zip(ev, ev_plain):
        assert a.t == b.t
        if isinstance(a, Odometry):
            assert (a.dt, a.gyro_rad_s) == (b.dt, b.gyro_rad_s) and np.array_equal(a.control, b.control)
        else:
            assert a.index == b.index and np.array_equal(a.polar, b.polar)
            assert (a.sensor.x, a.sensor.y, a.sensor.yaw, a.sensor.sensor_id, a.sensor.name) == (
                b.sensor.x, b.sensor.y, b.sensor.yaw, b.sensor.sensor_id, b.sensor.name)
            assert all(np.array_equal(a.channels[c], b.channels[c]) for c in b.channels)


def test_every_odometry_row_is_read_on_request(plain, dataset):
    rec = read_radarscenes(dataset / "data", 105, odometry="all")          # DATAROOT may be the data folder too
    assert rec.odo.shape == (2 * 5368 - 1, 2)
    np.testing.assert_array_equal(rec.odo_t[0::2], plain.odo_t)
    np.testing.assert_array_equal(rec.odo[1::2, 1], -1.0)                 # the unpaired rows between them
    with pytest.raises(InputError) as e:
        read_radarscenes(dataset, 105, odometry="nearest")
    one_line_message(e, "odometry", "scenes, all", "'nearest'")


# --- refusals, on the first seconds ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def short(plain):
    import dataclasses

    keep, odo = plain.det_t <= 2.0, plain.odo_t <= 2.5
    return dataclasses.replace(plain, det_t=plain.det_t[keep], det_polar=plain.det_polar[keep],
                               channels={k: v[keep] for k, v in plain.channels.items()}, labels=plain.labels[keep],
                               odo_t=plain.odo_t[odo], odo=plain.odo[odo])


def test_an_unknown_sequence_or_a_missing_file_is_refused_inone_line_message(short, tmp_path):
    write_sequence(tmp_path, short)
    with pytest.raises(InputError) as e:
        read_radarscenes(tmp_path, 104)
    one_line_message(e, "--sequence", str(tmp_path / "data" / "sequence_104"), "holds sequence_105")
    with pytest.raises(InputError) as e:
        read_radarscenes(tmp_path, "one-hundred-five")
    one_line_message(e, "--sequence", "'one-hundred-five'")
    with pytest.raises(InputError) as e:
        read_radarscenes(tmp_path / "nope", 105)
    one_line_message(e, str(tmp_path / "nope"), "no such directory")
    (tmp_path / "data" / "sequence_105" / "scenes.json").unlink()
    with pytest.raises(DataError) as e:
        read_radarscenes(tmp_path, 105)
    one_line_message(e, str(tmp_path / "data" / "sequence_105" / "scenes.json"), "no such file")
    assert read_radarscenes(tmp_path, 105, odometry="all").det_t.size == short.det_t.size   # scenes.json unused then
    (tmp_path / "data" / "sensors.json").unlink()
    with pytest.raises(DataError) as e:
        read_radarscenes(tmp_path, 105, odometry="all")
    one_line_message(e, str(tmp_path / "data" / "sensors.json"), "no such file")


def test_a_table_without_its_fields_or_a_radar_without_mounting_is_refused(short, tmp_path):
    names = [n for n in RADAR_DTYPE.names if n != "vr"]
    write_sequence(tmp_path, short, radar_fields=names)
    with pytest.raises(DataError) as e:
        read_radarscenes(tmp_path, 105)
    one_line_message(e, str(tmp_path / "data" / "sequence_105" / "radar_data.h5"), "dataset radar_data",
              "expected a table with fields timestamp, sensor_id, range_sc, azimuth_sc, rcs, vr, label_id",
              "vr_compensated")
    other = tmp_path / "other"
    write_sequence(other, short)
    sensors = json.loads((other / "data" / "sensors.json").read_text())
    del sensors["radar_3"]
    (other / "data" / "sensors.json").write_text(json.dumps(sensors))
    with pytest.raises(DataError) as e:
        read_radarscenes(other, 105)
    one_line_message(e, "sensor_id 3 has no mounting", str(other / "data" / "sensors.json"), "holds radars 1, 2, 4")


def test_without_h5py_the_data_extra_is_named(short, tmp_path, monkeypatch):
    write_sequence(tmp_path, short)
    monkeypatch.setitem(sys.modules, "h5py", None)
    with pytest.raises(InputError) as e:
        read_radarscenes(tmp_path, 105)
    one_line_message(e, "needs h5py", "radarslam[data]")


def test_the_cli_refuses_a_bad_dataroot_inone_line_message(tmp_path, capsys):
    from radarslam.cli.main import main

    out = tmp_path / "out"
    assert main(["run", "--dataset", "radarscenes", str(tmp_path / "nope"), "--sequence", "105",
                 "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(tmp_path / "nope") in err and "no such directory" in err
    assert main(["run", "--dataset", "radarscenes", str(tmp_path), "--out", str(out)]) == 1
    assert capsys.readouterr().err.strip().endswith("--sequence: expected with --dataset radarscenes (e.g. "
                                                    "--sequence 105), got none")
    assert main(["run", "--dataset", "radarscenes", str(tmp_path), "--sequence", "105", "--scene", "scene-0061",
                 "--out", str(out)]) == 1
    assert "--scene: expected with --dataset nuscenes DATAROOT, got --dataset radarscenes" in capsys.readouterr().err
    assert main(["run", "--dataset", "radarscenes", str(tmp_path), "--sequence", "105", "--protocol", "published",
                 "--out", str(out)]) == 1
    assert "--protocol: defined for --dataset victoria-park" in capsys.readouterr().err
    assert not out.exists()
