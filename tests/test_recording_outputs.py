"""What a recording run of a car's radars writes: ``--sensors``,
``ego_velocity.csv`` and its figure, ``moving.csv`` (equal from both engines, its landmark column
the filter's own associations) with its scores against an annotation, and ``map.png``."""

from __future__ import annotations

import csv
import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from helpers import first_seconds, shared_data
from radarslam.cli.main import main
from radarslam.core.types import Scan
from radarslam.runs.detection_flags import DetectionFlags, moving_scores
from radarslam.egomotion.rig import EGO_VELOCITY_COLUMNS
from radarslam.io.recording.mounting import Mounting
from radarslam.io.recording.plain import read_plain, write_plain
from radarslam.io.recording.stream import stream_events
from radarslam.io.recording.synthetic import synthetic_recording

GATE = "[filter]\ndoppler_gate = true\n"
#: A PNG file's first bytes.
PNG = b"\x89PNG\r\n\x1a\n"


def _table(path: Path) -> dict[str, list[str]]:
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    return {h: [r[j] for r in rows[1:]] for j, h in enumerate(rows[0])}


def _run(args: list[str], capsys) -> tuple[int, str]:
    code = main(["run", *args])
    return code, capsys.readouterr().err


# ------------------------------------------------------------------------------------------------
# --sensors
# ------------------------------------------------------------------------------------------------
RIG = {0: Mounting(3.0, 0.0, 0.0, "rig", 0, "front"), 1: Mounting(-1.0, 0.0, np.pi, "rig", 1, "rear")}


@pytest.fixture
def rig_recording(tmp_path) -> Path:
    d = tmp_path / "rig"
    d.mkdir()
    write_plain(synthetic_recording(duration_s=2.0, sensors=RIG), d)
    return d


def test_sensors_file_replaces_the_recordings_and_run_json_names_it(rig_recording, tmp_path, capsys):
    f = tmp_path / "sensors_calibrated.csv"
    f.write_text("sensor_id,x_m,y_m,yaw_rad,name\n0,3.0,0.0,0.01,front\n1,-1.0,0.0,3.13,rear\n")
    out = tmp_path / "out"
    code, err = _run(["--recording", str(rig_recording), "--sensors", str(f), "--out", str(out)], capsys)
    assert code == 0, err
    assert json.loads((out / "run.json").read_text())["sensors_file"] == str(f)
    from radarslam.runs.recording_outputs import with_sensors_file

    rec = with_sensors_file(read_plain(rig_recording), f)
    assert rec.sensors[0].yaw == 0.01 and rec.sensors[1].yaw == 3.13 and rec.sensors[1].name == "rear"
    own = tmp_path / "own"                       # without --sensors: the recording's own file
    assert _run(["--recording", str(rig_recording), "--out", str(own)], capsys)[0] == 0
    assert json.loads((own / "run.json").read_text())["sensors_file"] == str(rig_recording / "sensors.csv")


@pytest.mark.parametrize("text, says", [
    ("sensor_id,x_m,y_m\n0,3,0\n1,-1,0\n", "missing column(s) yaw_rad"),
    ("sensor_id,x_m,y_m,yaw_rad\n0,3,0,0\n0,-1,0,3.14\n", "line 3 column sensor_id: expected each sensor once"),
    ("sensor_id,x_m,y_m,yaw_rad\n0,3,0,0\n1,-1,0,nan\n", "line 3 column yaw_rad: expected a finite number"),
    ("sensor_id,x_m,y_m,yaw_rad\n0,3,0,0\n1,-1,0,180\n", "line 3 column yaw_rad: expected radians"),
    ("sensor_id,x_m,y_m,yaw_rad\n0,3,0,0\n", "column sensor_id: expected one of sensors.csv's 0, got 1.0"),
    ("sensor_id,x_m,y_m,yaw_rad\n0,3,0,0\n1,-1,0\n", "line 3: expected 4 values"),
])
def test_sensors_file_refused_in_one_line(rig_recording, tmp_path, capsys, text, says):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    out = tmp_path / "out"
    code, err = _run(["--recording", str(rig_recording), "--sensors", str(f), "--out", str(out)], capsys)
    assert code == 1 and len(err.strip().splitlines()) == 1, err
    assert says in err and ("bad.csv" in err or "detection" in err), err
    assert not out.exists()                                          # refused before --out is made


def test_missing_sensors_file_refused(rig_recording, tmp_path, capsys):
    code, err = _run(["--recording", str(rig_recording), "--sensors", str(tmp_path / "none.csv"), "--out",
                      str(tmp_path / "out")], capsys)
    assert code == 1 and "--sensors" in err and "no such file" in err


# ------------------------------------------------------------------------------------------------
# A hand-made recording with Doppler and labels: the oracle of moving.csv and its scores
# ------------------------------------------------------------------------------------------------
SPEED = 10.0          # the car's speed (m/s), straight along x
ONCOMING = -10.0      # a road user's speed (m/s), in the opposite lane


