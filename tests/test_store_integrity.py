"""The Monte Carlo store cannot mix results: trial identities, missing manifests, stray files, the
directory lock, SIGTERM and the worker count (issue "First run works", item 2)."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import profile_config, to_toml
from radarslam.core.errors import InputError
from radarslam.montecarlo import trials as mc
from radarslam.montecarlo.trials import load_results, run_montecarlo
from radarslam.montecarlo.store import ForeignTrial, TrialStore, decode_trial

from conftest import require


def short(n_steps: int = 30):
    cfg = profile_config("apsipa")
    return replace(cfg, trajectory=replace(cfg.trajectory, n_steps=n_steps, turn_end=min(100, n_steps)))


@pytest.fixture(scope="module")
def run_a(tmp_path_factory):
    out = tmp_path_factory.mktemp("a") / "mc"
    run_montecarlo(short(), 5, 3, out, progress=False, log=lambda s: None)
    return out


def test_every_trial_file_carries_its_identity(run_a):
    store = TrialStore.read(run_a)
    for t in (1, 2, 3):
        _, meta = decode_trial(store.path(t))
        assert (meta["trial"], meta["seed"], meta["config_hash"]) == (t, 5, store.chash)
        assert meta["format"] and meta["variants"] == list(store.variant_names)


@pytest.mark.parametrize("other", ["seed", "length"])
def test_a_trial_of_another_run_is_refused_naming_the_file(run_a, tmp_path, other):
    """A sound trial file from another seed or trajectory length, copied under a valid name: resume
    and report refuse with the file's name; the file is neither used nor deleted."""
    out = tmp_path / "mixed"
    shutil.copytree(run_a, out)
    foreign = tmp_path / "foreign"
    if other == "seed":
        run_montecarlo(short(), 6, 2, foreign, progress=False, log=lambda s: None)
    else:
        run_montecarlo(short(40), 5, 2, foreign, progress=False, log=lambda s: None)
    bad = out / "trials" / "trial_000002.npz"
    shutil.copyfile(foreign / "trials" / "trial_000002.npz", bad)
    before = bad.read_bytes()
    with pytest.raises(ForeignTrial, match=r"trial_000002\.npz: a trial of (seed 6|another configuration)"):
        run_montecarlo(short(), 5, 3, out, progress=False, log=lambda s: None)
    with pytest.raises(ForeignTrial, match=r"trial_000002\.npz"):
        load_results(out)
    assert bad.read_bytes() == before
    from radarslam.cli.main import main

    assert main(["report", str(out)]) == 1


def test_a_directory_without_its_manifest_is_rebuilt_only_for_its_own_trials(run_a, tmp_path):
    same = tmp_path / "same"
    shutil.copytree(run_a, same)
    (same / "manifest.json").unlink()
    s = run_montecarlo(short(), 5, 3, same, progress=False, log=lambda s: None)
    assert (s.resumed, s.computed) == (3, 0)                      # rebuilt, nothing recomputed
    other = tmp_path / "other"
    shutil.copytree(run_a, other)
    (other / "manifest.json").unlink()
    with pytest.raises(InputError, match=r"has no manifest\.json, and trial_000001\.npz is a trial of another run"):
        run_montecarlo(short(), 7, 3, other, progress=False, log=lambda s: None)   # never relabelled as seed 7
    assert not (other / "manifest.json").exists()


def test_stray_files_are_ignored_with_a_warning(run_a, tmp_path):
    out = tmp_path / "stray"
    shutil.copytree(run_a, out)
    (out / "trials" / "notes.txt").write_text("mine")
    (out / "trials" / "trial_abc.npz").write_bytes(b"x")
    logs = []
    s = run_montecarlo(short(), 5, 3, out, progress=False, log=logs.append)
    assert s.computed == 0 and s.recomputed_corrupt == 0
    assert sum("ignoring stray file" in line for line in logs) == 2
    res = load_results(out)
    assert list(res["trials"]) == [1, 2, 3] and len(res["stray"]) == 2
    assert (out / "trials" / "notes.txt").read_text() == "mine"


def test_two_runs_on_one_directory_are_prevented(run_a, tmp_path):
    out = tmp_path / "locked"
    shutil.copytree(run_a, out)
    store = TrialStore.read(out)
    with store.lock():
        with pytest.raises(InputError, match="is in use by another run"):
            run_montecarlo(short(), 5, 4, out, progress=False, log=lambda s: None)
    s = run_montecarlo(short(), 5, 4, out, progress=False, log=lambda s: None)   # released: runs
    assert s.computed == 1


