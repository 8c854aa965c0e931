"""The Monte Carlo runner: determinism across executors, resume, refusal, corruption, crashes, variants."""

from __future__ import annotations

import json
import os
import re
from dataclasses import replace

import numpy as np
import pytest

import radarslam.montecarlo.trials as mc
from radarslam.config import profile_config
from radarslam.core.errors import ConfigError, InputError, RadarSlamError
from radarslam.montecarlo.trials import load_results, run_montecarlo, trial_seed
from radarslam.runs.progress import Progress
from radarslam.simulation.trial import run_trial
from radarslam.montecarlo.store import TrialStore, config_hash, decode_trial, encode_trial
from radarslam.config.variants import DEFAULT_VARIANTS, PAPER_VARIANTS, Variant, apply_variant

#: A third variant: the extent in SLAM without its contour sifting (an ablation).
NOSIFT = Variant("nosift", "With extent, no contour sifting", {"extent": {"use_in_slam": True, "contour_sifting": False}})
THREE = DEFAULT_VARIANTS + (NOSIFT,)

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


def test_unreachable_scheduler_is_a_clear_error(tmp_path, monkeypatch):
    require("distributed")
    monkeypatch.setattr(mc, "CONNECT_TIMEOUT_S", 2.0)        # the same refusal, sooner than the 20 s default
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
        arrays, _ = decode_trial(p)
        at = data.find(arrays["noext/poses"].tobytes()[:64])
        assert at > 0
        b = bytearray(data)
        b[at + 20] ^= 0x01
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


def _dies_on_trial_3(config, seed, trial, variants=DEFAULT_VARIANTS, chash=None, engine="auto"):
    """Module level, so the pool pickles it by name; forked workers resolve it."""
    if trial == 3:
        os._exit(9)  # a worker killed mid-trial
    return _REAL_COMPUTE(config, seed, trial, variants, chash, engine)


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

    def interrupted_at_3(config, seed, trial, variants=DEFAULT_VARIANTS, chash=None, engine="auto"):
        if trial == 3:
            raise KeyboardInterrupt
        return real(config, seed, trial, variants, chash, engine)

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


def _parse_progress(line):
    m = re.fullmatch(r"\[(#*)(\.*)\] (\d+)/(\d+) trials  ([\d.]+) trials/s  ETA (\d+)m(\d\d)s", line)
    assert m, line
    return len(m[1]), len(m[2]), int(m[3]), int(m[4]), float(m[5]), 60 * int(m[6]) + int(m[7])


def test_progress_line_counts_rate_and_eta():
    p = Progress(10, 2, enabled=False)
    p.t0 = 100.0
    p.update(3)  # 5 of 10 done, 3 new in 1.5 s: 2 trials/s, 5 left: ETA 2.5 s
    fill, empty, done, total, rate, eta = _parse_progress(p.line(now=101.5))
    assert (fill, empty, done, total) == (15, 15, 5, 10)
    assert rate == 2.0 and eta == 2


def test_progress_without_tty_writes_a_first_line_then_one_per_decile():
    import io

    buf = io.StringIO()
    p = Progress(20, 0, stream=buf)
    for _ in range(20):
        p.update()
    lines = buf.getvalue().splitlines()
    done = [_parse_progress(ln)[2] for ln in lines]
    assert done == [1, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20]  # the first, then a new decile every 2 of 20


