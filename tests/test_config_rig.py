"""A multi-radar rig in the config: ``[[sensors]]`` tables, the same as a recording's
``sensors.csv`` with the yaw in degrees; their round trip through ``dump-config`` and a run's saved
``config.toml``, their one-line refusals, the precedence ``--sensors FILE`` > ``[[sensors]]`` > the
recording's ``sensors.csv``, and a run from the config's rig equal bit for bit to the run from
``sensors.csv`` (``run`` and ``calibrate``)."""

from __future__ import annotations

import json
import math
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from radarslam.cli.main import main
from radarslam.config import from_dict, load_config, profile_config, to_dict, to_toml
from radarslam.core.errors import ConfigError
from radarslam.io.recording.mounting import Mounting
from radarslam.io.recording.plain import read_plain, write_plain
from radarslam.io.recording.sensors import sensors_from_config
from radarslam.io.recording.synthetic import synthetic_recording

#: The rig of the tests: (id, x_m, y_m, yaw_deg, name).
RIG = [(0, 3.0, 0.0, 0.0, "front"), (1, -1.0, 0.25, 180.0, "rear")]
PYTHON = '[filter]\nbackend = "python"\n'


def rig_toml(rig=RIG, extra: str = "") -> str:
    """``[[sensors]]`` tables of ``rig`` (each a tuple as :data:`RIG`), ``extra`` added to each."""
    return "".join(f'\n[[sensors]]\nid = {i}\nx_m = {x!r}\ny_m = {y!r}\nyaw_deg = {d!r}\nname = "{n}"\n{extra}'
                   for i, x, y, d, n in rig)


def sensors_csv(rig=RIG) -> str:
    """The same rig as ``sensors.csv`` (the yaw in radians: ``math.radians`` of the degrees)."""
    return "sensor_id,x_m,y_m,yaw_rad,name\n" + "".join(
        f"{i},{x!r},{y!r},{math.radians(d)!r},{n}\n" for i, x, y, d, n in rig)


def mountings(rig=RIG) -> dict[int, Mounting]:
    return {i: Mounting(x, y, math.radians(d), "rig", i, n) for i, x, y, d, n in rig}


