"""Configuration loading/validation and the CLI (in-process ``main([...])``)."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from radarslam.cli.main import main
from radarslam.config import from_dict, load_config, profile_config, to_dict, to_toml
from radarslam.core.errors import ConfigError

from conftest import require


def test_toml_round_trip_both_profiles():
    for name in ("apsipa", "reference"):
        cfg = profile_config(name)
        assert from_dict(tomllib.loads(to_toml(cfg))) == cfg


@pytest.mark.parametrize("data,key", [
    ({"landmarks": {"betta": 3.0}}, "landmarks.betta"),
    ({"radar": {"detection_probability": 1.5}}, "radar.detection_probability"),
    ({"radar": {"range_std_m": -0.1}}, "radar.range_std_m"),
    ({"filter": {"range_std_m": "big"}}, "filter.range_std_m"),
    ({"trajectory": {"n_steps": 1.5}}, "trajectory.n_steps"),
    ({"extent": {"use_in_slam": 1}}, "extent.use_in_slam"),
    ({"extent": {"w_mode": "biggest"}}, "extent.w_mode"),
    ({"nonsense": {}}, "nonsense"),
    ({"filter": {"initial_pose": [0.0, 0.0]}}, "filter.initial_pose"),
    ({"profile": "fancy"}, "profile"),
    ({"odometer": 3}, "odometer"),
])
def test_bad_config_is_refused_naming_the_key(data, key):
    with pytest.raises(ConfigError) as ei:
        from_dict(data)
    assert str(ei.value).startswith(key)


def test_profile_key_in_file_and_override(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text('profile = "reference"\n[landmarks]\nbeta = 7.5\n')
    cfg = load_config(f)
    assert cfg.profile == "reference" and cfg.landmarks.beta == 7.5 and cfg.landmarks.merge_distance_m == 3.0
    cfg2 = load_config(f, profile="apsipa")
    assert cfg2.profile == "apsipa" and cfg2.landmarks.beta == 7.5 and cfg2.landmarks.merge_distance_m == 1.5


def test_dump_config_prints_loadable_toml(capsys):
    assert main(["dump-config"]) == 0
    text = capsys.readouterr().out
    assert from_dict(tomllib.loads(text)) == profile_config()
    assert main(["dump-config", "--profile", "reference"]) == 0
    assert 'profile = "reference"' in capsys.readouterr().out


def test_run_writes_all_outputs(tmp_path, capsys):
    out = tmp_path / "r"
    assert main(["run", "--seed", "3", "--out", str(out), "--no-plot"]) == 0
    text = capsys.readouterr().out
    assert "position avg. RMSE (m)" in text and "| vehicle |" in text
    for name in ("metrics.json", "per_step.csv", "trajectory.csv", "map.json", "config.toml", "run.json",
                 "trajectory_tum.txt", "groundtruth_tum.txt"):
        assert (out / name).is_file(), name
    m = json.loads((out / "metrics.json").read_text())["scalars"]
    assert 0.0 < m["position_avg_rmse_m"] < 5.0
    run = json.loads((out / "run.json").read_text())
    assert run["seed"] == 3 and run["config"]["profile"] == "apsipa"
    assert load_config(out / "config.toml") == profile_config()
    traj = np.loadtxt(out / "trajectory.csv", delimiter=",", skiprows=1)
    assert traj.shape == (120, 8)
    # The run is reproducible: the same seed gives the same trajectory file.
    out2 = tmp_path / "r2"
    assert main(["run", "--seed", "3", "--out", str(out2), "--no-plot"]) == 0
    assert (out / "trajectory.csv").read_bytes() == (out2 / "trajectory.csv").read_bytes()


def test_run_with_config_file_and_extent_flag(tmp_path, capsys):
    cfg = tmp_path / "c.toml"
    cfg.write_text("[trajectory]\nn_steps = 30\n")
    out = tmp_path / "o"
    assert main(["run", "--seed", "1", "--config", str(cfg), "--profile", "reference", "--extent",
                 "--out", str(out), "--no-plot"]) == 0
    saved = load_config(out / "config.toml")
    assert saved.trajectory.n_steps == 30 and saved.profile == "reference" and saved.extent.use_in_slam


def test_run_draws_map_when_matplotlib_present(tmp_path, capsys):
    require("matplotlib")
    out = tmp_path / "p"
    assert main(["run", "--seed", "1", "--out", str(out)]) == 0
    png = (out / "map.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000


@pytest.mark.parametrize("content,key", [("[landmarks]\nbetta = 3\n", "landmarks.betta"),
                                         ("[radar]\ndetection_probability = 2.0\n", "radar.detection_probability"),
                                         ("[radar\n", "not valid TOML")])
def test_cli_bad_config_one_line_exit_1(tmp_path, capsys, content, key):
    f = tmp_path / "bad.toml"
    f.write_text(content)
    assert main(["run", "--config", str(f), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert key in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_cli_missing_config_file(tmp_path, capsys):
    assert main(["dump-config", "--config", str(tmp_path / "nope.toml")]) == 1
    assert "no such file" in capsys.readouterr().err


def test_cli_creates_missing_parents(tmp_path, capsys):
    """--out a/b/c on a fresh checkout works as mkdir -p (the README writes under out/)."""
    out = tmp_path / "a" / "b" / "c"
    assert main(["run", "--out", str(out), "--no-plot"]) == 0
    assert (out / "metrics.json").is_file()


def test_cli_out_through_a_file_is_one_line(tmp_path, capsys):
    (tmp_path / "f").write_text("x")
    assert main(["run", "--out", str(tmp_path / "f" / "b")]) == 1
    err = capsys.readouterr().err
    assert "--out" in err and "is a file" in err and err.count("\n") == 1


def test_cli_refuses_unwritable_dir_via_access(tmp_path, capsys, monkeypatch):
    """The same check, independent of the user's privileges (CI runs as root)."""
    import radarslam.io.results as results

    real = results.os.access
    monkeypatch.setattr(results.os, "access", lambda p, mode: False if str(p).endswith("ro") else real(p, mode))
    d = tmp_path / "ro"
    d.mkdir()
    assert main(["run", "--out", str(d)]) == 1
    assert "not writable" in capsys.readouterr().err


