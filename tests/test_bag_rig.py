"""A multi-radar rig in a bag: several radar topics, topic i sensor_id i, each
frame's mounting from /tf_static (or a sensors table), each message one scan; the round trip
plain rig -> bag -> read back, the same SLAM run as from the plain format, every refusal in one
line naming the topic, and ``radarslam run`` with ``--radar-topic`` given several times."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from conftest import require
from radarslam.cli.main import main
from radarslam.core.errors import InputError
from radarslam.io.recording.mounting import Mounting

TOPICS = ["/radar_0/points", "/radar_1/points", "/radar_2/points"]
CLOUD, ODOM, TF = "sensor_msgs/msg/PointCloud2", "nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage"
S = 10**9
#: The configuration of every run here: the Python filter (nothing compiled).
PYTHON_TOML = '[filter]\nbackend = "python"\n'


def rig_recording():
    """Three radars (front, left looking left, rear looking back), each scanning at 10 Hz with its own
    offset, 2 s of a car at 5 m/s turning slowly past reflectors; exact odometry and truth."""
    from radarslam.io.recording.synthetic import synthetic_recording

    rig = {0: Mounting(3.5, 0.0, 0.0, sensor_id=0, name="front"),
           1: Mounting(1.0, 0.9, math.pi / 2, sensor_id=1, name="left"),
           2: Mounting(-1.0, -0.5, math.pi, sensor_id=2, name="rear")}
    return synthetic_recording(duration_s=2.0, speed_mps=5.0, turn_rate_rad_s=0.1, sensors=rig,
                               sensor_delays_s={1: 0.03, 2: 0.05}, fov_rad=math.radians(150))


def _bag_path(tmp_path: Path, fmt: str) -> Path:
    return tmp_path / ("rig.bag" if fmt == "ros1" else f"rig_{fmt}")


def _python_config():
    from radarslam.config import from_dict

    return from_dict({"filter": {"backend": "python"}})


def _write_msgs(path: Path, fmt: str, build) -> Path:
    """A bag of the messages ``build(m)`` returns as ``(topic, msgtype, log ns, message)``."""
    from radarslam.io.recording.bag_write import _Msgs, _open_writer, _typestore

    m = _Msgs(_typestore(fmt), fmt == "ros1")
    with _open_writer(path, fmt) as w:
        conns = {}
        for topic, msgtype, ns, msg in sorted(build(m), key=lambda x: x[2]):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=m.ts)
            w.write(conns[topic], ns, m.serialize(msg, msgtype))
    return path


def _rig_msgs(m, frames, tf=None, cols=None, n=3):
    """Two radar topics ``/a`` and ``/b`` in ``frames``, odometry on ``/odom``; ``tf``: ``{frame: Mounting}``
    on /tf_static (several entries of one frame: ``[(frame, Mounting), ...]``)."""
    cols = cols or {"x": np.array([3.0, 4.0]), "y": np.array([1.0, -1.0])}
    out = []
    for i in range(n):
        for k, (topic, frame) in enumerate(zip(("/a", "/b"), frames)):
            ns = 100 * S + i * S // 10 + k * S // 100
            out.append((topic, CLOUD, ns, m.cloud(ns, i, cols, 0, frame)))
        out.append(("/odom", ODOM, 100 * S + i * S // 10, m.odometry(100 * S + i * S // 10, i, "odom",
                                                                   twist=(1.0, 0.0))))
    if tf:
        items = tf if isinstance(tf, list) else list(tf.items())
        T = m.T
        trs = [T["geometry_msgs/msg/TransformStamped"](
            header=m.header(100 * S, "base_link"), child_frame_id=f,
            transform=T["geometry_msgs/msg/Transform"](translation=m.vec(mt.x, mt.y), rotation=m.quat(mt.yaw)))
            for f, mt in items]
        out.append(("/tf_static", TF, 100 * S, T[TF](transforms=trs)))
    return out


# ------------------------------------------------------------------------------------------------
# The round trip
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_a_three_radar_rig_round_trips_through_a_bag_of_three_topics(tmp_path, fmt):
    require("rosbags")
    from radarslam.io.recording.bag import list_topics, read_bag
    from radarslam.io.recording.bag_write import write_bag

    rec = rig_recording()
    assert rec.det_t.size > 300 and set(np.unique(rec.channels["sensor_id"]).tolist()) == {0.0, 1.0, 2.0}
    p = write_bag(rec, _bag_path(tmp_path, fmt), fmt)
    assert {t for t, ty in list_topics(p).items() if ty == CLOUD} == set(TOPICS)
    back = read_bag(p, TOPICS, "/odom", "/truth")
    np.testing.assert_allclose(back.det_t, rec.det_t, atol=1e-9)
    np.testing.assert_allclose(back.det_polar, rec.det_polar, atol=1e-12)
    np.testing.assert_array_equal(back.channels["sensor_id"], rec.channels["sensor_id"])
    assert set(back.channels) == {"sensor_id"}
    np.testing.assert_allclose(back.scan_t, rec.scan_t, atol=1e-9)
    assert back.scan_t.size == rec.scan_t.size and back.t0_ns == 1_700_000_000 * S
    np.testing.assert_allclose(back.odo_t, rec.odo_t - rec.scan_t[0], atol=1e-9)
    np.testing.assert_allclose(back.odo, rec.odo) and np.testing.assert_allclose(back.truth, rec.truth, atol=1e-12)
    assert back.mounting is None and sorted(back.sensors) == [0, 1, 2]
    for k, mt in rec.sensors.items():
        got = back.sensors[k]
        assert (got.sensor_id, got.name) == (k, TOPICS[k])
        assert got.x == pytest.approx(mt.x, abs=1e-12) and got.y == pytest.approx(mt.y, abs=1e-12)
        assert got.yaw == pytest.approx(mt.yaw, abs=1e-12)
        assert f"-> radar_{k}" in got.source
    assert back.notes == []
    # each message one scan: the stream's scans are the bag's clouds
    from radarslam.io.recording.stream import stream_events

    _, report = stream_events(back, Mounting())
    n_clouds = sum(np.unique(rec.det_t[rec.channels["sensor_id"] == k]).size for k in range(3))
    n_empty = np.setdiff1d(rec.scan_t, rec.det_t).size           # written as empty clouds of sensor 0
    assert report.scans == n_clouds + n_empty == rec.scan_t.size


def test_topics_in_another_order_are_sensors_in_that_order(tmp_path):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.bag_write import write_bag

    rec = rig_recording()
    p = write_bag(rec, tmp_path / "b", "mcap")
    back = read_bag(p, [TOPICS[2], TOPICS[0]], "/odom")
    assert [back.sensors[k].name for k in (0, 1)] == [TOPICS[2], TOPICS[0]]
    assert back.sensors[0].yaw == pytest.approx(math.pi) and back.sensors[1].x == pytest.approx(3.5)
    keep = np.isin(rec.channels["sensor_id"], [0.0, 2.0])
    assert back.det_t.size == int(keep.sum())
    first = back.det_t == back.det_t[0]                 # the front radar's first scan, now sensor 1
    np.testing.assert_array_equal(back.channels["sensor_id"][first], np.ones(int(first.sum())))
    np.testing.assert_allclose(back.det_polar[first], rec.det_polar[rec.det_t == rec.det_t[0]], atol=1e-12)
    assert back.t0_ns == 1_700_000_000 * S        # the time origin: the first radar message over all topics


def test_the_rig_from_a_bag_runs_as_from_the_plain_format(tmp_path):
    """plain rig -> bag of three topics -> read back -> run_recording: the plain format's run to 1e-12."""
    require("rosbags")
    from radarslam.runs.recording import run_recording
    from radarslam.io.recording import read_recording
    from radarslam.io.recording.bag_write import write_bag
    from radarslam.io.recording.plain import write_plain

    rec = rig_recording()
    (tmp_path / "plain").mkdir()
    write_plain(rec, tmp_path / "plain")
    bag = write_bag(rec, tmp_path / "bag", "mcap")
    cfg = _python_config()
    runs = [run_recording(read_recording(src, radar_topic=TOPICS, odom_topic="/odom", truth_topic="/truth"), cfg)
            for src in (tmp_path / "plain", bag)]
    a, b = runs
    assert a.metrics["scans"] == b.metrics["scans"] and a.metrics["associated"] > 0
    np.testing.assert_allclose(b.record.poses, a.record.poses, atol=1e-12)
    assert np.array_equal(a.record.n_associated, b.record.n_associated)
    assert np.array_equal(a.record.maps[-1].ids, b.record.maps[-1].ids)
    np.testing.assert_allclose(b.record.maps[-1].positions, a.record.maps[-1].positions, atol=1e-12)
    assert b.metrics["position_rmse_m"] == pytest.approx(a.metrics["position_rmse_m"], abs=1e-12)
    assert b.metrics["mounting"]["sensors"] == {str(k): TOPICS[k] for k in range(3)}


