"""The Monte Carlo runner: determinism across executors, resume, refusal, corruption, crashes."""

from __future__ import annotations

import os
from dataclasses import replace

import numpy as np
import pytest

import radarslam.experiments.montecarlo as mc
from radarslam.config import profile_config
from radarslam.core.errors import InputError, RadarSlamError
from radarslam.experiments.montecarlo import load_results, run_montecarlo, trial_seed
from radarslam.experiments.store import TrialStore, decode_trial

from conftest import require


def short_config(n_steps: int = 40):
    cfg = profile_config()
    return replace(cfg, trajectory=replace(cfg.trajectory, n_steps=n_steps))


def arrays_of(out, trial):
    arrays, _ = decode_trial(TrialStore.read(out).path(trial))
    return arrays


def assert_same_results(a, b, trials):
    for t in trials:
        x, y = arrays_of(a, t), arrays_of(b, t)
        assert x.keys() == y.keys()
        for k in x:
            assert np.array_equal(x[k], y[k], equal_nan=True), (t, k)


@pytest.fixture(scope="module")
def reference_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("mc_ref")
    run_montecarlo(short_config(), 11, 4, out, jobs=1, progress=False)
    return out


def test_trial_seed_is_the_spawned_child():
    kids = np.random.SeedSequence(5).spawn(7)
    for t in (1, 4, 7):
        a = np.random.default_rng(kids[t - 1]).random(5)
        b = np.random.default_rng(trial_seed(5, t)).random(5)
        assert np.array_equal(a, b)


def test_jobs_2_equals_jobs_1_bit_for_bit(reference_run, tmp_path):
    run_montecarlo(short_config(), 11, 4, tmp_path, jobs=2, progress=False)
    assert_same_results(reference_run, tmp_path, range(1, 5))


def test_dask_local_cluster_equals_local_run(reference_run, tmp_path):
    require("distributed")
    run_montecarlo(short_config(), 11, 4, tmp_path, dask_local=2, progress=False)
    assert_same_results(reference_run, tmp_path, range(1, 5))


def test_dask_scheduler_address_equals_local_run(reference_run, tmp_path):
    require("distributed")
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, host="127.0.0.1",
                      dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        run_montecarlo(short_config(), 11, 3, tmp_path, scheduler=cluster.scheduler_address, progress=False)
    assert_same_results(reference_run, tmp_path, range(1, 4))


def test_unreachable_scheduler_is_a_clear_error(tmp_path):
    require("distributed")
    with pytest.raises(InputError, match="--scheduler"):
        run_montecarlo(short_config(), 1, 1, tmp_path, scheduler="tcp://127.0.0.1:9", progress=False)


def test_resume_computes_only_missing_trials(reference_run, tmp_path):
    cfg = short_config()
    s1 = run_montecarlo(cfg, 11, 2, tmp_path, progress=False)
    stamps = {t: os.stat(TrialStore.read(tmp_path).path(t)).st_mtime_ns for t in (1, 2)}
    s2 = run_montecarlo(cfg, 11, 4, tmp_path, progress=False)
    assert (s1.computed, s2.computed, s2.resumed) == (2, 2, 2)
    assert {t: os.stat(TrialStore.read(tmp_path).path(t)).st_mtime_ns for t in (1, 2)} == stamps
    s3 = run_montecarlo(cfg, 11, 4, tmp_path, progress=False)
    assert s3.computed == 0 and s3.resumed == 4
    assert_same_results(reference_run, tmp_path, range(1, 5))
    res = load_results(tmp_path)
    assert res["trials"].tolist() == [1, 2, 3, 4] and res["noext"]["position_error_m"].shape == (4, 40)


def test_other_seed_or_config_is_refused(reference_run):
    with pytest.raises(InputError, match="seed 11, not 12"):
        run_montecarlo(short_config(), 12, 4, reference_run, progress=False)
    with pytest.raises(InputError, match="different configuration"):
        run_montecarlo(short_config(41), 11, 4, reference_run, progress=False)


