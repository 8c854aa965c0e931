"""numba's compiled-code cache as a user meets it: a read-only install, a cold cache, the warm-up.

docs/architecture.md "Backends": numba caches machine code beside the sources, or in a user cache
directory when the package directory cannot be written (a system install); the first Monte Carlo
on a machine says that it is compiling and compiles on two cores (compiling/warmup.py).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import radarslam
from radarslam.config import profile_config
from radarslam.montecarlo import trials as mc
from radarslam.compiling import costs, policy, readiness, warmup

from conftest import require

PACKAGE = Path(radarslam.__file__).resolve().parent

# A small cached kernel of the package, run in a fresh interpreter; prints numba's cache hits.
PROBE = """
import numpy as np
from radarslam.metrics._compiled import _assign
print(_assign(np.array([[1.0, 2.0], [2.0, 0.5]])).tolist(), sum(_assign.stats.cache_hits.values()))
"""


def _read_only_copy(tmp_path: Path) -> Path:
    """The package copied and made unwritable: read-only modes, and in every package directory a
    plain file where ``__pycache__`` would go, so that nothing can be cached beside the sources
    even by root (for whom the modes alone do not stop writes)."""
    root = tmp_path / "site"
    shutil.copytree(PACKAGE, root / "radarslam", ignore=shutil.ignore_patterns("__pycache__"))
    dirs = [Path(d) for d, _, _ in os.walk(root / "radarslam")]
    for d in dirs:
        (d / "__pycache__").write_text("not a directory: this install is read-only\n")
        for p in d.iterdir():
            if p.is_file():
                p.chmod(0o444)
    for d in sorted(dirs, reverse=True):
        d.chmod(0o555)
    return root


def _probe(site: Path, cache_home: Path) -> tuple[str, int]:
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "PYTHONPATH")}
    env.update(PYTHONPATH=str(site), XDG_CACHE_HOME=str(cache_home), HOME=str(cache_home))
    out = subprocess.run([sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, check=True)
    assignment, hits = out.stdout.rsplit(" ", 1)
    return assignment, int(hits)


def test_read_only_install_caches_in_the_user_cache_directory(tmp_path):
    """A package directory that cannot be written: the compiled code goes to the user's cache
    directory, the package is left as it was, and a second process loads the code from there."""
    require("numba")
    site, home = _read_only_copy(tmp_path), tmp_path / "home"
    first, hits1 = _probe(site, home)
    assert first == "[0, 1]" and hits1 == 0                       # compiled in this process
    assert not [p for p in (site / "radarslam").rglob("*") if p.suffix in (".nbi", ".nbc")]   # install untouched
    assert list(home.rglob("*.nbi")) and list(home.rglob("*.nbc"))
    second, hits2 = _probe(site, home)
    assert second == first and hits2 >= 1                         # loaded from the user cache


def test_cache_is_cold_in_an_empty_cache_directory(tmp_path):
    """The cold-cache test the warm-up relies on: True with an empty NUMBA_CACHE_DIR (a fresh
    interpreter, nothing compiled), False in this process once the engine's code is cached, and
    False in a fresh interpreter on this process's cache (the warm-up marked what it compiled)."""
    require("numba")
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "empty"))
    code = "from radarslam.compiling.readiness import cache_is_cold; print(cache_is_cold())"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "True"
    warmup.warm_up(profile_config(), mc.DEFAULT_VARIANTS, lambda s: None, parallel=False)
    assert readiness.cache_is_cold() is False
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_warm_up_says_it_compiles_and_leaves_results_unchanged(tmp_path, monkeypatch):
    """With the cache taken as cold, the Monte Carlo logs the compiling line once, runs the
    two-process warm-up, and stores the same trials bit for bit as a run without it."""
    require("numba")
    cfg = profile_config()
    logs: list[str] = []
    mc.run_montecarlo(cfg, 5, 2, tmp_path / "plain", jobs=1, progress=False, log=logs.append)
    assert not any(warmup.COMPILING in line for line in logs)
    monkeypatch.setattr(policy, "cache_is_cold", lambda: True)
    monkeypatch.setattr(policy, "first_run_engine", lambda *a: "auto")     # a long run: the fused engine first
    logs.clear()
    mc.run_montecarlo(cfg, 5, 2, tmp_path / "warm", jobs=2, progress=False, log=logs.append)
    assert sum(warmup.COMPILING in line for line in logs) == 1
    for t in (1, 2):
        a = np.load(tmp_path / "plain" / "trials" / f"trial_{t:06d}.npz")
        b = np.load(tmp_path / "warm" / "trials" / f"trial_{t:06d}.npz")
        for key in a.files:
            if key != "__meta__":                                   # meta holds wall times
                assert np.array_equal(a[key], b[key], equal_nan=True), key


