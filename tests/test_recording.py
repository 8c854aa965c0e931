"""Your own recording: the plain format, ROS bags written here and read back, the
PointCloud2 decoder, the mounting, every malformed input refused in one line, and the round trip
of a simulated trial through a bag and the plain files to the same trajectory and map."""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from conftest import require
from radarslam.cli.main import main
from radarslam.core.errors import InputError
from radarslam.io.recording.mounting import Mounting, detections_to_platform, detections_to_sensor
from radarslam.io.recording.plain import read_plain, write_plain
from radarslam.io.recording.pointcloud2 import Field, decode
from radarslam.io.recording.stream import Recording, to_events

TI_BAG = Path(__file__).resolve().parents[2] / "shared" / "data" / "ti_mmwave_demo" / "ti_mmwave_rospkg_demo.bag"
TOPICS = ["--radar-topic", "/radar/points", "--odom-topic", "/odom"]


def small_recording(n_scans: int = 6, per_scan: int = 4, seed: int = 0, channels: bool = True) -> Recording:
    rng = np.random.default_rng(seed)
    t = np.repeat(np.arange(n_scans) * 0.1, per_scan)
    polar = np.column_stack([rng.uniform(1, 15, t.size), rng.uniform(-1.5, 1.5, t.size)])
    ch = {"doppler_mps": rng.normal(size=t.size), "rcs": rng.uniform(0, 30, t.size)} if channels else {}
    odo_t = np.arange(n_scans) * 0.1
    odo = np.column_stack([np.full(n_scans, 2.0), np.full(n_scans, 0.1)])
    truth = np.column_stack([odo_t, 0.1 * odo_t, 0.05 * odo_t])
    return Recording(t, polar, ch, odo_t, odo, "unicycle", odo_t.copy(), truth)


def _bag_path(tmp_path: Path, fmt: str) -> Path:
    return tmp_path / ("rec.bag" if fmt == "ros1" else f"rec_{fmt}")


# ------------------------------------------------------------------------------------------------
# Decoding and mounting
# ------------------------------------------------------------------------------------------------
def test_pointcloud2_decodes_by_offset_datatype_endianness_and_row_padding():
    """Big-endian INT16 / FLOAT64 / UINT8 fields with padding between them and at every row end."""
    dt = np.dtype({"names": ["y", "x", "id"], "formats": [">i2", ">f8", "u1"], "offsets": [0, 4, 13], "itemsize": 16})
    pts = np.zeros((2, 3), dtype=dt)
    pts["x"] = [[1.5, -2.0, 3.25], [4.0, 5.0, 6.0]]
    pts["y"] = [[-7, 8, 9], [10, -11, 12]]
    pts["id"] = [[1, 2, 3], [4, 5, 6]]
    rows = [r.tobytes() + b"\xff" * 5 for r in pts]                 # row_step = 3 * 16 + 5
    fields = [Field("y", 0, 3), Field("x", 4, 8), Field("id", 13, 2)]
    out = decode(fields, b"".join(rows), width=3, height=2, point_step=16, row_step=53, is_bigendian=True,
                 names=["x", "y", "id"], where="t")
    assert out["x"].tolist() == [1.5, -2.0, 3.25, 4.0, 5.0, 6.0]
    assert out["y"].tolist() == [-7, 8, 9, 10, -11, 12] and out["id"].tolist() == [1, 2, 3, 4, 5, 6]
    with pytest.raises(InputError, match="truncated"):
        decode(fields, b"".join(rows)[:60], width=3, height=2, point_step=16, row_step=53, is_bigendian=True,
               names=["x"], where="t")
    with pytest.raises(InputError, match="inside the 16-byte point"):
        decode([Field("x", 12, 8)], b"\0" * 16, width=1, height=1, point_step=16, row_step=16, is_bigendian=False,
               names=["x"], where="t")