def test_one_topic_is_read_as_before(tmp_path):
    """A list of one topic is the single-topic read, field for field (no sensors, the /tf_static mounting)."""
    require("rosbags")
    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.bag_write import write_bag
    from radarslam.io.recording.synthetic import synthetic_recording

    rec = synthetic_recording(duration_s=1.0)
    p = write_bag(rec, tmp_path / "one", "mcap", mounting=Mounting(0.5, -0.2, 0.3))
    a, b = read_bag(p, "/radar/points", "/odom", "/truth"), read_bag(p, ["/radar/points"], "/odom", "/truth")
    assert a.sensors is None and b.sensors is None and a.mounting == b.mounting
    assert a.mounting.x == pytest.approx(0.5)
    for f in ("det_t", "det_polar", "odo_t", "odo", "truth_t", "truth", "scan_t"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f
    assert a.channels.keys() == b.channels.keys() and a.t0_ns == b.t0_ns and a.notes == b.notes


def test_a_sensors_table_gives_the_mountings_tf_static_lacks(tmp_path):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag

    bag = _write_msgs(tmp_path / "b", "mcap", lambda m: _rig_msgs(m, ("ra", "rb"), tf={"ra": Mounting(2.0, 0.0, 0.0)}))
    table = {0: Mounting(9.0, 9.0, 0.0, "t.csv", 0), 1: Mounting(-1.0, 0.5, math.pi, "t.csv", 1, "back", 50.0)}
    rec = read_bag(bag, ["/a", "/b"], "/odom", sensors=table)
    assert rec.sensors[0].x == pytest.approx(2.0)           # /tf_static wins
    assert (rec.sensors[1].x, rec.sensors[1].yaw, rec.sensors[1].name, rec.sensors[1].max_range_m) == \
        (-1.0, math.pi, "/b", 50.0)
    np.testing.assert_array_equal(rec.channels["sensor_id"], np.tile([0.0, 0.0, 1.0, 1.0], 3))
    np.testing.assert_allclose(rec.scan_t, [0.0, 0.01, 0.1, 0.11, 0.2, 0.21], atol=1e-12)


def test_radar_scan_and_pointcloud2_topics_mix_and_the_common_channels_are_kept(tmp_path):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.radar_scan import RADAR_SCAN, register_radar_msgs

    def build(m):
        register_radar_msgs(m.ts)
        T = m.T
        out = _rig_msgs(m, ("ra", "rb"), tf={"ra": Mounting(2.0, 0.0, 0.0), "rb": Mounting(0.0, 0.0, math.pi)},
                        cols={"x": np.array([3.0, 4.0]), "y": np.array([1.0, -1.0]), "doppler": np.array([0.5, 1.5])})
        out = [o for o in out if o[0] != "/b"]
        for i in range(3):
            ns = 100 * S + i * S // 10 + S // 100
            ret = [T["radar_msgs/msg/RadarReturn"](range=5.0, azimuth=0.25, elevation=0.0, doppler_velocity=-2.0,
                                                   amplitude=10.0)]
            out.append(("/b", RADAR_SCAN, ns, T[RADAR_SCAN](header=m.header(ns, "rb"), returns=ret)))
        return out

    rec = read_bag(_write_msgs(tmp_path / "b", "mcap", build), ["/a", "/b"], "/odom")
    assert set(rec.channels) == {"doppler_mps", "sensor_id"}
    np.testing.assert_allclose(rec.channels["doppler_mps"], np.tile([0.5, 1.5, -2.0], 3))
    np.testing.assert_allclose(rec.det_polar[2::3], [[5.0, 0.25]] * 3, rtol=1e-6)
    assert len(rec.notes) == 1 and "rcs, z_m left out: not carried by every radar topic (not by /a)" in rec.notes[0]


# ------------------------------------------------------------------------------------------------
# Refusals: one line naming the topic
# ------------------------------------------------------------------------------------------------
RIG_TF = {"ra": Mounting(2.0, 0.0, 0.0), "rb": Mounting(0.0, 0.0, math.pi)}
REFUSED = {
    "missing_topic": (lambda m: _rig_msgs(m, ("ra", "rb"), RIG_TF), ["/a", "/nope"], None,
                      r"radar topic /nope not found; topics: /a, /b, /odom, /tf_static"),
    "wrong_type": (lambda m: _rig_msgs(m, ("ra", "rb"), RIG_TF), ["/a", "/odom"], None,
                   r"topic /odom: expected sensor_msgs/msg/PointCloud2 or radar_msgs/msg/RadarScan for the radar, "
                   r"got nav_msgs/msg/Odometry"),
    "no_mounting": (lambda m: _rig_msgs(m, ("ra", "rb"), {"ra": Mounting(2.0, 0.0, 0.0)}), ["/a", "/b"], None,
                    r"topic /b: no mounting for its frame 'rb': expected a /tf_static transform to it, or a sensors "
                    r"table \(--sensors FILE\) with a row for sensor_id 1"),
    "same_frame_two_mountings": (lambda m: _rig_msgs(m, ("r", "r")), ["/a", "/b"],
                                 {0: Mounting(1.0, 0.0, 0.0, sensor_id=0), 1: Mounting(-1.0, 0.0, 0.0, sensor_id=1)},
                                 r"topics /a and /b share the frame 'r' but their mountings differ \(x 1 m, y 0 m, "
                                 r"yaw 0 rad and x -1 m, y 0 m, yaw 0 rad\); expected one mounting per frame"),
    "tf_static_twice": (lambda m: _rig_msgs(m, ("ra", "rb"), [("ra", Mounting(2.0, 0, 0)), ("rb", Mounting()),
                                                               ("ra", Mounting(2.5, 0, 0))]), ["/a", "/b"], None,
                        r"topic /a: /tf_static holds 2 different transforms to its frame 'ra'; expected one"),
    "sensor_id_field": (lambda m: _rig_msgs(m, ("ra", "rb"), RIG_TF, cols={
        "x": np.ones(2), "y": np.ones(2), "sensor_id": np.zeros(2)}), ["/a", "/b"], None,
                        r"topic /a: its clouds carry a sensor_id field \('sensor_id'\), but with several "
                        r"--radar-topic each topic is one sensor"),
    "topic_twice": (lambda m: _rig_msgs(m, ("ra", "rb"), RIG_TF), ["/a", "/a"], None,
                    r"--radar-topic /a given twice; expected each radar topic once"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_rig_faults_are_refused_in_one_line_naming_the_topic(tmp_path, case):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag

    build, topics, table, pattern = REFUSED[case]
    bag = _write_msgs(tmp_path / "bad", "mcap", build)
    with pytest.raises(InputError) as ei:
        read_bag(bag, topics, "/odom", sensors=table)
    msg = str(ei.value)
    assert "\n" not in msg and re.search(pattern, msg), msg


def test_cli_refuses_a_rig_fault_before_writing(tmp_path, capsys):
    require("rosbags")
    bag = _write_msgs(tmp_path / "bad", "mcap", lambda m: _rig_msgs(m, ("ra", "rb"), {"ra": Mounting(2.0, 0.0, 0.0)}))
    out = tmp_path / "out"
    assert main(["run", "--recording", str(bag), "--radar-topic", "/a", "--radar-topic", "/b", "--odom-topic", "/odom",
                 "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "topic /b: no mounting for its frame 'rb'" in err, err
    assert not out.exists()
    # a run without odometry takes one radar
    assert main(["run", "--recording", str(bag), "--radar-topic", "/a,/b", "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "takes one radar topic, got 2 (/a, /b)" in err, err
    assert not out.exists()


# ------------------------------------------------------------------------------------------------
# The command line end to end
# ------------------------------------------------------------------------------------------------
def test_cli_runs_a_rig_bag_given_several_radar_topics(tmp_path, capsys):
    require("rosbags")
    import json

    from radarslam.io.recording.bag_write import write_bag
    from radarslam.io.recording.plain import read_plain

    rec = rig_recording()
    bag = write_bag(rec, tmp_path / "bag", "mcap")
    (tmp_path / "py.toml").write_text(PYTHON_TOML)
    out = tmp_path / "run"
    args = ["run", "--recording", str(bag), "--radar-topic", TOPICS[0], "--radar-topic", TOPICS[1],
            "--radar-topic", TOPICS[2], "--odom-topic", "/odom", "--truth-topic", "/truth",
            "--config", str(tmp_path / "py.toml"), "--out", str(out)]
    assert main(args) == 0, capsys.readouterr().err
    m = json.loads((out / "metrics.json").read_text())
    assert m["mounting"]["sensors"] == {str(k): TOPICS[k] for k in range(3)}
    assert m["scans"] == rec.scan_t.size and np.loadtxt(out / "trajectory_tum.txt").shape[0] == rec.scan_t.size
    # the same as the plain format's run
    plain = tmp_path / "plain"
    plain.mkdir()
    from radarslam.io.recording.plain import write_plain

    write_plain(rec, plain)
    assert main(["run", "--recording", str(plain), "--config", str(tmp_path / "py.toml"), "--out",
                 str(tmp_path / "run_plain")]) == 0
    np.testing.assert_allclose(np.loadtxt(out / "trajectory_tum.txt")[:, 1:],
                               np.loadtxt(tmp_path / "run_plain" / "trajectory_tum.txt")[:, 1:], atol=1e-9)
    # convert writes the rig as the plain format with its sensors.csv (a comma-separated list)
    capsys.readouterr()
    assert main(["convert", "--recording", str(bag), "--radar-topic", ",".join(TOPICS), "--odom-topic", "/odom",
                 "--out", str(tmp_path / "conv")]) == 0
    back = read_plain(tmp_path / "conv")
    assert [back.sensors[k].name for k in range(3)] == TOPICS
    np.testing.assert_array_equal(back.channels["sensor_id"], rec.channels["sensor_id"])


def test_cli_takes_a_rigs_mountings_from_sensors_when_tf_static_lacks_them(tmp_path, capsys):
    require("rosbags")
    bag = _write_msgs(tmp_path / "b", "mcap", lambda m: _rig_msgs(m, ("ra", "rb"), n=6))
    (tmp_path / "s.csv").write_text("sensor_id,x_m,y_m,yaw_rad,name\n0,2.0,0.0,0.0,front\n1,-1.0,0.0,3.0,back\n")
    (tmp_path / "py.toml").write_text(PYTHON_TOML)
    base = ["run", "--recording", str(bag), "--radar-topic", "/a", "--radar-topic", "/b", "--odom-topic", "/odom",
            "--config", str(tmp_path / "py.toml")]
    assert main([*base, "--sensors", str(tmp_path / "s.csv"), "--out", str(tmp_path / "run")]) == 0, \
        capsys.readouterr().err
    import json

    m = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert m["mounting"]["sensors"] == {"0": "front", "1": "back"}