@pytest.mark.parametrize("damage", ["truncate", "flip", "empty", "swap"])
def test_corrupt_trial_is_detected_and_recomputed(reference_run, tmp_path, damage):
    import shutil

    shutil.copytree(reference_run, tmp_path / "d")
    out = tmp_path / "d"
    store = TrialStore.read(out)
    p = store.path(2)
    data = p.read_bytes()
    if damage == "truncate":
        p.write_bytes(data[: len(data) // 2])
    elif damage == "flip":  # a bit flipped inside an array's bytes: the zip CRC or our checksum catches it
        b = bytearray(data)
        b[len(b) // 2] ^= 0x01
        p.write_bytes(bytes(b))
    elif damage == "empty":
        p.write_bytes(b"")
    else:  # a valid file of another trial under this name
        p.write_bytes(store.path(3).read_bytes())
    good, bad = store.inventory(4)
    assert bad.keys() == {2} and good == [1, 3, 4]
    logs = []
    s = run_montecarlo(short_config(), 11, 4, out, progress=False, log=logs.append)
    assert s.recomputed_corrupt == 1 and s.computed == 1
    assert any("trial 2" in line and "corrupt" in line for line in logs)
    assert_same_results(reference_run, out, range(1, 5))


_REAL_COMPUTE = mc.compute_trial


def _dies_on_trial_3(config, seed, trial):
    """Module level, so the pool pickles it by name; forked workers resolve it."""
    if trial == 3:
        os._exit(9)  # a worker killed mid-trial
    return _REAL_COMPUTE(config, seed, trial)


def test_killed_worker_keeps_finished_trials(reference_run, tmp_path, monkeypatch):
    real = mc.compute_trial
    monkeypatch.setattr(mc, "compute_trial", _dies_on_trial_3)
    with pytest.raises(RadarSlamError, match="worker process died"):
        run_montecarlo(short_config(), 11, 4, tmp_path, jobs=2, progress=False)
    monkeypatch.setattr(mc, "compute_trial", real)
    good, bad = TrialStore.read(tmp_path).inventory(4)
    assert not bad and 3 not in good
    s = run_montecarlo(short_config(), 11, 4, tmp_path, jobs=2, progress=False)
    assert s.computed == 4 - len(good)
    assert_same_results(reference_run, tmp_path, range(1, 5))


def test_ctrl_c_keeps_finished_trials(reference_run, tmp_path, monkeypatch):
    real = mc.compute_trial

    def interrupted_at_3(config, seed, trial):
        if trial == 3:
            raise KeyboardInterrupt
        return real(config, seed, trial)

    monkeypatch.setattr(mc, "compute_trial", interrupted_at_3)
    with pytest.raises(KeyboardInterrupt):
        run_montecarlo(short_config(), 11, 4, tmp_path, jobs=1, progress=False)
    monkeypatch.setattr(mc, "compute_trial", real)
    assert TrialStore.read(tmp_path).inventory(4)[0] == [1, 2]
    run_montecarlo(short_config(), 11, 4, tmp_path, progress=False)
    assert_same_results(reference_run, tmp_path, range(1, 5))


@pytest.mark.parametrize("kw,match", [({"jobs": 0}, "--jobs"), ({"n_trials": 0}, "--trials"),
                                      ({"scheduler": "tcp://x:1", "dask_local": 2}, "--scheduler")])
def test_bad_arguments(tmp_path, kw, match):
    args = {"n_trials": 2, "jobs": 1} | kw
    with pytest.raises(InputError, match=match):
        run_montecarlo(short_config(), 1, args.pop("n_trials"), tmp_path, progress=False, **args)


def test_progress_line_format():
    import io

    buf = io.StringIO()
    p = mc.Progress(10, 2, stream=buf)
    p.update()
    assert "3/10 trials" in buf.getvalue() and "trials/s" in buf.getvalue() and "ETA" in buf.getvalue()


def test_cli_montecarlo_and_report(tmp_path, capsys):
    from radarslam.cli.main import main

    cfg = tmp_path / "short.toml"
    cfg.write_text("[trajectory]\nn_steps = 30\n")
    out = tmp_path / "mc"
    args = ["montecarlo", "--trials", "3", "--seed", "5", "--jobs", "2", "--config", str(cfg), "--out", str(out),
            "--quiet"]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert "## Table 1" in captured.out and "3 trials" in captured.err
    assert (out / "report" / "table1.md").is_file() and (out / "report" / "report.json").is_file()
    assert main(args) == 0  # resume: nothing to compute
    assert "0 computed, 3 resumed" in capsys.readouterr().err
    assert main(["montecarlo", "--trials", "3", "--seed", "6", "--out", str(out), "--quiet", "--no-report"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "seed 5, not 6" in err


def test_cli_reproduce_small(tmp_path, capsys, monkeypatch):
    """reproduce = montecarlo + report with the paper's (apsipa) settings; a short run here."""
    from radarslam.cli.main import main

    out = tmp_path / "rep"
    assert main(["reproduce", "--trials", "2", "--jobs", "1", "--out", str(out), "--quiet", "--no-report"]) == 0
    man = (out / "manifest.json").read_text()
    assert '"seed": 1' in man and "apsipa" in man
    res = load_results(out)
    assert res["noext"]["position_error_m"].shape == (2, 120)


def test_cli_montecarlo_interrupt_reports_stored_trials(tmp_path, capsys, monkeypatch):
    from radarslam.cli.main import main

    real = mc.compute_trial

    def interrupted_at_2(config, seed, trial):
        if trial == 2:
            raise KeyboardInterrupt
        return real(config, seed, trial)

    monkeypatch.setattr(mc, "compute_trial", interrupted_at_2)
    cfg = tmp_path / "short.toml"
    cfg.write_text("[trajectory]\nn_steps = 20\n")
    rc = main(["montecarlo", "--trials", "3", "--config", str(cfg), "--out", str(tmp_path / "o"), "--quiet"])
    assert rc == 130
    assert "1 finished trials are stored" in capsys.readouterr().err


def test_numba_backend_agrees_with_python_backend():
    """Same associations on every scan; poses and maps agree to rounding (not bit for bit)."""
    require("numba")
    from radarslam.experiments.single import run_trial

    base = profile_config()
    fast = replace(base, filter=replace(base.filter, backend="numba"))
    for seed in (1, 2, 3):
        for ext in (False, True):
            a, b = run_trial(base, seed, use_extent=ext), run_trial(fast, seed, use_extent=ext)
            assert np.array_equal(a.record.n_associated, b.record.n_associated)
            assert np.array_equal(a.record.n_landmarks, b.record.n_landmarks)
            assert np.allclose(a.record.poses, b.record.poses, atol=1e-9, rtol=0)
            assert np.allclose(a.record.pose_covs, b.record.pose_covs, atol=1e-12, rtol=1e-9)
            assert np.allclose(a.record.maps[-1].positions, b.record.maps[-1].positions, atol=1e-9)


def test_numba_backend_monte_carlo_is_deterministic_across_jobs(tmp_path):
    require("numba")
    cfg = short_config()
    cfg = replace(cfg, filter=replace(cfg.filter, backend="numba"))
    run_montecarlo(cfg, 3, 3, tmp_path / "a", jobs=1, progress=False)
    run_montecarlo(cfg, 3, 3, tmp_path / "b", jobs=2, progress=False)
    assert_same_results(tmp_path / "a", tmp_path / "b", range(1, 4))


def test_backend_is_part_of_the_directory_identity(reference_run):
    cfg = short_config()
    with pytest.raises(InputError, match="different configuration"):
        run_montecarlo(replace(cfg, filter=replace(cfg.filter, backend="numba")), 11, 4, reference_run,
                       progress=False)