def test_mounting_moves_detections_into_the_platform_frame():
    """A radar 1 m ahead looking left (yaw 90 deg): a return 2 m straight ahead of it is at (1, 2)."""
    m = Mounting(1.0, 0.0, math.pi / 2)
    p = detections_to_platform(np.array([[2.0, 0.0]]), m)
    np.testing.assert_allclose(p, [[math.hypot(1, 2), math.atan2(2, 1)]], atol=1e-12)
    rng = np.random.default_rng(1)
    polar = np.column_stack([rng.uniform(1, 20, 50), rng.uniform(-3, 3, 50)])
    m = Mounting(0.7, -0.4, 0.3)
    back = detections_to_platform(detections_to_sensor(polar, m), m)
    np.testing.assert_allclose(back[:, 0], polar[:, 0], atol=1e-12)
    np.testing.assert_allclose(np.angle(np.exp(1j * (back[:, 1] - polar[:, 1]))), 0, atol=1e-12)
    assert detections_to_platform(polar, Mounting()) is polar                  # zero mounting: untouched


def test_events_merge_odometry_first_and_carry_channels():
    rec = small_recording()
    ev = to_events(rec, Mounting())
    kinds = [type(e).__name__ for e in ev]
    assert kinds == ["Scan"] + ["Odometry", "Scan"] * 5
    assert ev[0].channels["doppler_mps"].shape == (4,) and ev[1].dt == pytest.approx(0.1)


# ------------------------------------------------------------------------------------------------
# Plain format
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("npz", [False, True])
def test_plain_format_reads_back_bit_for_bit(tmp_path, npz):
    rec = small_recording()
    path = tmp_path / "r.npz" if npz else tmp_path
    write_plain(rec, path)
    back = read_plain(path)
    assert np.array_equal(back.det_polar, rec.det_polar) and np.array_equal(back.odo, rec.odo)
    assert np.array_equal(back.channels["doppler_mps"], rec.channels["doppler_mps"])
    assert np.array_equal(back.truth, rec.truth)


def _csv(tmp_path: Path, det: str, odo: str = "t_s,speed_mps,yaw_rate_rad_s\n0,1,0\n0.1,1,0\n") -> Path:
    d = tmp_path / "rec"
    d.mkdir()
    (d / "detections.csv").write_text(det)
    (d / "odometry.csv").write_text(odo)
    return d


MALFORMED_PLAIN = {
    "unsorted": ("t_s,range_m,azimuth_rad\n0.1,1,0\n0.0,2,0\n", None, r"detections.csv line 3: expected non-decreasing times"),
    "nan": ("t_s,range_m,azimuth_rad\n0,1,0\n0.1,nan,0\n", None, r"line 3 column range_m: expected a finite number"),
    "degrees": ("t_s,range_m,azimuth_rad\n0,1,45\n", None, r"line 2 column azimuth_rad: expected radians.*degrees"),
    "deg_header": ("t_s,range_m,azimuth_deg\n0,1,45\n", None, r"column azimuth_deg: expected azimuth_rad"),
    "missing": ("t_s,range_m\n0,1\n", None, r"missing column\(s\) azimuth_rad"),
    "not_a_number": ("t_s,range_m,azimuth_rad\n0,one,0\n", None, r"line 2 column range_m: expected a number, got 'one'"),
    "truncated_line": ("t_s,range_m,azimuth_rad\n0,1,0\n0.1,2\n", None, r"line 3: expected 3 values"),
    "odo_backwards": ("t_s,range_m,azimuth_rad\n0,1,0\n", "t_s,speed_mps,yaw_rate_rad_s\n0,1,0\n0,1,0\n",
                      r"odometry.csv line 3: expected increasing times"),
    "odo_columns": ("t_s,range_m,azimuth_rad\n0,1,0\n", "t_s,speed_mps\n0,1\n", r"odometry.csv: expected columns"),
    "steering_deg": ("t_s,range_m,azimuth_rad\n0,1,0\n", "t_s,wheel_speed_mps,steering_rad\n0,1,20\n",
                     r"column steering_rad: expected radians"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED_PLAIN))