def test_cli_refuses_out_that_is_a_file(tmp_path, capsys):
    f = tmp_path / "file"
    f.write_text("x")
    assert main(["run", "--out", str(f)]) == 1
    assert "existing file" in capsys.readouterr().err


def test_cli_negative_seed(tmp_path, capsys):
    assert main(["run", "--seed", "-2", "--out", str(tmp_path / "o")]) == 1
    assert "--seed" in capsys.readouterr().err


def test_extent_noise_defaults_to_the_filter_R_and_can_be_its_own():
    import math

    from radarslam.config import profile_config

    cfg = profile_config("apsipa")
    np.testing.assert_array_equal(cfg.extent.R(cfg.filter.R), cfg.filter.R)
    vp = profile_config("victoria-park")
    np.testing.assert_allclose(vp.extent.R(vp.filter.R), np.diag([0.05**2, math.radians(0.5) ** 2]))
    assert vp.filter.R[0, 0] == pytest.approx(0.15**2)  # SLAM keeps the inflated point-landmark R
    # the motion model owns its control noise: ackermann wheel speed and steering, unicycle speed and turn rate
    from radarslam.models.motion import motion_model_from_config

    np.testing.assert_allclose(motion_model_from_config(vp.filter).control_cov(vp.filter),
                               np.diag([0.1**2, math.radians(0.99) ** 2]))   # the profile's s0 (c.11.10)
    np.testing.assert_allclose(motion_model_from_config(cfg.filter).control_cov(cfg.filter),
                               np.diag([0.02**2, math.radians(0.008) ** 2]))


