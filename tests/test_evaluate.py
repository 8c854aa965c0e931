"""``radarslam evaluate`` (docs/datasets.md "A whole dataset: radarslam evaluate"): every scene run
as ``radarslam run`` runs it, into one table, resumably.

The scenes are the first 3 s of two shared nuScenes scenes (``../shared/data/nuscenes_radar``),
cut into a temporary folder (the data's licence keeps them out of the repository), run with the
Python reference (``--backend python``: the same results as the compiled engines, no compile).
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from conftest import require
from helpers import first_seconds, shared_data
from radarslam.cli.main import main
from radarslam.core.errors import InputError

SCENES = ("scene-0061", "scene-0655")
#: The options every evaluation here runs its scenes with.
OPTIONS = ["--profile", "automotive", "--backend", "python", "--no-plot", "--quiet"]
#: Figures of a row that are a timing, not a result.
TIMINGS = ("seconds",)


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    base = tmp_path_factory.mktemp("recordings")
    return [first_seconds(shared_data() / "nuscenes_radar" / s, 3.0, base / s) for s in SCENES]


@pytest.fixture(scope="module")
def evaluated(recordings, tmp_path_factory):
    """Both scenes evaluated on two local worker processes: ``(out, stdout)``."""
    import contextlib
    import io

    out = tmp_path_factory.mktemp("evaluation") / "out"
    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        code = main(["evaluate", "--recordings", *map(str, recordings), *OPTIONS, "--workers", "2", "--out", str(out)])
    assert code == 0
    return out, buf.getvalue()


def _rows(out) -> list[dict]:
    return [json.loads((out / "rows" / f"{s}.json").read_text()) for s in json.loads(
        (out / "evaluation.json").read_text())["scenes"]]


def _results(row: dict) -> dict:
    return {k: v for k, v in row.items() if k not in TIMINGS}


def _broken(src, dst):
    """A copy of the recording ``src`` whose detections.csv has a malformed line."""
    shutil.copytree(src, dst)
    lines = (dst / "detections.csv").read_text().splitlines()
    lines[5] = "0.1,not-a-number,oops"
    (dst / "detections.csv").write_text("\n".join(lines) + "\n")
    return dst


def test_each_row_is_the_metrics_json_that_run_writes_for_its_scene(evaluated, recordings, tmp_path, capsys):
    """Every row's figures are the numbers of the scene's metrics.json; the scene's folder holds what
    ``radarslam run`` writes, and a separate ``radarslam run`` of the first scene writes the same
    files, metrics (but for the filter's time) and configuration."""
    from radarslam.runs.evaluate_table import row_from_outputs

    out, stdout = evaluated
    rows = _rows(out)
    assert [r["scene"] for r in rows] == list(SCENES) and all(r["status"] == "ok" for r in rows)
    for r in rows:
        m = json.loads((out / "scenes" / r["scene"] / "metrics.json").read_text())
        run = json.loads((out / "scenes" / r["scene"] / "run.json").read_text())
        assert r["scans"] == m["scans"] and r["position_rmse_m"] == m["position_rmse_m"]
        assert r["heading_rmse_deg"] == m["heading_rmse_deg"]
        assert r["ratio_position"] == m["ratio_to_dead_reckoning"]["position_rmse"]
        assert r["ratio_heading"] == m["ratio_to_dead_reckoning"]["heading_rmse"]
        assert r["nees_time_average"] == m["pose_nees"]["time_average"]
        assert r["nees_share_inside"] == m["pose_nees"]["share_inside_band"]
        for k in ("along_track", "cross_track", "heading"):
            assert r[f"nees_{k}"] == m["pose_nees"]["components"][k]["time_average"] and np.isfinite(r[f"nees_{k}"])
        assert r["ego_speed_rmse_mps"] == m["ego_velocity"]["against_odometry"]["speed_mps"]["rmse"]
        assert r["ego_yaw_rate_rmse_deg_s"] == m["ego_velocity"]["against_odometry"]["yaw_rate_deg_s"]["rmse"]
        assert r["seconds"] == run["wall_seconds"] and r["road_users_in_map"] is None    # nuScenes: no labels
        assert all(isinstance(r[k], float) and np.isfinite(r[k]) for k in ("position_rmse_m", "nees_time_average"))
        assert r["scene"] in stdout
    own = tmp_path / "run"
    assert main(["run", "--recording", str(recordings[0]), *OPTIONS[:-1], "--out", str(own)]) == 0
    capsys.readouterr()
    scene = out / "scenes" / SCENES[0]
    assert sorted(p.name for p in scene.iterdir()) == sorted(p.name for p in own.iterdir())
    a, b = (json.loads((d / "metrics.json").read_text()) for d in (scene, own))
    assert a.pop("filter_seconds") > 0 and b.pop("filter_seconds") > 0
    assert a == b
    assert (scene / "config.toml").read_text() == (own / "config.toml").read_text()
    assert _results(row_from_outputs(SCENES[0], b, {})) == _results(rows[0])
    # the scene's run.json says the radarslam run command that reproduces it
    argv = json.loads((scene / "run.json").read_text())["argv"]
    assert argv[:4] == ["radarslam", "run", "--recording", str(recordings[0])] and argv[-2:] == ["--out", str(scene)]


def test_the_table_summary_and_figure_are_written(evaluated):
    """evaluation.csv and .md hold one row per scene; summary.json the mean, median and bootstrap
    interval of each figure (radarslam.metrics.statistics' bootstrap); evaluation.json the command,
    the configuration, the version and the seeds."""
    from radarslam.metrics.statistics import bootstrap_counts, percentile_interval

    out, _ = evaluated
    csv = (out / "evaluation.csv").read_text().splitlines()
    assert csv[0].startswith("scene,status,scans,seconds,position_rmse_m,") and len(csv) == 3
    md = (out / "evaluation.md").read_text()
    assert "## Summary over the scenes" in md and all(f"| {s} | ok |" in md for s in SCENES)
    s = json.loads((out / "summary.json").read_text())
    x = np.array([r["position_rmse_m"] for r in _rows(out)])
    p = s["figures"]["position_rmse_m"]
    assert (s["ok"], s["failed"], p["scenes"]) == (2, 0, 2)
    assert p["mean"] == pytest.approx(x.mean(), rel=1e-12) and p["median"] == pytest.approx(np.median(x), rel=1e-12)
    counts = bootstrap_counts(2, 2000, np.random.default_rng(np.random.SeedSequence(0)))
    assert p["ci95_mean"] == pytest.approx(percentile_interval(counts @ x / 2), rel=1e-12)
    assert s["figures"]["road_users_in_map"] == {"scenes": 0, "mean": None, "median": None, "ci95_mean": None}
    ev = json.loads((out / "evaluation.json").read_text())
    assert ev["config"]["profile"] == "automotive" and ev["config"]["filter"]["backend"] == "python"
    assert ev["version"] and ev["command"].startswith("radarslam ") and ev["seeds"]["bootstrap"]["seed"] == 0
    assert ev["run_options"][:4] == ["--profile", "automotive", "--backend", "python"]
    if importlib.util.find_spec("matplotlib"):
        assert (out / "ratios.png").stat().st_size > 0


def test_a_second_invocation_runs_nothing_and_gives_the_same_table(evaluated, recordings, tmp_path, capsys):
    out = tmp_path / "out"
    shutil.copytree(evaluated[0], out)
    stamps = {s: (out / "scenes" / s / "run.json").stat().st_mtime_ns for s in SCENES}
    before = {f: (out / f).read_bytes() for f in ("evaluation.csv", "evaluation.md", "summary.json")}
    t0 = time.perf_counter()
    assert main(["evaluate", "--recordings", *map(str, recordings), *OPTIONS, "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert time.perf_counter() - t0 < 10.0
    assert "2 of 2 scenes already finished" in err and "(0 run, 2 resumed, 0 failed)" in err
    assert {s: (out / "scenes" / s / "run.json").stat().st_mtime_ns for s in SCENES} == stamps
    after = {f: (out / f).read_bytes() for f in before}
    # evaluation.md names the command that wrote it (this one: another --out, no --workers); the table is the same
    command = [line for line in after["evaluation.md"].decode().splitlines() if line.startswith("`radarslam evaluate")]
    assert len(command) == 1 and "--workers" not in command[0] and str(out) in command[0]
    strip = (lambda b: "\n".join(line for line in b.decode().splitlines() if not line.startswith("`radarslam evaluate")))
    assert after["evaluation.csv"] == before["evaluation.csv"] and after["summary.json"] == before["summary.json"]
    assert strip(after["evaluation.md"]) == strip(before["evaluation.md"])


def test_a_broken_recording_is_an_error_row_and_the_others_succeed(evaluated, recordings, tmp_path, capsys):
    out = tmp_path / "out"
    shutil.copytree(evaluated[0], out)
    broken = _broken(recordings[0], tmp_path / "broken")
    assert main(["evaluate", "--recordings", *map(str, recordings), str(broken), *OPTIONS, "--out", str(out)]) == 0
    err = capsys.readouterr().err
    rows = _rows(out)
    assert [r["status"] for r in rows[:2]] == ["ok", "ok"] and rows[2]["scene"] == "broken"
    status = rows[2]["status"]
    assert status.startswith("error: ") and "\n" not in status and str(broken / "detections.csv") in status
    assert all(rows[2][k] is None for k in ("scans", "position_rmse_m", "ratio_position"))
    assert "broken: error: " in err and not (out / "scenes" / "broken" / "run.json").exists()
    assert "failed_scenes" in (out / "summary.json").read_text() and json.loads(
        (out / "summary.json").read_text())["failed_scenes"] == ["broken"]
    assert "detections.csv" in (out / "logs" / "broken.txt").read_text()


def _shared_nuscenes():
    root = shared_data() / "nuscenes_official"
    if not (root / "v1.0-mini" / "scene.json").is_file():
        pytest.skip(f"{root} lacks v1.0-mini/scene.json")
    return root


@pytest.mark.parametrize("argv, expected", [
    ([], "--recordings/--dataset: expected recordings or a dataset to evaluate, got neither"),
    (["--recordings", "{rec}", "--dataset", "nuscenes", "{nu}", "--scenes", "all"],
     "--recordings: expected either --recordings or --dataset, got both"),
    (["--recordings", "{rec}", "--scenes", "scene-0061"], "--scenes: expected with --dataset nuscenes|radarscenes"),
    (["--dataset", "nuscenes", "{nu}"], "--scenes: expected with --dataset nuscenes ('all' or the scenes' names)"),
    (["--dataset", "nuscenes", "{nu}", "--scenes", "scene-9999"], "--scenes: expected scenes of "),
    (["--dataset", "nuscenes", "{nu}", "--scenes", "all"], "expected the CAN bus files"),
    (["--dataset", "radarscenes", "{tmp}", "--scenes", "104"], "--scenes: expected "),
    (["--dataset", "kitti", "{tmp}", "--scenes", "all"], "--dataset: expected nuscenes or radarscenes, got 'kitti'"),
    (["--dataset", "radarscenes", "{tmp}", "--scenes", "all", "--version", "v1.0-mini"], "--version: expected with"),
    (["--recordings", "{tmp}/nope"], "--recordings: {tmp}/nope: no such file or directory"),
    (["--recordings", "{rec}", "{rec}"], "--recordings: two recordings named"),
    (["--recordings", "{rec}", "--workers", "0"], "--workers: expected an integer >= 1, got 0"),
    (["--recordings", "{rec}", "--calibration", "{tmp}/none.json"], "{tmp}/none.json"),
])
def test_bad_arguments_are_one_line_errors(argv, expected, recordings, tmp_path, capsys):
    """Exit 1, one line naming the argument, before anything is written."""
    fill = {"rec": str(recordings[0]), "nu": str(_shared_nuscenes()), "tmp": str(tmp_path)}
    out = tmp_path / "out"
    code = main(["evaluate", *[a.format(**fill) for a in argv], *OPTIONS, "--out", str(out)])
    err = capsys.readouterr().err.strip()
    assert code == 1 and len(err.splitlines()) == 1, err
    assert err.startswith("radarslam evaluate: error: ") and expected.format(**fill) in err, err
    assert not out.exists()


def test_a_dataset_scene_that_cannot_be_read_is_an_error_row(tmp_path, capsys):
    """--dataset nuscenes: the shared official tables hold scene-0061 but not its sweeps' records:
    the scene is an error row naming the file, the evaluation ends with its table."""
    out = tmp_path / "out"
    assert main(["evaluate", "--dataset", "nuscenes", str(_shared_nuscenes()), "--scenes", "scene-0061", *OPTIONS,
                 "--out", str(out)]) == 0
    (row,) = _rows(out)
    assert row["scene"] == "scene-0061" and row["status"].startswith("error: ") and ".json" in row["status"]
    capsys.readouterr()


def test_dask_local_1_gives_the_rows_of_the_local_workers(evaluated, recordings, tmp_path, capsys):
    require("distributed")
    out = tmp_path / "out"
    assert main(["evaluate", "--recordings", str(recordings[1]), *OPTIONS, "--dask-local", "1", "--out", str(out)]) == 0
    capsys.readouterr()
    (row,) = _rows(out)
    assert _results(row) == _results(_rows(evaluated[0])[1])


def test_an_unreachable_scheduler_is_one_line(recordings, tmp_path, capsys, monkeypatch):
    require("distributed")
    import radarslam.runs.evaluate as ev

    monkeypatch.setattr(ev, "CONNECT_TIMEOUT_S", 2.0)        # the same refusal, sooner than the 20 s default
    code = main(["evaluate", "--recordings", str(recordings[0]), *OPTIONS, "--scheduler", "tcp://127.0.0.1:9",
                 "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 1 and err.startswith("radarslam evaluate: error: --scheduler: cannot reach tcp://127.0.0.1:9")
    assert len(err.splitlines()) == 1


def test_sigterm_keeps_the_finished_scenes_and_a_rerun_runs_only_the_rest(recordings, tmp_path):
    """SIGTERM once the first scene is finished: exit 130 saying so; the rerun runs the other scene only."""
    import signal
    import subprocess
    import sys

    out = tmp_path / "out"
    argv = [sys.executable, "-m", "radarslam", "evaluate", "--recordings", *map(str, recordings), *OPTIONS,
            "--workers", "1", "--out", str(out)]
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    first = out / "scenes" / SCENES[0] / "run.json"
    deadline = time.time() + 120
    while time.time() < deadline and not first.exists() and p.poll() is None:
        time.sleep(0.05)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    if p.returncode == 0:                                  # both scenes ended before the signal: nothing to show
        pytest.skip("the evaluation ended before SIGTERM reached it")
    assert p.returncode == 130 and "finished scenes are stored" in err and "Traceback" not in err, err
    stamp = first.stat().st_mtime_ns
    done = subprocess.run(argv, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "(1 run, 1 resumed, 0 failed)" in done.stderr and first.stat().st_mtime_ns == stamp
    assert [r["status"] for r in _rows(out)] == ["ok", "ok"]


def test_radarscenes_sequences_give_the_road_users_in_the_map(tmp_path, capsys):
    """--dataset radarscenes DATAROOT --scenes all: every data/sequence_N folder (here 2 s of 105,
    written in the official layout), with its labels: the road users in the map."""
    require("h5py")
    from radarslam.io.recording.plain import read_plain
    from test_radarscenes_official import write_sequence

    plain = read_plain(shared_data() / "radarscenes" / "sequence_105")
    keep = (plain.det_t >= 52.0) & (plain.det_t <= 54.0)            # 2 s with over a thousand road users' detections
    odo = (plain.odo_t >= 51.5) & (plain.odo_t <= 54.5)
    short = dataclasses.replace(plain, det_t=plain.det_t[keep], det_polar=plain.det_polar[keep],
                                channels={k: v[keep] for k, v in plain.channels.items()}, labels=plain.labels[keep],
                                odo_t=plain.odo_t[odo], odo=plain.odo[odo])
    root = tmp_path / "RadarScenes"
    write_sequence(root, short)
    out = tmp_path / "out"
    assert main(["evaluate", "--dataset", "radarscenes", str(root), "--scenes", "all", *OPTIONS, "--out",
                 str(out)]) == 0
    capsys.readouterr()
    (row,) = _rows(out)
    m = json.loads((out / "scenes" / "sequence_105" / "metrics.json").read_text())
    assert row["status"] == "ok" and row["position_rmse_m"] is None and row["ratio_position"] is None   # no truth
    assert row["road_users_in_map"] == m["moving_scores"]["road_user_updated"] is not None
    assert row["road_users_in_map_share"] == m["moving_scores"]["road_user_updated_share"]
    assert m["moving_scores"]["road_user_detections"] > 0


# --- the store and the scenes, without running the filter ---------------------------------------


def _fake_runner(source):
    """A runner that 'runs' a scene by copying ``source``'s metrics.json and run.json into its --out,
    counting its calls."""
    calls = []

    def runner(argv):
        calls.append(argv)
        dst = Path(argv[argv.index("--out") + 1])
        dst.mkdir(parents=True, exist_ok=True)
        for f in ("metrics.json", "run.json"):          # run.json last, as radarslam run writes it
            shutil.copy(source / f, dst / f)
    runner.calls = calls
    return runner


def _config(ev: dict):
    """The configuration evaluation.json holds (its TOML: JSON has no infinity)."""
    import tomllib

    from radarslam.config import from_dict

    return from_dict(tomllib.loads(ev["config_toml"]))


def test_a_scene_cut_short_is_run_again_and_a_lost_row_is_read_again(evaluated, tmp_path):
    """Killed mid-way: a scene folder without run.json is run again; a finished scene whose row was
    not stored yet (killed between its run.json and its row) is not, its row read from its files."""
    from radarslam.config import profile_config
    from radarslam.runs.evaluate import evaluate
    from radarslam.runs.evaluate_scenes import Scene

    src = evaluated[0]
    out = tmp_path / "out"
    shutil.copytree(src, out)
    old = {r["scene"]: r for r in _rows(src)}
    (out / "scenes" / SCENES[1] / "run.json").unlink()                  # cut short: partial files, no run.json
    (out / "rows" / f"{SCENES[0]}.json").unlink()                        # finished, its row not stored
    runner = _fake_runner(src / "scenes" / SCENES[1])
    scenes = [Scene(s, ("--recording", s)) for s in SCENES]
    with pytest.raises(InputError, match="another configuration"):              # another profile: refused
        evaluate(scenes, out, runner, config=profile_config("apsipa"), options=["--backend", "python"],
                 progress=False, log=lambda s: None)
    ev = json.loads((out / "evaluation.json").read_text())
    options = ev["run_options"]
    res = evaluate(scenes, out, runner, config=_config(ev), options=options, progress=False,
                   log=lambda s: None)
    assert (res.computed, res.resumed) == (1, 1) and len(runner.calls) == 1
    assert runner.calls[0][:3] == ["run", "--recording", SCENES[1]] and runner.calls[0][-1] == str(
        out / "scenes" / SCENES[1])
    assert [r["status"] for r in res.rows] == ["ok", "ok"]
    assert res.rows[0] == old[SCENES[0]] and res.rows[1] == old[SCENES[1]]
    assert json.loads((out / "rows" / f"{SCENES[0]}.json").read_text()) == old[SCENES[0]]    # stored again
    # the engine and the figures change no result: the same evaluation without --no-plot, by numba
    same = [o for o in options if o != "--no-plot"]
    cfg = _config(ev)
    cfg = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, backend="numba"))
    res = evaluate(scenes, out, runner, config=cfg, options=same, progress=False, log=lambda s: None)
    assert (res.computed, res.resumed) == (0, 2) and len(runner.calls) == 1


def test_a_directory_in_use_is_refused(evaluated, tmp_path):
    from radarslam.io.results import DirectoryLock
    from radarslam.runs.evaluate import evaluate
    from radarslam.runs.evaluate_scenes import Scene

    out = tmp_path / "out"
    shutil.copytree(evaluated[0], out)
    ev = json.loads((out / "evaluation.json").read_text())
    with DirectoryLock(out), pytest.raises(InputError, match="in use by another run"):
        evaluate([Scene(SCENES[0], ())], out, _fake_runner(out), config=_config(ev),
                 options=ev["run_options"], progress=False)


def test_the_scenes_of_all(tmp_path):
    """nuScenes 'all': the scenes of scene.json with their CAN bus wheel speeds and IMU; RadarScenes
    'all': every data/sequence_N folder by number; a sequence named twice is one scene."""
    from radarslam.runs.evaluate_scenes import nuscenes_scenes, radarscenes_scenes, recording_scenes

    root = tmp_path / "nuscenes"
    (root / "v1.0-mini").mkdir(parents=True)
    (root / "v1.0-mini" / "scene.json").symlink_to(_shared_nuscenes() / "v1.0-mini" / "scene.json")
    (root / "can_bus").mkdir()
    for s in ("scene-0916", "scene-0103"):
        for m in ("zoe_veh_info", "ms_imu"):
            (root / "can_bus" / f"{s}_{m}.json").write_text("[]")
    (root / "can_bus" / "scene-0061_zoe_veh_info.json").write_text("[]")      # no IMU: not taken
    got = nuscenes_scenes(str(root), ["all"], "v1.0-mini")
    assert [s.name for s in got] == ["scene-0103", "scene-0916"]             # scene.json's order
    assert got[0].run_args == ("--dataset", "nuscenes", str(root), "--scene", "scene-0103", "--version", "v1.0-mini")
    data = tmp_path / "rs" / "data"
    for name in ("sequence_10", "sequence_9", "sequence_x"):
        (data / name).mkdir(parents=True)
    (data / "sequence_11").write_text("")
    assert [s.name for s in radarscenes_scenes(str(tmp_path / "rs"), ["all"])] == ["sequence_9", "sequence_10"]
    got = radarscenes_scenes(str(tmp_path / "rs"), ["10", "sequence_10", "9"])
    assert [s.run_args[-1] for s in got] == ["10", "9"]
    npz = tmp_path / "drive.npz"
    npz.write_bytes(b"")
    assert [s.name for s in recording_scenes([str(data / "sequence_9"), str(npz)])] == ["sequence_9", "drive"]


def test_the_summary_of_rows_with_gaps_and_failures():
    from radarslam.runs.evaluate_table import FIGURES, error_row, summary

    base = {k: None for k in FIGURES}
    rows = [{"scene": f"s{i}", "status": "ok", **base, "position_rmse_m": v} for i, v in enumerate((1.0, 2.0, 6.0))]
    rows += [{"scene": "t", "status": "ok", **base}, error_row("bad", "x.csv line 3:\n  bad")]
    s = summary(rows)
    p = s["figures"]["position_rmse_m"]
    assert (s["scenes"], s["ok"], s["failed"], p["scenes"]) == (5, 4, 1, 3)
    assert (p["mean"], p["median"]) == (3.0, 2.0) and 1.0 <= p["ci95_mean"][0] < 3.0 < p["ci95_mean"][1] <= 6.0
    assert rows[-1]["status"] == "error: x.csv line 3: bad" and s["failed_scenes"] == ["bad"]