def write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def one_line_error(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


# ------------------------------------------------------------------------------------------------
# The config: loading, round trip, refusals
# ------------------------------------------------------------------------------------------------
def test_rig_tables_load_and_round_trip_through_toml_and_dump_config(tmp_path, capsys):
    f = write(tmp_path / "rig.toml", rig_toml(extra="max_range_m = 60\n") + "fov_deg = 120.0\n")
    cfg = load_config(f)
    assert [(s.id, s.x_m, s.y_m, s.yaw_deg, s.name) for s in cfg.sensors] == RIG
    assert cfg.sensors[0].max_range_m == 60.0 and cfg.sensors[0].fov_deg is None and cfg.sensors[1].fov_deg == 120.0
    assert cfg.sensor.mount_x_m == 0.0                          # the single radar's [sensor] untouched
    for comments in (True, False):
        assert from_dict(tomllib.loads(to_toml(cfg, comments=comments))) == cfg
    assert from_dict(to_dict(cfg)) == cfg
    assert "fov_deg" not in to_dict(cfg)["sensors"][0]         # not stated: absent, as in TOML
    assert main(["dump-config", "--config", str(f)]) == 0
    out = capsys.readouterr().out
    assert out.count("[[sensors]]") == 2 and from_dict(tomllib.loads(out)) == cfg


def test_no_rig_leaves_the_config_dict_as_before():
    """A config without a rig has no ``sensors`` key (so the hash of every stored run holds) and its
    TOML only a comment pointing at ``[[sensors]]``."""
    cfg = profile_config()
    assert cfg.sensors == [] and "sensors" not in to_dict(cfg)
    text = to_toml(cfg)
    assert "# [[sensors]]: none" in text and "sensors" not in tomllib.loads(text)


def test_the_rigs_mountings_are_the_sensors_csv_ones(tmp_path):
    """The yaw and the field of view in radians (math.radians of the degrees), as sensors.csv's reader
    makes them: the same floats."""
    cfg = load_config(write(tmp_path / "c.toml", rig_toml(extra="fov_deg = 100.0\nmax_range_m = 50.0\n")))
    rec = tmp_path / "rec"
    rec.mkdir()
    write_plain(synthetic_recording(duration_s=0.3, sensors=mountings()), rec)
    write(rec / "sensors.csv", "sensor_id,x_m,y_m,yaw_rad,name,max_range_m,fov_deg\n" + "".join(
        f"{i},{x!r},{y!r},{math.radians(d)!r},{n},50.0,100.0\n" for i, x, y, d, n in RIG))
    own = read_plain(rec).sensors
    ours = sensors_from_config(cfg.sensors)
    strip = lambda m: (m.x, m.y, m.yaw, m.sensor_id, m.name, m.max_range_m, m.fov_rad)
    assert {k: strip(m) for k, m in ours.items()} == {k: strip(m) for k, m in own.items()}


@pytest.mark.parametrize("body, says", [
    ("[[sensors]]\nx_m = 1.0\ny_m = 0.0\nyaw_deg = 0.0\n", "sensors[0].id: missing"),
    (rig_toml() + "[[sensors]]\nid = 1\nx_m = 0.0\ny_m = 0.0\nyaw_deg = 0.0\n",
     "sensors[2].id: expected each sensor once, got 1 again (as sensors[1])"),
    ("[[sensors]]\nid = 0\nx_m = nan\ny_m = 0.0\nyaw_deg = 0.0\n", "sensors[0].x_m: expected a number, got nan"),
    ("[[sensors]]\nid = 0\nx_m = 1.0\ny_m = inf\nyaw_deg = 0.0\n", "sensors[0].y_m: expected a finite number"),
    (rig_toml()[:-1] + "\n[[sensors]]\nid = 2\nx_m = 0.0\ny_m = 0.0\nyaw_deg = 400.0\n",
     "sensors[2].yaw_deg: expected degrees within [-360, 360], got 400.0"),
    ("[[sensors]]\nid = 0\nx_m = 1.0\ny_m = 0.0\nyaw_rad = 1.57\n", ("sensors[0].yaw_rad: unknown key; the config "
     "takes the yaw in degrees, yaw_deg")),
    ("[[sensors]]\nid = 0\nx_m = 1.0\ny_m = 0.0\nyaw_deg = 0.0\nheight_m = 1.0\n", "sensors[0].height_m: unknown key"),
    ("[[sensors]]\nid = 0\nx_m = 1.0\ny_m = 0.0\n", "sensors[0].yaw_deg: missing"),
    ("[[sensors]]\nid = -1\nx_m = 1.0\ny_m = 0.0\nyaw_deg = 0.0\n", "sensors[0].id: expected a value >= 0"),
    ("[[sensors]]\nid = 0.5\nx_m = 1.0\ny_m = 0.0\nyaw_deg = 0.0\n", "sensors[0].id: expected an integer"),
    ("[[sensors]]\nid = 0\nx_m = 1.0\ny_m = 0.0\nyaw_deg = 0.0\nfov_deg = 400.0\n", ("sensors[0].fov_deg: expected a "
     "value <= 360.0")),
    ("[[sensors]]\nid = 0\nx_m = 1.0\ny_m = 0.0\nyaw_deg = 0.0\nmax_range_m = 0\n", ("sensors[0].max_range_m: "
     "expected a value > 0.0")),
    ("[sensors]\nid = 0\n", "sensors: expected an array of tables [[sensors]], one per radar, got a table"),
    ("[[sensor]]\nmount_x_m = 1.0\n", ("sensor: expected the table [sensor] (one radar's mounting), got an array of "
     "tables [[sensor]]; a rig of several radars is [[sensors]]")),
])
def test_a_faulty_rig_is_refused_in_one_line_naming_the_table_and_key(tmp_path, capsys, body, says):
    f = write(tmp_path / "bad.toml", body)
    with pytest.raises(ConfigError, match=None) as exc:
        load_config(f)
    assert says in str(exc.value), str(exc.value)
    assert main(["dump-config", "--config", str(f)]) == 1
    assert says in one_line_error(capsys)


# ------------------------------------------------------------------------------------------------
# Runs: the precedence, bit for bit
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> dict[str, Path]:
    """One synthetic rig recording three ways: with its sensors.csv (``own``), without (``bare``),
    and with a wrong sensors.csv (``wrong``: the rear radar's yaw off by 10 deg)."""
    root = tmp_path_factory.mktemp("rig")
    own = root / "own"
    own.mkdir()
    write_plain(synthetic_recording(duration_s=2.0, sensors=mountings()), own)
    write(own / "sensors.csv", sensors_csv())
    bare, wrong = root / "bare", root / "wrong"
    shutil.copytree(own, bare)
    (bare / "sensors.csv").unlink()
    shutil.copytree(own, wrong)
    write(wrong / "sensors.csv", sensors_csv([RIG[0], (1, -1.0, 0.25, 170.0, "rear")]))
    return {"own": own, "bare": bare, "wrong": wrong, "root": root}


def _run(rec: Path, out: Path, capsys, *extra: str) -> tuple[int, str]:
    code = main(["run", "--recording", str(rec), "--out", str(out), *extra])
    return code, capsys.readouterr().err


RESULTS = ("trajectory.csv", "trajectory_tum.txt", "map.csv")


def _same_results(a: Path, b: Path) -> bool:
    return all((a / f).read_bytes() == (b / f).read_bytes() for f in RESULTS)


def test_a_config_rig_runs_as_sensors_csv_does_bit_for_bit_and_wins_over_it(recordings, tmp_path, capsys):
    ref = tmp_path / "ref"
    code, err = _run(recordings["own"], ref, capsys, "--config", str(write(tmp_path / "py.toml", PYTHON)))
    assert code == 0, err
    cfg = write(tmp_path / "rig.toml", PYTHON + rig_toml())
    for name in ("bare", "wrong"):              # no sensors.csv; a wrong one, which the config's rig replaces
        out = tmp_path / name
        code, err = _run(recordings[name], out, capsys, "--config", str(cfg))
        assert code == 0, err
        assert _same_results(ref, out), name
        run = json.loads((out / "run.json").read_text())
        assert run["sensors_file"] is None and run["rig_from"] == "config"
        saved = load_config(out / "config.toml")     # the saved config holds the rig, and runs the same
        assert saved.sensors == load_config(cfg).sensors
    assert json.loads((ref / "run.json").read_text())["rig_from"] == "recording"
    # the saved config.toml runs again to the same numbers
    again = tmp_path / "again"
    assert _run(recordings["bare"], again, capsys, "--config", str(tmp_path / "bare" / "config.toml"))[0] == 0
    assert _same_results(ref, again)
    # negative control: the wrong sensors.csv alone gives another run (the rig matters to these numbers)
    wrong = tmp_path / "wrong_own"
    assert _run(recordings["wrong"], wrong, capsys, "--config", str(tmp_path / "py.toml"))[0] == 0
    assert not _same_results(ref, wrong)


def test_sensors_file_wins_over_the_config_rig(recordings, tmp_path, capsys):
    ref = tmp_path / "ref"
    assert _run(recordings["own"], ref, capsys, "--config", str(write(tmp_path / "py.toml", PYTHON)))[0] == 0
    bad_rig = write(tmp_path / "bad_rig.toml", PYTHON + rig_toml([RIG[0], (1, 0.0, 0.0, 90.0, "rear")]))
    out = tmp_path / "out"
    code, err = _run(recordings["bare"], out, capsys, "--config", str(bad_rig), "--sensors",
                     str(recordings["own"] / "sensors.csv"))
    assert code == 0, err
    assert _same_results(ref, out)
    run = json.loads((out / "run.json").read_text())
    assert run["rig_from"] == "--sensors" and run["sensors_file"] == str(recordings["own"] / "sensors.csv")


def test_a_detection_without_a_mounting_in_the_config_rig_is_refused_in_one_line(recordings, tmp_path, capsys):
    cfg = write(tmp_path / "front.toml", PYTHON + rig_toml([RIG[0]]))
    out = tmp_path / "out"
    code, err = _run(recordings["own"], out, capsys, "--config", str(cfg))
    assert code == 1 and len(err.strip().splitlines()) == 1, err
    assert "sensor 1 has no mounting in the config's [[sensors]]" in err and str(cfg) in err, err
    assert "which holds sensors 0" in err and "--sensors FILE" in err, err
    assert not out.exists()


def test_a_run_without_odometry_refuses_a_config_rig(tmp_path, capsys):
    """As ``--sensors`` is: a run from Doppler alone takes one radar, its mounting ``[sensor]``."""
    cfg = write(tmp_path / "rig.toml", rig_toml())
    code, err = _run(tmp_path / "x.bag", tmp_path / "out", capsys, "--radar-topic", "/r", "--config", str(cfg))
    assert code == 1 and "[[sensors]]" in err and "odometry" in err, err


# ------------------------------------------------------------------------------------------------
# calibrate
# ------------------------------------------------------------------------------------------------
def test_calibrate_takes_the_config_rig_and_sensors_file_as_run_does(tmp_path, capsys):
    from test_calibrate import MOUNT, simulated_rig

    rig = simulated_rig(np.array([0.0, 1.0, 1.0, 0.0, 0.0]), seconds=4.0)
    degrees = [0.0, 90.0, -90.0, 174.0, -176.0]
    table = [(i, float(MOUNT[i, 0]), float(MOUNT[i, 1]), d, rig.names[i]) for i, d in enumerate(degrees)]
    own = tmp_path / "own"
    own.mkdir()
    np.savetxt(own / "detections.csv", np.column_stack([rig.t, rig.range_m, rig.azimuth, rig.doppler,
                                                          rig.sensor_ids[rig.sensor]]),
               delimiter=",", header="t_s,range_m,azimuth_rad,doppler_mps,sensor_id", comments="", fmt="%.6f")
    np.savetxt(own / "odometry.csv", rig.odometry, delimiter=",", header="t_s,speed_mps,yaw_rate_rad_s",
               comments="", fmt="%.6f")
    write(own / "sensors.csv", sensors_csv(table))
    bare = tmp_path / "bare"
    shutil.copytree(own, bare)
    (bare / "sensors.csv").unlink()
    cfg = write(tmp_path / "rig.toml", rig_toml(table))
    files = ("calibration.csv", "sensors_calibrated.csv", "ego_velocity.csv")
    assert main(["calibrate", "--recording", str(own), "--out", str(tmp_path / "ref")]) == 0
    assert main(["calibrate", "--recording", str(bare), "--config", str(cfg), "--out", str(tmp_path / "cfg")]) == 0
    wrong = write(tmp_path / "wrong.toml", rig_toml([(i, 0.0, 0.0, 0.0, n) for i, _, _, _, n in table]))
    assert main(["calibrate", "--recording", str(bare), "--config", str(wrong), "--sensors", str(own / "sensors.csv"),
                 "--out", str(tmp_path / "file")]) == 0
    for out in ("cfg", "file"):
        for f in files:
            assert (tmp_path / out / f).read_bytes() == (tmp_path / "ref" / f).read_bytes(), (out, f)
    # negative control: the wrong rig alone calibrates otherwise (the rig reaches the numbers)
    assert main(["calibrate", "--recording", str(bare), "--config", str(wrong), "--out", str(tmp_path / "w")]) == 0
    assert (tmp_path / "w" / "calibration.csv").read_bytes() != (tmp_path / "ref" / "calibration.csv").read_bytes()
    capsys.readouterr()
    short = write(tmp_path / "short.toml", rig_toml(table[:2]))
    assert main(["calibrate", "--recording", str(bare), "--config", str(short), "--out", str(tmp_path / "x")]) == 1
    err = one_line_error(capsys)
    assert "sensor_id 2 not in the config's [[sensors]]" in err and "short.toml" in err, err


def test_a_bag_rig_takes_the_config_rig_where_tf_static_has_no_mountings(tmp_path, capsys):
    """A bag of two radar topics without /tf_static: the config's rig gives the mountings, the same run
    as ``--sensors`` with the same rig."""
    from conftest import require

    require("rosbags")
    from test_bag_rig import _rig_msgs, _write_msgs

    bag = _write_msgs(tmp_path / "b", "mcap", lambda m: _rig_msgs(m, ("ra", "rb"), n=6))
    rig = [(0, 2.0, 0.0, 0.0, "front"), (1, -1.0, 0.0, 171.0, "back")]
    base = ["--radar-topic", "/a", "--radar-topic", "/b", "--odom-topic", "/odom"]
    code, err = _run(bag, tmp_path / "file", capsys, *base, "--config", str(write(tmp_path / "py.toml", PYTHON)),
                     "--sensors", str(write(tmp_path / "s.csv", sensors_csv(rig))))
    assert code == 0, err
    code, err = _run(bag, tmp_path / "cfg", capsys, *base, "--config",
                     str(write(tmp_path / "rig.toml", PYTHON + rig_toml(rig))))
    assert code == 0, err
    assert _same_results(tmp_path / "file", tmp_path / "cfg")
    m = json.loads((tmp_path / "cfg" / "metrics.json").read_text())
    assert m["mounting"]["sensors"] == {"0": "front", "1": "back"}
    assert json.loads((tmp_path / "cfg" / "run.json").read_text())["rig_from"] == "config"


def test_the_docs_example_rig_loads():
    """docs/recordings.md "A rig in the config": its TOML example is a valid rig of two radars."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "recordings.md").read_text()
    section = text[text.index("## A rig in the config"):]
    example = section[section.index("```toml\n") + 8:section.index("```", section.index("```toml\n") + 8)]
    cfg = from_dict(tomllib.loads(example))
    assert [s.id for s in cfg.sensors] == [0, 1] and cfg.sensors[1].yaw_deg == 174.2