def test_jobs_are_capped_at_the_trials_to_compute(run_a, tmp_path, monkeypatch):
    out = tmp_path / "cap"
    shutil.copytree(run_a, out)
    used = []
    monkeypatch.setattr(mc, "_run_pool", lambda *a, **k: used.append(a[5]))
    reference = replace(short(), filter=replace(short().filter, backend="python"))
    run_montecarlo(reference, 5, 2, tmp_path / "py", jobs=8, progress=False, log=lambda s: None)
    assert used == [2]                                             # two trials to compute: two workers, not eight
    used.clear()
    run_montecarlo(short(), 5, 5, out, jobs=8, progress=False, log=lambda s: None)
    # numba: two trials left (a cold compiled-code cache is filled here first, compiling/warmup.py),
    # so two workers; never eight
    assert used == [2]
    used.clear()
    s = run_montecarlo(short(), 5, 3, out, jobs=8, progress=False, log=lambda s: None)
    assert used == [] and s.computed == 0


def test_sigterm_is_handled_like_ctrl_c_and_leaves_no_worker(tmp_path):
    """SIGTERM to a 2-worker run: exit 130, every stored trial sound, no worker process left."""
    psutil = require("psutil")
    cfg = tmp_path / "c.toml"
    cfg.write_text(to_toml(short(120)))
    out = tmp_path / "term"
    p = subprocess.Popen([sys.executable, "-m", "radarslam", "montecarlo", "--trials", "40", "--jobs", "2",
                          "--config", str(cfg), "--out", str(out), "--quiet", "--no-report"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and len(list((out / "trials").glob("trial_*.npz"))) < 2:
        time.sleep(0.1)
    children = psutil.Process(p.pid).children(recursive=True)
    assert children, "the run should have started its workers"
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert "finished trials are stored" in err and "Traceback" not in err
    gone, alive = psutil.wait_procs(children, timeout=10)
    assert not alive, [c.pid for c in alive]
    store = TrialStore.read(out)
    good, bad = store.inventory(40)
    assert good and not bad and len(good) < 40
    json.loads((out / "manifest.json").read_text())
    assert np.isfinite(load_results(out)["noext"]["position_error_m"]).all()


def _quick_trial(cfg_dict, seed, trial, variants, chash, engine):
    time.sleep(0.01)
    return b"%d" % trial


def _sigterm_in(seconds: float) -> threading.Timer:
    timer = threading.Timer(seconds, lambda: os.kill(os.getpid(), signal.SIGTERM))
    timer.start()
    return timer


def _manager_threads_alive(within_s: float = 10.0) -> list:
    deadline = time.time() + within_s
    while True:
        alive = [t for t in threading.enumerate() if type(t).__name__ == "_ExecutorManagerThread"]
        if not alive or time.time() > deadline:
            return alive
        time.sleep(0.05)


@pytest.mark.parametrize("delay_s", [0.05, 0.13, 0.31, 0.57])
def test_an_interrupt_stops_the_pool_between_trials_never_inside_one(monkeypatch, delay_s):
    """SIGTERM during a 2-worker pool is acted on between two waits: no trial's storing is cut
    short, the pool's manager thread ends (a KeyboardInterrupt raised inside ``wait`` once left it
    blocked on futures' locks, and the command hung at exit), and the handlers are put back."""
    monkeypatch.setattr(mc, "compute_trial", _quick_trial)
    started, ended = [], []

    def finish(t, data):                       # a slow store: an interrupt raised here would show
        started.append(t)
        time.sleep(0.03)
        ended.append(t)

    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    with mc._sigterm_as_interrupt():
        _sigterm_in(delay_s)
        with pytest.raises(KeyboardInterrupt):
            mc._run_pool({}, 1, (), list(range(1, 401)), finish, 2, "h")
    assert started and started == ended
    assert not _manager_threads_alive()
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == before


def _big_trial(cfg_dict, seed, trial, variants, chash, engine):
    return b"x" * (16 << 20)                   # a worker spends nearly all its time handing this back


def test_a_worker_ended_while_handing_back_a_trial_leaves_no_thread_waiting(monkeypatch, tmp_path):
    """SIGTERM while workers hand back large trials: the pool's manager thread ends and the spool
    directory is gone. Trials' bytes once went back over the result pipe; a worker ended in the
    middle of one left the manager thread waiting for the rest for ever, and the command hung at
    exit (CI, test_sigterm_is_handled_like_ctrl_c_and_leaves_no_worker). The negative control below
    shows that hang with the bytes sent back."""
    monkeypatch.setattr(mc, "compute_trial", _big_trial)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    stored = []
    with mc._sigterm_as_interrupt():
        _sigterm_in(0.5)
        with pytest.raises(KeyboardInterrupt):
            mc._run_pool({}, 1, (), list(range(1, 401)), lambda t, data: stored.append(len(data)), 2, "h")
    assert stored and set(stored) == {16 << 20}
    assert not _manager_threads_alive()
    assert list(tmp_path.iterdir()) == []


_BYTES_OVER_THE_PIPE = """
import os, signal, sys, threading, time
from concurrent.futures import ProcessPoolExecutor, wait, FIRST_COMPLETED

def big(i):
    return b"x" * (16 << 20)

if __name__ == "__main__":
    ex = ProcessPoolExecutor(2, initializer=signal.signal, initargs=(signal.SIGTERM, signal.SIG_DFL))
    pending = {ex.submit(big, i) for i in range(400)}
    t0 = time.time()
    while time.time() - t0 < 0.5:
        done, pending = wait(pending, timeout=0.2, return_when=FIRST_COMPLETED)
    for p in list(ex._processes.values()):
        p.terminate()
    ex.shutdown(wait=False, cancel_futures=True)
    time.sleep(5)
    alive = [t for t in threading.enumerate() if type(t).__name__ == "_ExecutorManagerThread"]
    print("stuck" if alive else "ended", flush=True)
    os._exit(0)
"""


def test_negative_control_a_worker_ended_while_sending_bytes_leaves_the_manager_stuck(tmp_path):
    """The hazard that the spool avoids, seen: a plain pool whose workers send 16 MB results back,
    ended while they do, leaves its manager thread blocked (the script leaves with os._exit). Whether
    a worker is caught mid-send is a race (on a loaded machine once in CI none was, at 775bd71): the
    hazard must show in one of three tries."""
    script = tmp_path / "pipe.py"
    script.write_text(_BYTES_OVER_THE_PIPE)
    seen = []
    for _ in range(3):
        out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=120)
        seen.append(out.stdout.strip())
        if seen[-1] == "stuck":
            break
    assert seen[-1] == "stuck", (seen, out.stderr)


def test_negative_control_a_raising_handler_does_cut_a_slow_step_short():
    """What the test above guards against can be seen: SIGTERM's handler raising KeyboardInterrupt
    (outside the pool) cuts a step short at an arbitrary point."""
    started, ended = [], []
    with mc._sigterm_as_interrupt(), pytest.raises(KeyboardInterrupt):
        _sigterm_in(0.05)
        for t in range(100):
            started.append(t)
            time.sleep(0.03)
            ended.append(t)
    assert len(started) == len(ended) + 1


def _trial_bytes() -> bytes:
    from radarslam.montecarlo.store import encode_trial

    rng = np.random.default_rng(2)
    arrays = {"true_poses": rng.normal(size=(120, 3)), "noext/n_landmarks": np.arange(120),
              "noext/scalars": rng.normal(size=12), "noext/flag": np.array([True, False]),
              "noext/empty": np.empty((0, 2)), "noext/one": np.float64(3.5) * np.ones(())}
    return encode_trial(arrays, {"trial": 1, "seed": 1, "variants": ["noext"]})


def test_fast_trial_reader_equals_numpy_and_falls_back():
    """decode_trial reads uncompressed trial files straight from the ZIP (store._read_npz_stored):
    the same arrays, dtypes and shapes as np.load; a compressed .npz goes to np.load."""
    import io

    from radarslam.montecarlo.store import _read_npz_stored

    raw = _trial_bytes()
    fast = _read_npz_stored(raw)
    with np.load(io.BytesIO(raw)) as z:
        ref = {k: z[k] for k in z.files}
    assert fast is not None and set(fast) == set(ref)
    for k in ref:
        assert fast[k].dtype == ref[k].dtype and fast[k].shape == ref[k].shape and np.array_equal(fast[k], ref[k])
        assert fast[k].flags.writeable
    buf = io.BytesIO()
    np.savez_compressed(buf, **ref)
    assert _read_npz_stored(buf.getvalue()) is None              # not the simple form: np.load reads it
    arrays, meta = decode_trial(raw)
    assert meta["trial"] == 1 and np.array_equal(arrays["noext/n_landmarks"], np.arange(120))


@pytest.mark.parametrize("where", ["data", "header", "truncated"])
def test_fast_trial_reader_refuses_damage(where):
    """A flipped byte in an array's data or .npy header, or a cut file: CorruptTrial, never values."""
    from radarslam.montecarlo.store import CorruptTrial

    raw = bytearray(_trial_bytes())
    at = raw.find(b"\x93NUMPY", raw.find(b"true_poses.npy"))
    if where == "data":
        raw[at + 200] ^= 0xFF
    elif where == "header":
        raw[at + 20] ^= 0x01
    else:
        raw = raw[:len(raw) // 2]
    with pytest.raises(CorruptTrial):
        decode_trial(bytes(raw))