def test_result_files_are_readable_like_any_file_the_user_writes(tmp_path):
    """Atomic writes go through mkstemp (0600); the result gets 0666 less the umask, as open() would."""
    import os
    import stat

    from radarslam.io.results import atomic_write_text

    old = os.umask(0o022)
    try:
        atomic_write_text(tmp_path / "a.txt", "x")
        assert stat.S_IMODE((tmp_path / "a.txt").stat().st_mode) == 0o644
        os.umask(0o077)
        atomic_write_text(tmp_path / "b.txt", "x")
        assert stat.S_IMODE((tmp_path / "b.txt").stat().st_mode) == 0o600
    finally:
        os.umask(old)


@pytest.mark.parametrize("content,key", [
    ("[trajectory]\nspeed_mps = inf\n", "trajectory.speed_mps: expected a finite number, got inf"),
    ("[filter]\nrange_std_m = -inf\n", "filter.range_std_m: expected a finite number, got -inf"),
    ("[trajectory]\nn_steps = 100000000\n", "trajectory.n_steps: expected a value <= 100000"),
    ("[radar]\npoints_per_m2 = 1e9\n", "radar.points_per_m2: expected a value <= 100.0"),
    ("[radar]\npoints_per_m2 = 90.0\n[world]\nvehicles = [[0.0, 0.0, 100.0, 100.0], [200.0, 0.0, 10.0, 10.0]]\n",
     "radar.points_per_m2: expected at most 100000 expected vehicle detections per scan"),
    ("[radar]\nclutter_rate_per_m2 = 1e6\n", "radar.clutter_rate_per_m2: expected a value <= 10.0"),
    ("[radar]\nclutter_rate_per_m2 = 9.0\nscene_min_m = -1000.0\nscene_max_m = 1000.0\n",
     "radar.clutter_rate_per_m2: expected at most 100000 clutter points per scan"),
    ('profile = "victoria-park"\n', "filter.motion_model: expected 'unicycle' for the car-park simulation"),
])
@pytest.mark.parametrize("command", ["run", "montecarlo"])
def test_config_limits_one_line_and_nothing_left_behind(tmp_path, capsys, content, key, command):
    f = tmp_path / "c.toml"
    f.write_text(content)
    out = tmp_path / "new" / "o"
    extra = ["--trials", "1", "--quiet"] if command == "montecarlo" else []
    assert main([command, "--config", str(f), "--out", str(out)] + extra) == 1
    err = capsys.readouterr().err
    assert key in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (tmp_path / "new").exists()
    # merge_axis_tol_m is the one value meant to admit inf (no axis test)
    f.write_text("[landmarks]\nmerge_axis_tol_m = inf\n")
    assert main(["dump-config", "--config", str(f)]) == 0