def _labelled_recording(rng: np.random.Generator):
    """A car driving past point reflectors (static, label 11) with an oncoming car in the opposite
    lane (its detections labelled 0): every Doppler exact plus 0.05 m/s of noise. Returns the
    recording and the road users' mask in input order."""
    rec = synthetic_recording(duration_s=6.0, speed_mps=SPEED, spacing_m=6.0, lateral_m=6.0, returns=3)
    scans = np.unique(rec.det_t)
    t_car, polar_car = [], []
    corners = np.array([[-2.0, -0.9], [2.0, -0.9], [-2.0, 0.9], [2.0, 0.9], [0.0, 0.9]])
    for ts in scans:
        centre = np.array([50.0 + ONCOMING * ts, 3.0])
        local = centre + corners - [SPEED * ts, 0.0]                  # the platform's frame (heading 0)
        r, az = np.hypot(*local.T), np.arctan2(local[:, 1], local[:, 0])
        seen = (r <= 25.0) & (r > 1.0)
        t_car.append(np.full(seen.sum(), ts))
        polar_car.append(np.column_stack([r[seen], az[seen]]))
    t = np.r_[rec.det_t, np.concatenate(t_car)]
    polar = np.r_[rec.det_polar, np.concatenate(polar_car)]
    road = np.r_[np.zeros(rec.det_t.size, bool), np.ones(t.size - rec.det_t.size, bool)]
    rel = np.where(road, ONCOMING - SPEED, -SPEED)                    # x velocity relative to the radar
    doppler = rel * np.cos(polar[:, 1]) + rng.normal(0.0, 0.05, t.size)   # positive receding
    order = np.argsort(t, kind="stable")
    rec = dataclasses.replace(rec, det_t=t[order], det_polar=polar[order], channels={"doppler_mps": doppler[order]},
                              labels=np.where(road, 0, 11)[order].astype(np.int64), scan_t=None)
    return rec, road[order]


def test_scores_of_a_hand_made_recording_against_what_is_known(tmp_path, capsys):
    """The gate's flags and the landmarks in moving.csv scored against the labels the recording was
    made with; the oncoming car's detections are called moving and update no landmark."""
    rec, road = _labelled_recording(np.random.default_rng(3))
    d = tmp_path / "rec"
    d.mkdir()
    write_plain(rec, d)
    cfg = tmp_path / "gate.toml"
    cfg.write_text(GATE)
    out = tmp_path / "out"
    code, err = _run(["--recording", str(d), "--config", str(cfg), "--out", str(out)], capsys)
    assert code == 0, err
    mv = _table(out / "moving.csv")
    moving = np.array(mv["moving"], dtype=int) == 1
    landmark = np.array(mv["landmark"], dtype=int)
    assert moving.size == rec.det_t.size
    s = json.loads((out / "metrics.json").read_text())["moving_scores"]
    assert s["road_user_detections"] == int(road.sum()) > 50
    assert s["static_detections"] == int((~road).sum())
    assert s["road_user_updated"] == int(np.count_nonzero(road & (landmark >= 0))) == 0
    assert s["static_moving"] == int(np.count_nonzero(~road & moving))
    assert s["road_user_called_moving"] >= 0.9 * s["road_user_detections"]
    assert s["static_moving_share"] <= 0.05
    assert np.count_nonzero(~road & (landmark >= 0)) > 100                 # the reflectors do make the map


def test_moving_scores_by_hand():
    """Six detections, labels and flags chosen by hand."""
    labels = np.array([11, 11, 11, 0, 2, 7])
    flags = DetectionFlags(np.array([True, False, False, True, False, False]), np.array([-1, 4, -1, -1, 5, -1]),
                           np.array([True, True, False, True, True, True]))
    s = moving_scores(labels, flags)
    assert (s["road_user_detections"], s["road_user_updated"], s["road_user_called_moving"]) == (3, 1, 1)
    assert (s["static_detections"], s["static_moving"], s["static_updated"], s["unused_detections"]) == (3, 1, 1, 1)
    assert s["road_user_updated_share"] == pytest.approx(1 / 3) and s["static_moving_share"] == pytest.approx(1 / 3)
    wrong = moving_scores(labels, flags, static_label=0)                   # negative control: another label
    assert wrong["road_user_detections"] != 3


# ------------------------------------------------------------------------------------------------
# The shared recordings' first 5 s
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def shared(tmp_path_factory):
    data = shared_data()
    base = tmp_path_factory.mktemp("shared5s")
    return {name: first_seconds(data / name, 5.0, base / name.replace("/", "_"))
            for name in ("nuscenes_radar/scene-0061", "radarscenes/sequence_105")}


@pytest.fixture(scope="module")
def scene_runs(shared, tmp_path_factory):
    """scene-0061's first 5 s with the Doppler gate, by the compiled engine and by its Python form."""
    base = tmp_path_factory.mktemp("runs")
    cfg = base / "gate.toml"
    cfg.write_text(GATE)
    outs = {}
    for name, extra in (("fused", []), ("python", ["--backend", "python"])):
        outs[name] = base / name
        assert main(["run", "--recording", str(shared["nuscenes_radar/scene-0061"]), "--config", str(cfg), *extra,
                     "--out", str(outs[name])]) == 0
    return outs