# A fresh interpreter on this process's cache: the readiness of the default engine, the simulation
# and the evaluation, with the stamp of every source taken as another file's when asked.
STALE = """
import sys
from radarslam.compiling import markers, readiness
if sys.argv[1] == "edited":
    markers._source_stamp = lambda source: "another source"
print(readiness.cache_is_cold(), readiness.fused_is_cold())
"""


def test_a_stale_marker_counts_as_cold():
    """A marker written for another version of the source (an upgraded install) stands for no code
    numba will load: readiness must take it as cold, not only a missing marker. Negative control:
    the same marker for its own source is fresh. (tests/test_compile_markers.py edits a real file.)"""
    require("numba")
    from radarslam.compiling import markers
    from radarslam.slam._fused import run_stream

    warmup.warm_up(profile_config(), mc.DEFAULT_VARIANTS[:1], lambda s: None, parallel=False)
    if not markers.is_marked(run_stream):    # the warm-up only compiles a cold engine; make sure it is marked
        from radarslam.slam.driver import run_filter
        run_filter(profile_config(), warmup._tiny_stream())
        markers.mark(run_stream)
    assert markers.is_marked(run_stream) is True
    assert readiness.has_fresh_code(run_stream) is True
    fresh = subprocess.run([sys.executable, "-c", STALE, "as-is"], capture_output=True, text=True, check=True)
    assert fresh.stdout.split() == ["False", "False"]
    edited = subprocess.run([sys.executable, "-c", STALE, "edited"], capture_output=True, text=True, check=True)
    assert edited.stdout.split() == ["True", "True"]