def test_cli_montecarlo_and_report(tmp_path, capsys):
    from radarslam.cli.main import main

    cfg = tmp_path / "short.toml"
    cfg.write_text("[trajectory]\nn_steps = 30\n")
    out = tmp_path / "mc"
    args = ["montecarlo", "--trials", "3", "--seed", "5", "--jobs", "2", "--config", str(cfg), "--out", str(out),
            "--quiet"]
    assert main(args) == 0
    captured = capsys.readouterr()
    assert captured.out == (out / "report" / "report.md").read_text()  # the report is what is printed
    res = load_results(out)
    assert res["trials"].tolist() == [1, 2, 3] and res["seed"] == 5
    assert res["noext"]["position_error_m"].shape == (3, 30)
    rep = json.loads((out / "report" / "report.json").read_text())
    assert rep["table1"]["n_runs"] == 3 and rep["meta"]["trials"] == [1, 2, 3]
    stamps = {t: os.stat(TrialStore.read(out).path(t)).st_mtime_ns for t in (1, 2, 3)}
    assert main(args) == 0  # resume: nothing to compute
    assert {t: os.stat(TrialStore.read(out).path(t)).st_mtime_ns for t in (1, 2, 3)} == stamps
    capsys.readouterr()
    assert main(["montecarlo", "--trials", "3", "--seed", "6", "--out", str(out), "--quiet", "--no-report"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(out) in err
    assert json.loads((out / "manifest.json").read_text())["seed"] == 5  # refused, not overwritten


def test_cli_reproduce_small(tmp_path, capsys, monkeypatch):
    """reproduce = montecarlo + report with the paper's (apsipa) settings; a short run here."""
    from radarslam.cli.main import main

    out = tmp_path / "rep"
    ov = tmp_path / "noinfl.toml"
    ov.write_text("[extent]\nuse_in_slam = true\ninflate_noise = false\n")
    assert main(["reproduce", "--trials", "2", "--jobs", "1", "--out", str(out), "--quiet", "--no-report",
                 "--variant", f"noinfl={ov}"]) == 0
    man = json.loads((out / "manifest.json").read_text())
    assert man["seed"] == 1 and man["config"]["profile"] == "apsipa"
    assert [(v["name"], v["label"]) for v in man["variants"]] == [("noext", "No extent"), ("ext", "With extent"),
                                                                  ("consistent", "Consistent (beyond the paper)"),
                                                                  ("noinfl", "noinfl")]
    res = load_results(out)
    assert res["noext"]["position_error_m"].shape == (2, 120) and res["noinfl"]["poses"].shape == (2, 120, 3)
    np.testing.assert_array_equal(res["noinfl"]["poses"][1], run_trial(
        apply_variant(res["config"], res["variants"][3]), trial_seed(1, 2)).record.poses)


def test_cli_montecarlo_interrupt_reports_stored_trials(tmp_path, capsys, monkeypatch):
    from radarslam.cli.main import main

    real = mc.compute_trial

    def interrupted_at_2(config, seed, trial, variants=DEFAULT_VARIANTS, chash=None, engine="auto"):
        if trial == 2:
            raise KeyboardInterrupt
        return real(config, seed, trial, variants, chash, engine)

    monkeypatch.setattr(mc, "compute_trial", interrupted_at_2)
    cfg = tmp_path / "short.toml"
    cfg.write_text("[trajectory]\nn_steps = 20\n")
    rc = main(["montecarlo", "--trials", "3", "--config", str(cfg), "--out", str(tmp_path / "o"), "--quiet"])
    assert rc == 130
    good, bad = TrialStore.read(tmp_path / "o").inventory(3)
    assert good == [1] and not bad
    said = re.search(r"(\d+) finished trials are stored in (\S+);", capsys.readouterr().err)
    assert said and int(said[1]) == len(good) and said[2] == str(tmp_path / "o")


def test_numba_backend_monte_carlo_is_deterministic_across_jobs(tmp_path):
    require("numba")
    cfg = short_config()
    cfg = replace(cfg, filter=replace(cfg.filter, backend="numba"))
    run_montecarlo(cfg, 3, 3, tmp_path / "a", jobs=1, progress=False)
    run_montecarlo(cfg, 3, 3, tmp_path / "b", jobs=2, progress=False)
    assert_same_results(tmp_path / "a", tmp_path / "b", range(1, 4))


def test_backend_is_part_of_the_directory_identity(reference_run):
    cfg = short_config()
    other = "python" if cfg.filter.backend == "numba" else "numba"
    with pytest.raises(InputError, match="different configuration"):
        run_montecarlo(replace(cfg, filter=replace(cfg.filter, backend=other)), 11, 4, reference_run,
                       progress=False)


# --------------------------------------------------------------------------------------------- variants


@pytest.fixture(scope="module")
def three_variant_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("mc_three")
    run_montecarlo(short_config(), 11, 3, out, jobs=1, progress=False, variants=THREE)
    return out


def test_variants_run_on_the_same_data(reference_run, three_variant_run):
    """The default two of a 3-variant run equal, bit for bit, a 2-variant run of the same seed; the
    third is the filter of its own configuration on that same simulated trial."""
    for t in (1, 2, 3):
        a, b = arrays_of(reference_run, t), arrays_of(three_variant_run, t)
        assert set(a) < set(b) and {k.split("/")[0] for k in set(b) - set(a)} == {"nosift"}
        for k in a:
            assert np.array_equal(a[k], b[k], equal_nan=True), (t, k)
    tr = run_trial(apply_variant(short_config(), NOSIFT), trial_seed(11, 2))
    b = arrays_of(three_variant_run, 2)
    assert np.array_equal(tr.scenario.truth.poses, b["true_poses"])
    assert np.array_equal(tr.record.poses, b["nosift/poses"])
    assert np.array_equal(tr.metrics["position_error_m"], b["nosift/position_error_m"])
    assert not np.array_equal(b["nosift/poses"], b["ext/poses"])  # the overlay changed the estimate


def test_load_results_has_every_variant_in_order(three_variant_run):
    res = load_results(three_variant_run)
    assert res["variants"] == THREE
    for v in THREE:
        assert res[v.name]["poses"].shape == (3, 40, 3) and res[v.name]["nees"].shape == (3, 40)
        assert res[v.name]["scalars"]["position_avg_rmse_m"].shape == (3,)
    _, meta = decode_trial(TrialStore.read(three_variant_run).path(1))
    names = ["noext", "ext", "consistent", "nosift"]
    assert meta["variants"] == names and set(meta["filter_seconds"]) == set(names)
    assert list(res["filter_seconds"]) == names
    assert res["filter_seconds"]["ext"][0] == meta["filter_seconds"]["ext"] > 0    # trial 1, from its file
    assert all(t.shape == (3,) and np.all(t > 0) for t in res["filter_seconds"].values())
    man = json.loads((three_variant_run / "manifest.json").read_text())
    assert [(v["name"], v["label"], v["overlay"]) for v in man["variants"]] == \
        [(v.name, v.label, v.overlay) for v in THREE]


@pytest.mark.parametrize("variants", [DEFAULT_VARIANTS, THREE[::-1],
                                      DEFAULT_VARIANTS + (Variant("nosift", "renamed", NOSIFT.overlay),),
                                      DEFAULT_VARIANTS + (Variant("nosift", NOSIFT.label, {"extent": {"kappa": 2.0}}),)])
def test_another_variant_list_is_refused(three_variant_run, variants):
    before = {p.name: p.stat().st_mtime_ns for p in (three_variant_run / "trials").iterdir()}
    with pytest.raises(InputError) as ei:
        run_montecarlo(short_config(), 11, 3, three_variant_run, progress=False, variants=variants)
    msg = str(ei.value)
    assert msg.startswith(f"--out: {three_variant_run} holds a Monte Carlo with") and "\n" not in msg
    assert {p.name: p.stat().st_mtime_ns for p in (three_variant_run / "trials").iterdir()} == before


def test_same_variant_list_resumes(three_variant_run, tmp_path):
    import shutil

    shutil.copytree(three_variant_run, tmp_path / "d")
    s = run_montecarlo(short_config(), 11, 4, tmp_path / "d", progress=False, variants=list(THREE))
    assert (s.resumed, s.computed) == (3, 1)
    assert load_results(tmp_path / "d")["nosift"]["poses"].shape == (4, 40, 3)


def test_trial_file_missing_a_variant_is_recomputed(three_variant_run, tmp_path):
    """A valid, checksummed file that lacks one variant of the manifest is corrupt for this directory."""
    import shutil

    out = tmp_path / "d"
    shutil.copytree(three_variant_run, out)
    store = TrialStore.read(out)
    arrays, meta = decode_trial(store.path(2))
    partial = {k: v for k, v in arrays.items() if not k.startswith("nosift/")}
    for listed in (["noext", "ext", "consistent"], ["noext", "ext", "consistent", "nosift"]):  # honest, or claiming all
        store.save(2, encode_trial(partial, dict(meta, variants=listed)))
        decode_trial(store.path(2))  # a sound file in itself
        good, bad = store.inventory(3)
        assert good == [1, 3] and list(bad) == [2] and "nosift" in bad[2]
        assert list(load_results(out)["corrupt"]) == [2]
    logs = []
    s = run_montecarlo(short_config(), 11, 3, out, progress=False, log=logs.append, variants=THREE)
    assert (s.recomputed_corrupt, s.computed) == (1, 1) and any("trial 2" in ln for ln in logs)
    assert decode_trial(store.path(2))[0].keys() == arrays.keys()
    for k, v in decode_trial(store.path(2))[0].items():
        assert np.array_equal(v, arrays[k], equal_nan=True), k


def test_bad_variant_is_refused_before_anything_is_written(tmp_path):
    bad = Variant("bad", "Bad", {"extent": {"use_in_slm": True}})
    with pytest.raises(ConfigError) as ei:
        run_montecarlo(short_config(), 1, 1, tmp_path / "x", progress=False, variants=DEFAULT_VARIANTS + (bad,))
    assert str(ei.value).startswith("variant 'bad': extent.use_in_slm: unknown key")
    assert not (tmp_path / "x").exists()
    with pytest.raises(InputError, match="'ext' twice"):
        run_montecarlo(short_config(), 1, 1, tmp_path / "y", progress=False,
                       variants=DEFAULT_VARIANTS + (Variant("ext", "again", {}),))
    assert not (tmp_path / "y").exists()


def test_directory_written_before_variants_resumes_with_the_default_two(reference_run, tmp_path):
    """A manifest without variants (hash of the configuration alone) and trial files whose meta lists
    none are the default two: they resume and load; any other variant list is refused."""

    out = tmp_path / "old"
    run_montecarlo(short_config(), 11, 4, out, progress=False, variants=PAPER_VARIANTS)
    man = json.loads((out / "manifest.json").read_text())
    del man["variants"]
    man["config_hash"] = config_hash(short_config())
    (out / "manifest.json").write_text(json.dumps(man))
    store = TrialStore.read(out)
    for t in (1, 2, 3, 4):
        arrays, meta = decode_trial(store.path(t))
        del meta["variants"], meta["config_hash"]     # the trial format before variants and identities
        store.save(t, encode_trial(arrays, meta))
    assert store.variants == PAPER_VARIANTS and store.inventory(4) == ([1, 2, 3, 4], {})
    s = run_montecarlo(short_config(), 11, 4, out, progress=False, variants=PAPER_VARIANTS)
    assert (s.resumed, s.computed) == (4, 0)
    res = load_results(out)
    assert np.array_equal(res["ext"]["poses"], load_results(reference_run)["ext"]["poses"])
    with pytest.raises(InputError, match="variants \\['noext', 'ext'\\], not \\['noext', 'ext', 'consistent', 'nosift'\\]"):
        run_montecarlo(short_config(), 11, 4, out, progress=False, variants=THREE)


def test_cli_variant_appends_to_the_default_two(tmp_path, capsys):
    from radarslam.cli.main import main

    cfg = tmp_path / "short.toml"
    cfg.write_text("[trajectory]\nn_steps = 20\n")
    ov = tmp_path / "nosift.toml"
    ov.write_text('label = "no sifting"\n[extent]\nuse_in_slam = true\ncontour_sifting = false\n')
    out = tmp_path / "mc"
    base = ["montecarlo", "--trials", "2", "--config", str(cfg), "--out", str(out), "--quiet", "--no-report"]
    assert main(base + ["--variant", f"nosift={ov}"]) == 0
    res = load_results(out)
    assert [(v.name, v.label) for v in res["variants"]] == [("noext", "No extent"), ("ext", "With extent"),
                                                           ("consistent", "Consistent (beyond the paper)"),
                                                           ("nosift", "no sifting")]
    assert res["nosift"]["poses"].shape == (2, 20, 3)
    capsys.readouterr()
    assert main(base) == 1  # the same directory without the variant
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(out) in err
    for arg in (f"ext={ov}", f"Bad={ov}", "nosift", f"x={tmp_path / 'missing.toml'}"):
        assert main(base[:-4] + ["--out", str(tmp_path / "other"), "--quiet", "--variant", arg]) == 1
        err = capsys.readouterr().err
        assert err.startswith("radarslam montecarlo: error: --variant") and err.count("\n") == 1
    assert not (tmp_path / "other").exists()


@pytest.mark.parametrize("seed, trial, key", [(1, 0, "trial"), (1, -3, "trial"), (1, 1.5, "trial"), (-1, 1, "seed"),
                                              ("1", 1, "seed")])
def test_trial_seed_refuses_bad_numbers_in_one_line(seed, trial, key):
    """Trials are numbered from 1 and seeds are non-negative integers: anything else is refused with
    the argument's name (numpy's own message named neither)."""
    from radarslam.core.errors import InputError
    from radarslam.montecarlo.trials import trial_seed

    with pytest.raises(InputError, match=rf"^{key}: expected an integer"):
        trial_seed(seed, trial)
    assert trial_seed(1, 1).spawn_key == (0,)