def test_moving_csv_one_row_per_input_detection_equal_from_both_engines(shared, scene_runs):
    fused, python = (_table(scene_runs[k] / "moving.csv") for k in ("fused", "python"))
    assert json.loads((scene_runs["fused"] / "run.json").read_text())["engine"] == "fused"
    assert json.loads((scene_runs["python"] / "run.json").read_text())["engine"] == "fused-python"
    assert list(fused) == ["t_s", "sensor_id", "moving", "landmark", "used"]
    assert fused == python
    det = _table(shared["nuscenes_radar/scene-0061"] / "detections.csv")
    assert len(fused["t_s"]) == len(det["t_s"])                            # one row per input detection
    np.testing.assert_allclose(np.array(fused["t_s"], float), np.array(det["t_s"], float), rtol=0, atol=1e-9)
    assert [int(v) for v in fused["sensor_id"]] == [int(v) for v in det["sensor_id"]]
    moving = np.array(fused["moving"], dtype=int)
    used = np.array(fused["used"], dtype=int)
    assert 0 < moving.sum() < moving.size and not np.any(moving.astype(bool) & ~used.astype(bool))
    assert used.sum() < used.size                                           # scans before the odometry: unused
    m = json.loads((scene_runs["fused"] / "metrics.json").read_text())
    assert int(np.count_nonzero(np.array(fused["landmark"], dtype=int) >= 0)) == m["associated"]


def test_landmark_column_is_the_filters_associations(shared, scene_runs):
    """An independent path: the filter event by event (EkfSlam's reports), each scan carrying its rows' numbers as a
    channel, its ScanReport's moving rows and associations put back at those rows."""
    from radarslam.config import load_config
    from radarslam.runs.recording import effective_mounting, start_pose
    from radarslam.slam.filter import EkfSlam

    src = shared["nuscenes_radar/scene-0061"]
    rec = read_plain(src)
    cfg_path = scene_runs["python"] / "config.toml"
    config = load_config(cfg_path)
    m = effective_mounting(rec, config)
    tagged = dataclasses.replace(rec, channels={**rec.channels, "row": np.arange(rec.det_t.size, dtype=float)})
    events, _ = stream_events(tagged, m)
    pose, _ = start_pose(rec, config, next(e.t for e in events if isinstance(e, Scan)))
    assert np.allclose(pose, config.filter.initial_pose)
    slam = EkfSlam(config)
    moving, landmark = np.zeros(rec.det_t.size, int), np.full(rec.det_t.size, -1)
    for ev in events:
        rep = slam.process(ev)
        if rep is None:
            continue
        rows = ev.channels["row"].astype(int)
        moving[rows[rep.moving]] = 1
        for lid, idx in rep.associations.items():
            assert np.all(landmark[rows[idx]] == -1)                      # one landmark per detection
            landmark[rows[idx]] = lid
    table = _table(scene_runs["fused"] / "moving.csv")
    assert np.array_equal(np.array(table["moving"], dtype=int), moving)
    assert np.array_equal(np.array(table["landmark"], dtype=int), landmark)


def test_ego_velocity_csv_and_figures(scene_runs):
    out = scene_runs["fused"]
    t = _table(out / "ego_velocity.csv")
    assert tuple(t) == EGO_VELOCITY_COLUMNS
    ok = np.array(t["status"]) == "ok"
    assert ok.mean() > 0.9
    vals = np.array([[float(t[c][i]) for c in EGO_VELOCITY_COLUMNS[:10]] for i in np.flatnonzero(ok)])
    assert np.all(np.isfinite(vals)) and np.all(np.diff(np.array(t["t_s"], dtype=float)) > 0)
    assert np.all(vals[:, 4] > 0) and np.all(vals[:, 9] > 0)                # variances of v_x and omega
    m = json.loads((out / "metrics.json").read_text())["ego_velocity"]
    assert m["sensors"] == 5 and m["against_odometry"]["speed_mps"]["rmse"] < 0.2
    pytest.importorskip("matplotlib")
    for name in ("map.png", "ego_velocity.png"):
        assert (out / name).read_bytes()[:8] == PNG


def test_radarscenes_first_seconds_scored_against_its_labels(shared, tmp_path, capsys):
    src = shared["radarscenes/sequence_105"]
    out = tmp_path / "out"
    code, err = _run(["--recording", str(src), "--profile", "automotive", "--out", str(out)], capsys)
    assert code == 0, err
    labels = read_plain(src).labels
    t = _table(out / "moving.csv")
    moving, landmark = np.array(t["moving"], dtype=int) == 1, np.array(t["landmark"], dtype=int)
    assert moving.size == labels.size
    s = json.loads((out / "metrics.json").read_text())["moving_scores"]
    road = labels != 11
    assert s["road_user_detections"] == int(road.sum()) > 0
    assert s["road_user_updated"] == int(np.count_nonzero(road & (landmark >= 0)))
    assert s["static_moving"] == int(np.count_nonzero(~road & moving))
    assert s["static_moving_share"] == pytest.approx(s["static_moving"] / s["static_detections"])
    assert (out / "map.png").is_file() or pytest.importorskip("matplotlib") is None
