"""The first-run rule of the single commands (compiling/first_run.py): a part whose compiled code
is not ready runs through its Python reference, the run says so on its first line and starts the
background compile; the results equal a run whose compiled code is ready. The compile state is
faked (no timed assertions)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from radarslam.cli.main import main
from radarslam.compiling import background, first_run, policy
from radarslam.io.recording.plain import write_plain


def _state(monkeypatch, filt: bool, sim: bool, match: bool, started: list) -> None:
    monkeypatch.setattr(policy, "_filter_ready", lambda: filt)
    monkeypatch.setattr(policy, "_simulation_ready", lambda: sim)
    monkeypatch.setattr(policy, "_matching_ready", lambda: match)
    _fake_background(monkeypatch, started)


def _fake_background(monkeypatch, started: list) -> None:
    """The background compile enabled, idle, and its start recorded in ``started`` (pid 4242)."""
    monkeypatch.setattr(background, "enabled", lambda: True)
    monkeypatch.setattr(background, "busy", lambda: False)
    monkeypatch.setattr(background, "start", lambda *a, **k: started.append(a) or 4242)


def test_choose_names_each_part_that_is_not_ready(monkeypatch):
    started: list = []
    _state(monkeypatch, False, True, False, started)
    c = first_run.choose("numba", simulation=True, matching=True)
    assert c.filter_backend == "python" and c.simulation_compiled and not c.matching_compiled
    assert c.reference_parts == ("filter", "evaluation")
    assert first_run.choose("numba").reference_parts == ("filter",)        # a recording: the filter alone
    _state(monkeypatch, True, True, True, started)
    assert first_run.choose("numba", simulation=True, matching=True) == first_run.FirstRun()
    # the python backend is the reference already: nothing to announce
    assert first_run.choose("python", simulation=True, matching=True).reference_parts == ()


def _run_seed(tmp_path, name, capsys) -> tuple[dict, dict, str]:
    assert main(["run", "--seed", "1", "--out", str(tmp_path / name), "--no-plot"]) == 0
    err = capsys.readouterr().err
    out = tmp_path / name
    return json.loads((out / "metrics.json").read_text()), json.loads((out / "run.json").read_text()), err


def test_run_seed_cold_takes_the_reference_announces_it_and_equals_the_warm_run(tmp_path, monkeypatch, capsys):
    """Cold: the first stderr line announces the reference parts and the background compile (pid);
    run.json says engine "python". Warm (negative control): no announcement, the fused engine.
    The metrics agree to 1e-9 and the trajectories too."""
    pytest.importorskip("numba")
    started: list = []
    _state(monkeypatch, False, False, False, started)
    cold_m, cold_r, err = _run_seed(tmp_path, "cold", capsys)
    first = err.strip().splitlines()[0]
    assert first.startswith("run: first run on this machine") and "filter, simulation, evaluation" in first
    assert "pid 4242" in first and len(started) == 1
    assert cold_r["engine"] == "python"
    _state(monkeypatch, True, True, True, started)
    warm_m, warm_r, err = _run_seed(tmp_path, "warm", capsys)
    assert "first run" not in err and len(started) == 1
    assert warm_r["engine"] == "fused"
    for k, v in warm_m["scalars"].items():
        if isinstance(v, float):
            np.testing.assert_allclose(cold_m["scalars"][k], v, rtol=0, atol=1e-9, err_msg=k)
        else:
            assert cold_m["scalars"][k] == v, k
    a = np.loadtxt(tmp_path / "cold" / "trajectory.csv", delimiter=",", skiprows=1)
    b = np.loadtxt(tmp_path / "warm" / "trajectory.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9)


def test_run_recording_cold_takes_the_reference_and_equals_the_warm_run(tmp_path, monkeypatch, capsys):
    pytest.importorskip("numba")
    from radarslam.config import profile_config
    from radarslam.runs.recording import recording_from_scenario
    from radarslam.simulation.scenario import generate_scenario

    cfg = profile_config("apsipa")
    rec = recording_from_scenario(generate_scenario(cfg, np.random.default_rng(3), compiled=False), cfg.trajectory.dt_s)
    d = tmp_path / "rec"
    d.mkdir()
    write_plain(rec, d)
    started: list = []
    runs = {}
    for name, ready in (("cold", False), ("warm", True)):
        _state(monkeypatch, ready, True, True, started)
        monkeypatch.setattr(policy, "_steps_ready", lambda: ready)   # cold: nothing compiled
        assert main(["run", "--recording", str(d), "--out", str(tmp_path / name)]) == 0
        err = capsys.readouterr().err
        assert ("run: first run on this machine" in err) is (not ready)
        runs[name] = (json.loads((tmp_path / name / "run.json").read_text()),
                      np.loadtxt(tmp_path / name / "trajectory.csv", delimiter=",", skiprows=1))
    assert len(started) == 1
    assert runs["cold"][0]["engine"] == "python" and runs["warm"][0]["engine"] == "fused"
    np.testing.assert_allclose(runs["cold"][1], runs["warm"][1], rtol=0, atol=1e-9)


# --- run --dataset (compiling/stream_plan.py first_run_plan) ---------------------------------------------

def _dataset_state(monkeypatch, fused: bool, steps: bool, started: list) -> None:

    monkeypatch.setattr(policy, "_fused_ready", lambda: fused)
    monkeypatch.setattr(policy, "_steps_ready", lambda: steps)
    _fake_background(monkeypatch, started)


def test_dataset_plan_picks_what_ends_sooner_and_says_how_long(monkeypatch):
    """Cold: a short run takes the reference at once, a whole park compiles the steps form's
    kernels first (with the expected seconds); either way the fused engine goes to the background.
    Warm (negative controls): the fused engine, nothing announced, nothing started."""
    from radarslam.config import profile_config
    from radarslam.runs import dataset
    from radarslam.compiling import costs
    from radarslam.compiling.policy import Plan as FirstRunPlan

    cfg = profile_config("victoria-park")
    started: list = []
    _dataset_state(monkeypatch, False, False, started)
    short = dataset.first_run_plan(cfg, 300, fused=True)
    assert short.engine == "python" and not short.compiles and "300 scans go through the Python reference" in short.announce
    assert f"about {300 * costs.PYTHON_SCAN_S:.0f} s" in short.announce and "pid 4242" in short.announce
    whole = dataset.first_run_plan(cfg, 7230, fused=True)
    assert whole.engine == "steps" and whole.compiles and whole.compile_s == costs.STEPS_COMPILE_S
    assert f"about {costs.STEPS_COMPILE_S:.0f} s" in whole.announce and "compiling" in whole.announce
    # the break-even of the cost model, from its constants
    n = int(costs.STEPS_COMPILE_S / (costs.PYTHON_SCAN_S - costs.STEPS_SCAN_S))
    assert dataset.first_run_plan(cfg, n, True).engine == "python"
    assert dataset.first_run_plan(cfg, n + 2, True).engine == "steps"
    _dataset_state(monkeypatch, False, True, started)
    ready = dataset.first_run_plan(cfg, 7230, fused=True)
    assert ready.engine == "steps" and not ready.compiles and "steps form" in ready.announce
    n_started = len(started)
    _dataset_state(monkeypatch, True, False, started)
    warm = dataset.first_run_plan(cfg, 7230, fused=True)          # compiled, its progress part by part: no note
    assert warm.engine == "fused" and not warm.compiles and warm.announce == ""
    assert warm.expected_s == pytest.approx(7230 * costs.FUSED_SCAN_S)
    assert len(started) == n_started
    assert dataset.first_run_plan(to_python(cfg), 300, fused=False) == FirstRunPlan("python")


def to_python(cfg):
    import dataclasses

    return dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, backend="python"))


def test_run_dataset_cold_takes_the_reference_and_equals_the_fused_engine(victoria_park_dir, tmp_path, monkeypatch,
                                                                          capsys):
    """The first 300 scans of Victoria Park: cold, the CLI announces the reference on its first
    line and metrics.json says engine "python"; the run equals the fused engine's (warm) with the
    same associations and landmark counts on every scan, poses to 1e-9."""
    pytest.importorskip("numba")
    from radarslam.config import profile_config
    from radarslam.runs.dataset import run_dataset, victoria_park_options

    started: list = []
    _dataset_state(monkeypatch, False, False, started)
    out = tmp_path / "cold"
    assert main(["run", "--dataset", "victoria-park", str(victoria_park_dir), "--scans", "300", "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0].startswith("run: first run on this machine") and "Python reference" in err[0], err[0]
    assert json.loads((out / "metrics.json").read_text())["engine"] == "python" and len(started) == 1
    assert not any("ETA" in ln and "ETA --" not in ln for ln in err[1:2])      # no ETA from the first scan alone
    cfg = profile_config("victoria-park")
    runs = {}
    for name, fused in (("cold", False), ("warm", True)):
        _dataset_state(monkeypatch, fused, False, started)
        runs[name] = run_dataset("victoria-park", victoria_park_dir, cfg, n_scans=300, progress=False,
                                 loader_options=victoria_park_options(cfg))
    cold, warm = runs["cold"], runs["warm"]
    assert cold.engine == "python" and warm.engine == "fused"
    np.testing.assert_array_equal(cold.n_associated, warm.n_associated)
    np.testing.assert_array_equal(cold.n_landmarks, warm.n_landmarks)
    np.testing.assert_array_equal(cold.final_map.ids, warm.final_map.ids)
    np.testing.assert_allclose(cold.poses, warm.poses, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cold.final_map.positions, warm.final_map.positions, rtol=0, atol=1e-9)


# --- the progress bar (runs/progress.Progress, drawn by tqdm) -------------------------------------------

def test_progress_writes_one_line_per_decile_to_a_file_and_no_eta_before_a_unit_is_done():
    import io

    from radarslam.runs.progress import Progress

    buf = io.StringIO()
    p = Progress(50, 0, stream=buf, unit="scans")
    assert buf.getvalue() == ""                               # nothing (no ETA) before the first unit
    for _ in range(50):
        p.update()
    lines = buf.getvalue().split("\n")
    assert lines[-1] == "" and "\r" not in buf.getvalue()
    done = [int(ln.split("] ")[1].split("/")[0]) for ln in lines[:-1]]
    assert done == [1, 5, 10, 15, 20, 25, 30, 35, 40, 45, 50]      # the first unit, then each decile
    # a first unit that carries a compile: the clock starts after it, its line shows no ETA
    buf = io.StringIO()
    p = Progress(10, 0, stream=buf, unit="scans", warm_up_unit=True)
    p.update()
    assert buf.getvalue().rstrip().endswith("0.00 scans/s  ETA --")
    p.update()
    assert "ETA --" not in buf.getvalue().splitlines()[-1]


def test_run_dataset_warm_moves_its_progress_part_by_part(victoria_park_dir, tmp_path, monkeypatch, capsys):
    """Warm (the fused engine's code ready), 3,000 scans of Victoria Park: the compiled engine runs the
    stream in parts (slam/fused/chunks.py), so the progress lines come as the scans are done, not all at
    the end; the rate on the last line is the run's (scans over the run's seconds)."""
    pytest.importorskip("numba")
    import re

    from radarslam.slam.fused import chunks, plan as fused_plan

    _dataset_state(monkeypatch, True, False, [])
    monkeypatch.setattr(fused_plan, "Pacer", lambda: chunks.Pacer(first=300, target_s=1e-12, least=300))
    out = tmp_path / "warm"
    assert main(["run", "--dataset", "victoria-park", str(victoria_park_dir), "--scans", "3000", "--out", str(out)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert json.loads((out / "metrics.json").read_text())["engine"] == "fused"
    done = [int(m.group(1)) for ln in err if (m := re.search(r"\] (\d+)/3000 scans", ln))]
    assert done[0] == 300 and done[-1] == 3000 and len(done) >= 10, err     # the first part, then each decile
    assert not any("in one call" in ln for ln in err)
    rate = float(re.search(r"3000/3000 scans\s+([0-9.]+) scans/s", err[[i for i, ln in enumerate(err)
                                                                       if "3000/3000" in ln][0]]).group(1))
    assert 50 < rate < 50_000, err       # 0.02-20 ms a scan


def test_a_recording_plans_by_its_size_the_reference_or_a_compile(monkeypatch):
    """The one compile policy for a recording: from an empty cache a nuScenes-sized
    recording (1,263 scans, 126,749 detections) goes through the reference at once, a RadarScenes-sized
    one (6,478 scans, 1,071,716 detections: minutes through the reference) compiles the
    steps form's kernels first; the old rule took the reference for both (409 s measured)."""
    from radarslam.compiling.costs import STEPS_COMPILE_S
    from radarslam.compiling.policy import Workload, plan, python_seconds
    from radarslam.config import profile_config

    cfg = profile_config("automotive")
    monkeypatch.setattr(policy, "_filter_ready", lambda *f: False)
    monkeypatch.setattr(policy, "_steps_ready", lambda: False)
    small = plan(cfg, Workload("stream", n_scans=1263, n_detections=126_749, fused=True))
    big = plan(cfg, Workload("stream", n_scans=6478, n_detections=1_071_716, fused=True))
    assert small.engine == "python" and not small.compiles and small.expected_s < 30
    assert big.engine == "steps" and big.compiles and big.compile_s == STEPS_COMPILE_S
    assert python_seconds(6478, 1_071_716) > 300 and big.expected_s < 100
    assert f"about {python_seconds(6478, 1_071_716):.0f} s" in big.announce   # the reference's cost it avoided, said
    # warm (negative control): the fused engine, whatever the size
    monkeypatch.setattr(policy, "_filter_ready", lambda *f: True)
    assert plan(cfg, Workload("stream", n_scans=6478, n_detections=1_071_716)).engine == "fused"