def test_malformed_plain_files_are_refused_in_one_line_and_nothing_is_written(tmp_path, capsys, case):
    det, odo, pattern = MALFORMED_PLAIN[case]
    d = _csv(tmp_path, det, *([odo] if odo else []))
    out = tmp_path / "out"
    assert main(["run", "--recording", str(d), "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(d) in err, err
    import re

    assert re.search(pattern, err), err
    assert not out.exists()


def test_malformed_npz_is_refused_naming_the_array(tmp_path):
    f = tmp_path / "r.npz"
    np.savez(f, **{"detections.t_s": np.array([0.0, 1.0]), "detections.range_m": np.array([1.0, np.nan]),
                   "detections.azimuth_rad": np.zeros(2), "odometry.t_s": np.array([0.0]),
                   "odometry.speed_mps": np.ones(1), "odometry.yaw_rate_rad_s": np.zeros(1)})
    with pytest.raises(InputError, match=r"table detections row 2 column range_m: expected a finite number"):
        read_plain(f)
    (tmp_path / "bad.npz").write_bytes(b"PK\x03\x04 truncated")
    with pytest.raises(InputError, match="unreadable"):
        read_plain(tmp_path / "bad.npz")


# ------------------------------------------------------------------------------------------------
# Bags written here, read back
# ------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("fmt", ["ros1", "sqlite3", "mcap"])
def test_bags_of_every_format_read_back(tmp_path, fmt):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.bag_write import write_bag

    rec = small_recording()
    mount = Mounting(0.5, -0.2, 0.3)
    p = write_bag(rec, _bag_path(tmp_path, fmt), fmt, mounting=mount, pad=4)
    back = read_bag(p, "/radar/points", "/odom", "/truth")
    np.testing.assert_allclose(back.det_polar, rec.det_polar, atol=1e-12)
    np.testing.assert_allclose(back.det_t, rec.det_t, atol=1e-9)
    np.testing.assert_allclose(back.channels["doppler_mps"], rec.channels["doppler_mps"])
    np.testing.assert_allclose(back.channels["rcs"], rec.channels["rcs"])
    np.testing.assert_allclose(back.odo, rec.odo) and np.testing.assert_allclose(back.truth, rec.truth, atol=1e-12)
    assert back.mounting.x == pytest.approx(0.5) and back.mounting.yaw == pytest.approx(0.3)
    assert back.notes == []


def _write_msgs(path: Path, fmt: str, build) -> Path:
    """A bag of the messages ``build(m)`` returns as ``(topic, msgtype, log ns, message)``."""
    from radarslam.io.recording.bag_write import _Msgs, _open_writer, _typestore

    m = _Msgs(_typestore(fmt), fmt == "ros1")
    with _open_writer(path, fmt) as w:
        conns = {}
        for topic, msgtype, ns, msg in build(m):
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=m.ts)
            w.write(conns[topic], ns, m.serialize(msg, msgtype))
    return path


S = 10**9
CLOUD, ODOM = "sensor_msgs/msg/PointCloud2", "nav_msgs/msg/Odometry"


def _cloud(m, stamp, cols=None, seq=0):
    cols = cols or {"x": np.array([3.0, 4.0]), "y": np.array([1.0, -1.0])}
    return m.cloud(stamp, seq, cols, 0)


def _odom(m, stamp, seq=0):
    return m.odometry(stamp, seq, "odom", twist=(1.0, 0.0))


def _stream(m, cloud_stamps, odo_stamps, logs=None, cols=None):
    logs = logs or [100 * S + i * S // 10 for i in range(max(len(cloud_stamps), len(odo_stamps)))]
    out = [("/radar/points", CLOUD, logs[i], _cloud(m, s, cols, i)) for i, s in enumerate(cloud_stamps)]
    out += [("/odom", ODOM, logs[i], _odom(m, s, i)) for i, s in enumerate(odo_stamps)]
    return sorted(out, key=lambda x: x[2])


def _truncated_cloud(m):
    c = _cloud(m, 100 * S)
    c.width, c.row_step = 50, 50 * c.point_step
    return [("/radar/points", CLOUD, 100 * S, c), ("/odom", ODOM, 100 * S, _odom(m, 100 * S))]


MALFORMED_BAGS = {
    "missing_topic": (lambda m: _stream(m, [100 * S], [100 * S]), {"radar": "/nope"}, r"radar topic /nope not found"),
    "wrong_type": (lambda m: _stream(m, [100 * S], [100 * S]), {"radar": "/odom"},
                   r"topic /odom: expected sensor_msgs/msg/PointCloud2 or radar_msgs/msg/RadarScan for the radar, "
                   r"got nav_msgs/msg/Odometry"),
    "empty_clouds": (lambda m: _stream(m, [100 * S], [100 * S], cols={"x": np.empty(0), "y": np.empty(0)}), {},
                     r"every cloud is empty"),
    "truncated_cloud": (_truncated_cloud, {}, r"message 1: expected 800 bytes.*truncated"),
    "nan_points": (lambda m: _stream(m, [100 * S], [100 * S], cols={"x": np.array([1.0, np.nan]), "y": np.ones(2)}),
                   {}, r"message 1 field x: expected finite values, got NaN"),
    "backwards": (lambda m: _stream(m, [101 * S, 100 * S], [100 * S, 101 * S]), {},
                  r"topic /radar/points message 2: expected increasing times.*backwards"),
    "cartesian_velocity": (lambda m: _stream(m, [100 * S], [100 * S], cols={
        "x": np.ones(2), "y": np.ones(2), "vx": np.ones(2), "vy": np.ones(2)}), {}, r"\['vx', 'vy'\].*--doppler-field"),
    "mixed_clocks": (lambda m: _stream(m, [0, 0], [5000 * S, 5000 * S + S // 10]), {},
                     r"topic /odom: its header clock is 4900.0 s from the log time.*refusing to mix"),
}


@pytest.mark.parametrize("case", sorted(MALFORMED_BAGS))
def test_malformed_bags_are_refused_in_one_line_and_nothing_is_written(tmp_path, capsys, case):
    require("rosbags")
    build, topics, pattern = MALFORMED_BAGS[case]
    bag = _write_msgs(tmp_path / "bad", "mcap", build)
    out = tmp_path / "out"
    args = ["run", "--recording", str(bag), "--radar-topic", topics.get("radar", "/radar/points"),
            "--odom-topic", "/odom", "--out", str(out)]
    assert main(args) == 1
    err = capsys.readouterr().err.strip()
    import re

    assert "\n" not in err and re.search(pattern, err), err
    assert not out.exists()


def test_zero_stamps_fall_back_to_log_time_with_one_warning(tmp_path, capsys):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag

    logs = [100 * S + i * S // 10 for i in range(3)]
    bag = _write_msgs(tmp_path / "b", "sqlite3", lambda m: _stream(m, [0, 0, 0], logs, logs))
    rec = read_bag(bag, "/radar/points", "/odom")
    assert len(rec.notes) == 1 and "every header stamp is 0; using the bag's log time" in rec.notes[0]
    np.testing.assert_allclose(rec.scan_t, [0.0, 0.1, 0.2])


def test_named_doppler_field_is_accepted_and_carried(tmp_path):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag

    cols = {"x": np.ones(2), "y": np.ones(2), "vx": np.array([0.5, -0.5]), "vy": np.ones(2)}
    bag = _write_msgs(tmp_path / "b.bag", "ros1", lambda m: _stream(m, [100 * S], [100 * S], cols=cols))
    rec = read_bag(bag, "/radar/points", "/odom", doppler_field="vx")
    assert rec.channels["doppler_mps"].tolist() == [0.5, -0.5]


@pytest.mark.parametrize("fmt", ["ros1", "mcap"])
def test_a_truncated_bag_file_is_refused_in_one_line(tmp_path, fmt):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag
    from radarslam.io.recording.bag_write import write_bag

    p = write_bag(small_recording(n_scans=40), _bag_path(tmp_path, fmt), fmt)
    f = p if fmt == "ros1" else next(p.glob("*.mcap"))
    data = f.read_bytes()
    f.write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match=r"bag .*(cannot open|cannot read)") as ei:
        read_bag(p, "/radar/points", "/odom")
    assert "\n" not in str(ei.value)


@pytest.mark.skipif(not TI_BAG.is_file() and not os.environ.get("CI"), reason="../shared/data/ti_mmwave_demo absent")
def test_real_ti_mmwave_bag_reads_with_doppler_and_the_log_time_fallback(tmp_path):
    require("rosbags")
    from radarslam.io.recording.bag import read_bag

    rec = read_bag(TI_BAG, "/ti_mmwave/radar_scan_pcl", None)
    assert rec.scan_t.size == 412 and 19 * 412 <= rec.det_t.size <= 87 * 412
    assert set(rec.channels) == {"z_m", "doppler_mps", "rcs"}
    assert "every header stamp is 0" in rec.notes[0]
    assert 0.2 < rec.det_polar[:, 0].min() and rec.det_polar[:, 0].max() < 19.5
    assert np.abs(rec.channels["doppler_mps"]).max() < 5.0          # radial velocities of a walk, m/s
    assert main(["convert", "--recording", str(TI_BAG), "--radar-topic", "/ti_mmwave/radar_scan_pcl",
                 "--out", str(tmp_path / "ti.npz")]) == 0
    assert read_plain(tmp_path / "ti.npz").scan_times().size == 412


# ------------------------------------------------------------------------------------------------
# The round trip: a simulated trial as a bag and as plain files gives the simulation's run
# ------------------------------------------------------------------------------------------------
def _small_config():
    from radarslam.config import from_dict

    return from_dict({"trajectory": {"n_steps": 40}})


@pytest.mark.parametrize("fmt, mount", [("mcap", None), ("sqlite3", (1.5, -0.4, 20.0)), ("ros1", (0.0, 0.0, 0.0))])
def test_round_trip_through_a_bag_and_the_plain_format_equals_the_simulation(tmp_path, fmt, mount):
    """A non-zero mounting too: the simulated radar is mounted there (docs/method.md b.4.3), the bag
    holds its sensor-frame detections and /tf_static; the same run results."""
    require("rosbags")
    import dataclasses

    from radarslam.config import load_config
    from radarslam.runs.recording import export_simulation, run_recording
    from radarslam.simulation.trial import run_trial
    from radarslam.io.recording import read_recording

    cfg = _small_config()
    m = Mounting(mount[0], mount[1], math.radians(mount[2])) if mount else None
    mounted = cfg if m is None else dataclasses.replace(cfg, sensor=dataclasses.replace(
        cfg.sensor, mount_x_m=m.x, mount_y_m=m.y, mount_yaw_deg=mount[2]))
    sim = run_trial(mounted, 7)
    paths = export_simulation(cfg, 7, tmp_path, fmt=fmt, mounting=m)
    run_cfg = load_config(paths["config"])
    for src in (paths["bag"], paths["plain"]):
        rec = read_recording(src, radar_topic="/radar/points", odom_topic="/odom", truth_topic="/truth")
        run = run_recording(rec, run_cfg, start="config")     # the simulation's own start (its b.5 offset)
        np.testing.assert_allclose(run.record.poses, sim.record.poses, atol=1e-9)
        assert np.array_equal(run.record.n_associated, sim.record.n_associated)
        assert np.array_equal(run.record.maps[-1].ids, sim.record.maps[-1].ids)
        np.testing.assert_allclose(run.record.maps[-1].positions, sim.record.maps[-1].positions, atol=1e-9)
        assert run.metrics["position_avg_rmse_m"] == pytest.approx(sim.metrics["position_avg_rmse_m"], abs=1e-9)


def test_cli_export_run_convert_and_refuse_to_overwrite(tmp_path, capsys):
    """The README's worked example at a reduced size: export, run on the bag, convert it back."""
    require("rosbags")
    (tmp_path / "small.toml").write_text("[trajectory]\nn_steps = 30\n")
    ex, out = tmp_path / "trial", tmp_path / "run"
    assert main(["export", "--seed", "3", "--config", str(tmp_path / "small.toml"), "--out", str(ex)]) == 0
    run = ["run", "--recording", str(ex / "bag"), *TOPICS, "--truth-topic", "/truth",
           "--config", str(ex / "config.toml"), "--out", str(out)]
    assert main(run) == 0
    for f in ("trajectory_tum.txt", "groundtruth_tum.txt", "map.json", "map.csv", "config.toml", "metrics.json"):
        assert (out / f).is_file(), f
    tum = np.loadtxt(out / "trajectory_tum.txt")
    assert tum.shape == (30, 8)
    capsys.readouterr()
    assert main(run) == 1 and "already holds a finished result" in capsys.readouterr().err
    assert main(["convert", "--recording", str(ex / "bag"), *TOPICS, "--truth-topic", "/truth",
                 "--out", str(tmp_path / "plain")]) == 0
    a, b = read_plain(tmp_path / "plain"), read_plain(ex / "plain")
    np.testing.assert_allclose(a.det_polar, b.det_polar, atol=1e-12)
    assert main(["convert", "--recording", str(ex / "bag"), *TOPICS, "--out", str(tmp_path / "plain")]) == 1


def test_animation_is_written(tmp_path):
    require("rosbags")
    require("matplotlib")
    from radarslam.runs.recording import animation_frames, run_recording
    from radarslam.viz.animation import animate_run

    rec = small_recording(n_scans=4, per_scan=5, channels=False)
    run = run_recording(rec, _small_config())
    frames = animation_frames(run)
    assert len(frames) == 4 and frames[0]["labels"].shape == (5,)
    animate_run(tmp_path / "a.gif", frames)
    assert (tmp_path / "a.gif").stat().st_size > 1000


def test_evo_ape_equals_radarslams_own_figure(tmp_path):
    """evo's APE (translation, no alignment) on the written TUM files: its mean is radarslam's
    position avg. RMSE of a single run, its RMSE the root mean square of the position errors."""
    require("rosbags")
    evo = require("evo")  # noqa: F841
    from evo.core import metrics, sync
    from evo.tools import file_interface

    (tmp_path / "small.toml").write_text("[trajectory]\nn_steps = 40\n")
    ex, out = tmp_path / "trial", tmp_path / "run"
    assert main(["export", "--seed", "5", "--config", str(tmp_path / "small.toml"), "--out", str(ex)]) == 0
    assert main(["run", "--recording", str(ex / "bag"), *TOPICS, "--truth-topic", "/truth",
                 "--config", str(ex / "config.toml"), "--out", str(out)]) == 0
    ref = file_interface.read_tum_trajectory_file(str(out / "groundtruth_tum.txt"))
    est = file_interface.read_tum_trajectory_file(str(out / "trajectory_tum.txt"))
    ref, est = sync.associate_trajectories(ref, est)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    import json

    m = json.loads((out / "metrics.json").read_text())
    err = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    own_rmse = float(np.sqrt(np.mean((err[:, 2] - err[:, 5]) ** 2 + (err[:, 3] - err[:, 6]) ** 2)))
    assert ape.get_statistic(metrics.StatisticsType.mean) == pytest.approx(m["position_avg_rmse_m"], abs=1e-5)
    assert ape.get_statistic(metrics.StatisticsType.rmse) == pytest.approx(own_rmse, abs=1e-5)
    assert ape.get_statistic(metrics.StatisticsType.rmse) == pytest.approx(m["position_rmse_m"], abs=1e-5)
