"""The first-run rule of the single commands (experiments/first_run.py): a part whose compiled code
is not ready runs through its Python reference, the run says so on its first line and starts the
background compile; the results equal a run whose compiled code is ready. The compile state is
faked (no timed assertions)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from radarslam.cli.main import main
from radarslam.experiments import background, first_run
from radarslam.io.recording.plain import write_plain


def _state(monkeypatch, filt: bool, sim: bool, match: bool, started: list) -> None:
    monkeypatch.setattr(first_run, "_filter_ready", lambda: filt)
    monkeypatch.setattr(first_run, "_simulation_ready", lambda: sim)
    monkeypatch.setattr(first_run, "_matching_ready", lambda: match)
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
    from radarslam.experiments.recording import recording_from_scenario
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
        assert main(["run", "--recording", str(d), "--out", str(tmp_path / name)]) == 0
        err = capsys.readouterr().err
        assert ("run: first run on this machine" in err) is (not ready)
        runs[name] = (json.loads((tmp_path / name / "run.json").read_text()),
                      np.loadtxt(tmp_path / name / "trajectory.csv", delimiter=",", skiprows=1))
    assert len(started) == 1
    assert runs["cold"][0]["engine"] == "python" and runs["warm"][0]["engine"] == "fused"
    np.testing.assert_allclose(runs["cold"][1], runs["warm"][1], rtol=0, atol=1e-9)