@pytest.mark.parametrize("kind", ["binary", "utf16", "directory"])
def test_unreadable_config_files_are_one_line(tmp_path, capsys, kind):
    f = tmp_path / "c.toml"
    if kind == "binary":
        f.write_bytes(bytes(range(256)) * 4)
    elif kind == "utf16":
        f.write_text("[trajectory]\nn_steps = 40\n", encoding="utf-16")
    else:
        f.mkdir()
    assert main(["run", "--config", str(f), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("radarslam run: error: config file") and err.count("\n") == 1, err
    assert not (tmp_path / "o").exists()


def test_run_never_overwrites_a_finished_run_without_being_asked(tmp_path, capsys):
    out = tmp_path / "o"
    cfg = tmp_path / "c.toml"
    cfg.write_text("[trajectory]\nn_steps = 10\n")
    assert main(["run", "--config", str(cfg), "--out", str(out), "--no-plot"]) == 0
    before = (out / "metrics.json").read_bytes()
    capsys.readouterr()
    assert main(["run", "--seed", "2", "--config", str(cfg), "--out", str(out), "--no-plot"]) == 1
    err = capsys.readouterr().err
    assert "--out" in err and "already holds a finished result (run.json)" in err and err.count("\n") == 1
    assert (out / "metrics.json").read_bytes() == before
    assert main(["run", "--seed", "2", "--config", str(cfg), "--out", str(out), "--no-plot", "--overwrite"]) == 0
    assert (out / "metrics.json").read_bytes() != before


def test_a_closed_pipe_exits_quietly(monkeypatch, capsys):
    """`radarslam ... | head`: when the reader has gone, printing raises BrokenPipeError; main() ends
    with exit 0 and no traceback (negative control: the same write to an open pipe succeeds)."""
    import os
    import sys

    r, w = os.pipe()
    os.close(r)                                   # the reader is gone
    stream = os.fdopen(w, "w", buffering=1)       # line-buffered: the first line hits the pipe
    monkeypatch.setattr(sys, "stdout", stream)
    assert main(["dump-config"]) == 0
    assert "Traceback" not in capsys.readouterr().err
    stream.close()                                # its descriptor now points at /dev/null
    r2, w2 = os.pipe()
    monkeypatch.setattr(sys, "stdout", os.fdopen(w2, "w", buffering=1))
    assert main(["dump-config", "--profile", "reference"]) == 0
    sys.stdout.close()
    assert b"profile" in os.read(r2, 100)
    os.close(r2)


def test_summary_explains_values_that_are_not_defined():
    from radarslam.cli.run import _defined

    assert _defined(float("nan"), ".2f", "no vehicle was mapped") == "not defined: no vehicle was mapped"
    assert _defined(1.234, ".2f", "x") == "1.23"


def test_a_long_single_run_shows_progress(tmp_path, capsys, monkeypatch):
    import radarslam.cli.run as run_cli

    monkeypatch.setattr(run_cli, "LONG_RUN_SCANS", 20)
    cfg = tmp_path / "c.toml"
    cfg.write_text("[trajectory]\nn_steps = 25\nturn_end = 20\n")
    assert main(["run", "--config", str(cfg), "--out", str(tmp_path / "o"), "--no-plot"]) == 0
    err = capsys.readouterr().err
    assert "25/25 scans" in err
    cfg.write_text("[trajectory]\nn_steps = 15\nturn_end = 12\n")     # a short run stays quiet
    assert main(["run", "--config", str(cfg), "--out", str(tmp_path / "o2"), "--no-plot"]) == 0
    assert "scans" not in capsys.readouterr().err


@pytest.mark.parametrize("args,key", [(["--trials", "0"], "--trials"), (["--trials", "2", "--jobs", "0"], "--jobs"),
                                      (["--trials", "2", "--seed", "-1"], "--seed")])
def test_montecarlo_argument_errors_leave_no_directory(tmp_path, capsys, args, key):
    out = tmp_path / "new" / "mc"
    assert main(["montecarlo", "--out", str(out), "--quiet"] + args) == 1
    assert key in capsys.readouterr().err
    assert not (tmp_path / "new").exists()


def test_a_profile_extends_another_and_cycles_are_refused(monkeypatch):
    """large-carpark extends apsipa: every value of apsipa it does not set is apsipa's; a profile
    naming an unknown base, or extending itself through another, is a one-line ConfigError."""
    from radarslam import config as cfgmod

    big, paper = to_dict(profile_config("large-carpark")), to_dict(profile_config("apsipa"))
    own = cfgmod._read_profile("large-carpark")
    assert own["extends"] == "apsipa" and "landmarks" not in own
    assert big["landmarks"] == paper["landmarks"] and big["extent"] == paper["extent"]
    for section, table in own.items():
        if isinstance(table, dict):
            for key, value in table.items():
                assert big[section][key] == value
    fake = {"a": {"extends": "b", "landmarks": {"beta": 5.0}}, "b": {"extends": "a"}, "c": {"extends": "nope"}}
    monkeypatch.setattr(cfgmod, "list_profiles", lambda: sorted(fake))
    monkeypatch.setattr(cfgmod, "_read_profile", lambda name: dict(fake[name]))
    with pytest.raises(ConfigError, match=r"profile 'b': extends: expected no cycle, got a -> b -> a"):
        cfgmod.profile_overlay("a")
    with pytest.raises(ConfigError, match=r"profile 'c': extends: expected one of \['a', 'b', 'c'\], got 'nope'"):
        cfgmod.profile_overlay("c")