def test_first_run_engine_takes_the_steps_form_while_it_ends_sooner():
    """The choice of a cold first run (compiling/warmup.py): the steps form up to the trial
    count where compiling the fused engine first pays for itself, computed from the measured
    costs, and the fused engine beyond it; more workers move the boundary up in proportion."""
    per = costs.STEPS_S - costs.FUSED_S
    saved = costs.FUSED_COMPILE_S - costs.STEPS_WARM_UP_S
    boundary = int(saved / per * 2 / 3)                  # three variants on two workers
    assert boundary == 1692
    assert costs.first_run_engine(200, 3, 2) == "steps"           # the README's main job
    assert costs.first_run_engine(boundary, 3, 2) == "steps"
    assert costs.first_run_engine(boundary + 1, 3, 2) == "auto"
    assert costs.first_run_engine(5000, 3, 2) == "auto"
    assert costs.first_run_engine(int(saved / per * 4 / 3), 3, 4) == "steps"
    assert costs.first_run_engine(boundary + 1, 3, 1) == "auto"         # one worker: less time to save
    # a few trials: the Python reference whole at once, up to where the steps form's warm-up pays
    few = int(costs.STEPS_WARM_UP_S / (costs.PYTHON_TRIAL_S - costs.STEPS_S) * 2 / 3)
    assert 20 <= few <= 100                           # reproduce --trials 2 at once, --trials 200 not
    assert costs.first_run_engine(2, 3, 2) == "python"
    assert costs.first_run_engine(few, 3, 2) == "python"
    assert costs.first_run_engine(few + 1, 3, 2) == "steps"
    assert costs.first_run_engine(few + 1, 3, 1) == "steps"              # one worker: python's cost doubles
    assert costs.first_run_engine(few // 2, 3, 1) == "python"


def test_a_short_cold_run_uses_the_steps_form_and_stores_the_same_results(tmp_path, monkeypatch):
    """A cold cache and a short run: the compiling line says the run does not wait, the detached
    compilation is started once, every trial records the steps form, and the results equal a
    fused run's (same associations and landmark counts exactly, values to 1e-9); the report's
    Fig. 2 reruns trial 1 with the engine that stored it, bit for bit. Negative control: the plain
    run's trials record the fused engine."""
    require("numba")
    require("matplotlib")
    from radarslam.compiling import background
    from radarslam.montecarlo.report import write_report

    cfg = profile_config()
    mc.run_montecarlo(cfg, 5, 2, tmp_path / "plain", jobs=1, progress=False, log=lambda s: None)
    started: list = []
    monkeypatch.setattr(policy, "cache_is_cold", lambda: True)
    monkeypatch.setattr(policy, "fused_is_cold", lambda: True)
    monkeypatch.setattr(policy, "_steps_are_cold", lambda: True)
    monkeypatch.setattr(policy, "first_run_engine", lambda *a: "steps")   # a run of some hundred trials
    monkeypatch.setattr(background, "start", lambda *a: started.append(a) or 4242)
    logs: list[str] = []
    mc.run_montecarlo(cfg, 5, 2, tmp_path / "short", jobs=2, progress=False, log=logs.append)
    assert sum(warmup.COMPILING_SHORT.format(s=costs.STEPS_WARM_UP_S) in line for line in logs) == 1
    assert len(started) == 1 and any("pid 4242" in line for line in logs)
    # the steps form's kernels cached, the fused engine still compiling: no compiling line, no
    # second background process, the trials by the steps form again
    monkeypatch.setattr(policy, "_steps_are_cold", lambda: False)
    monkeypatch.setattr(background, "enabled", lambda: True)
    monkeypatch.setattr(background, "busy", lambda: True)
    logs.clear()
    mc.run_montecarlo(cfg, 5, 1, tmp_path / "again", jobs=1, progress=False, log=logs.append)
    assert not any("compiling the numba" in line for line in logs)
    assert sum("still compiling in the background" in line for line in logs) == 1 and len(started) == 1
    assert mc.load_results(tmp_path / "again")["engines"]["consistent"] == ["fused-steps"]
    plain = mc.load_results(tmp_path / "plain")
    short = mc.load_results(tmp_path / "short")
    assert all(e == ["fused", "fused"] for e in plain["engines"].values())
    assert all(e == ["fused-steps", "fused-steps"] for e in short["engines"].values())
    for v in ("noext", "ext", "consistent"):
        a, b = plain[v], short[v]
        assert np.array_equal(a["n_landmarks"], b["n_landmarks"])
        np.testing.assert_allclose(b["poses"], a["poses"], rtol=0, atol=1e-9)
    rep = write_report(tmp_path / "short", n_boot=50)
    assert rep["fig2"]["matches_stored"] is True


def test_a_few_cold_trials_run_the_python_reference_and_store_the_same_results(tmp_path, monkeypatch):
    """A cold cache and a run of a few trials (reproduce --trials 2): no compiling line and no
    warm-up, one line saying the trials go through the Python reference, the detached compilation
    started once, every trial's every variant recorded as "python", and the results equal a
    compiled run's (same landmark counts exactly, poses to 1e-9); the report's Fig. 2 reruns trial 1
    by the reference, bit for bit. Negative control: with the steps form's kernels cached the same
    run takes the steps form (nothing to wait for)."""
    require("numba")
    require("matplotlib")
    from radarslam.compiling import background
    from radarslam.montecarlo.report import write_report

    cfg = profile_config()
    mc.run_montecarlo(cfg, 5, 2, tmp_path / "plain", jobs=1, progress=False, log=lambda s: None)
    started: list = []
    for name in ("cache_is_cold", "fused_is_cold", "_steps_are_cold"):
        monkeypatch.setattr(policy, name, lambda *families: True)
    monkeypatch.setattr(background, "start", lambda *a: started.append(a) or 4242)
    monkeypatch.setattr(warmup, "_steps_trial", lambda *a, **k: pytest.fail("the warm-up ran"))
    logs: list[str] = []
    mc.run_montecarlo(cfg, 5, 2, tmp_path / "few", jobs=2, progress=False, log=logs.append)
    assert not any("compiling the numba" in line for line in logs)
    assert sum(warmup.PYTHON_SHORT in line for line in logs) == 1
    assert len(started) == 1 and any("pid 4242" in line for line in logs)
    plain, few = mc.load_results(tmp_path / "plain"), mc.load_results(tmp_path / "few")
    assert all(e == ["python", "python"] for e in few["engines"].values())
    for v in ("noext", "ext", "consistent"):
        assert np.array_equal(plain[v]["n_landmarks"], few[v]["n_landmarks"])
        np.testing.assert_allclose(few[v]["poses"], plain[v]["poses"], rtol=0, atol=1e-9)
    assert write_report(tmp_path / "few", n_boot=50)["fig2"]["matches_stored"] is True
    monkeypatch.setattr(policy, "_steps_are_cold", lambda *families: False)
    assert warmup.warm_up(cfg, mc.DEFAULT_VARIANTS, lambda s: None, n_trials=2, jobs=2) == "fused-steps"


def test_a_short_warm_up_splits_the_variants_over_its_two_processes(monkeypatch):
    """A short cold run's warm-up (warmup._short_side): the second process simulates and compiles
    the last variant's kernels, this one the others and the evaluation; one variant stays here (the
    second process then only simulates); on one core everything runs here, the simulation and the
    evaluation by a Python-filter trial (warmup._side)."""
    from concurrent.futures import Future

    from radarslam.compiling import background

    calls: list = []

    class Inline:                                  # the second process, recorded instead of started
        def __init__(self, max_workers):
            pass

        def submit(self, f, *args):
            calls.append((f.__name__, args[1:]))
            done = Future()
            done.set_result(None)
            return done

        def shutdown(self, wait=True):
            pass

    for name in ("cache_is_cold", "fused_is_cold", "_steps_are_cold"):
        monkeypatch.setattr(policy, name, lambda *families: True)
    monkeypatch.setattr(background, "start", lambda *a: None)
    monkeypatch.setattr(warmup, "ProcessPoolExecutor", Inline)
    monkeypatch.setattr(warmup, "_steps_trial",
                        lambda cfg, variants, evaluation=False: calls.append(("here", [v.name for v in variants], evaluation)))
    monkeypatch.setattr(warmup, "_side", lambda cfg_dict, overlay: calls.append(("_side", overlay)))
    cfg, variants = profile_config(), mc.DEFAULT_VARIANTS
    assert warmup.warm_up(cfg, variants, lambda s: None, parallel=True, n_trials=200, jobs=2) == "fused-steps"
    assert calls == [("_short_side", (variants[-1:],)), ("here", ["noext", "ext"], True)]
    calls.clear()
    assert warmup.warm_up(cfg, variants[:1], lambda s: None, parallel=True, n_trials=200, jobs=2) == "fused-steps"
    assert calls == [("_short_side", ((),)), ("here", ["noext"], True)]
    calls.clear()
    assert warmup.warm_up(cfg, variants, lambda s: None, parallel=False, n_trials=200, jobs=1) == "fused-steps"
    assert calls == [("here", ["noext", "ext", "consistent"], False), ("_side", dict(variants[0].overlay))]


def test_background_compilation_runs_once_per_cache(tmp_path, monkeypatch):
    """The detached compilation's lock: while one process holds it another is told it is busy and
    nothing is started; turned off by RADARSLAM_BACKGROUND_COMPILE=0; the job itself compiles
    (here: loads) the fused engine, deletes its job file and exits 0, or exits 0 at once when the
    lock is held elsewhere."""
    require("numba")
    import json

    from radarslam.compiling import background, background_job
    from radarslam.config.variants import variants_to_json

    monkeypatch.setattr(background, "lock_path", lambda: tmp_path / "compile.lock")
    monkeypatch.setenv(background.ENV, "1")
    assert background.busy() is False
    job = tmp_path / "job.json"
    job.write_text(json.dumps({"config": mc.to_dict(profile_config()),
                               "variants": variants_to_json(mc.DEFAULT_VARIANTS[:1])}))
    with background.held_lock(tmp_path / "compile.lock") as mine:
        assert mine is True
        assert background.busy() is True
        assert background.start({}, []) is None                     # held: nothing started
        assert background_job.main(str(job)) == 0 and not job.exists()   # held elsewhere: nothing to do
    monkeypatch.setenv(background.ENV, "0")
    assert background.enabled() is False and background.start({}, []) is None
    job.write_text(json.dumps({"config": mc.to_dict(profile_config()),
                               "variants": variants_to_json(mc.DEFAULT_VARIANTS[:1])}))
    from radarslam.compiling import markers
    from radarslam.slam._fused import run_stream

    marker = markers.marker_path(run_stream)
    marker.unlink(missing_ok=True)                                  # the job must leave it
    assert markers.is_marked(run_stream) is False
    assert background_job.main(str(job)) == 0 and not job.exists()
    assert markers.is_marked(run_stream) is True and readiness.has_fresh_code(run_stream) is True


def test_first_run_engine_scans_for_a_recording():
    """One run of a recording on a cold cache: event by event up to the scan count where the fused
    engine's compilation pays for itself, from the measured costs (Victoria Park's whole run,
    about 7,200 scans, well inside); the fused engine beyond."""
    saved = costs.FUSED_COMPILE_S - costs.STEPS_COMPILE_S
    boundary = int(saved / (costs.STEPS_SCAN_S - costs.FUSED_SCAN_S))
    assert 7300 < boundary == 47368
    assert costs.first_run_engine_scans(7300) == "steps"
    assert costs.first_run_engine_scans(boundary) == "steps"
    assert costs.first_run_engine_scans(boundary + 1) == "auto"
