"""The Monte Carlo experiment of the seed paper (Table 1, Figs. 2-3), over any list of variants.

Trial ``t`` (1-based) draws everything from ``SeedSequence(seed).spawn(n)[t - 1]``, i.e.
``SeedSequence(seed, spawn_key=(t - 1,))``, simulates one car park and runs, on that same data,
every configuration variant (:mod:`.variants`; by default "No extent" and "With extent", both
tracking RMA and EFA extents). A trial depends on nothing but the configuration, the variants, the
seed and its number, so results are identical bit for bit whatever runs them: one process, a local
pool, or a Dask cluster. Each finished trial is stored at once (:mod:`.store`); a rerun resumes.
"""

from __future__ import annotations

import contextlib
import signal
import sys
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam.config import Config, from_dict, to_dict, validate
from radarslam.core.errors import InputError, RadarSlamError
from radarslam.simulation.trial import check_simulation_config, evaluate, with_initial_estimate
from radarslam.slam.driver import run_filter
from radarslam.runs.progress import Progress
from radarslam.montecarlo.store import (CorruptTrial, TrialStore, check_identity, config_hash, decode_trial, encode_trial)
from radarslam.config.variants import DEFAULT_VARIANTS, Variant, apply_variant, check_variants
from radarslam.compiling.warmup import warm_up
from radarslam.simulation.scenario import generate_scenario

PER_STEP = ("position_error_m", "heading_error_rad", "nees", "nis_sum", "nis_count", "false_per_scan", "missed_per_scan",
            "stale_per_scan", "gwd_count") + tuple(
    f"gwd_{a}_{c}" for a in ("rma", "efa") for c in ("moment", "full", "inscribed", "enclosing", "shape"))
PER_VEHICLE = ("final_errors", "inclusion_delay", "removal_delay")
SCALARS = ("position_avg_rmse_m", "heading_avg_rmse_deg", "landmark_mae_m", "mean_inclusion_delay",
           "mean_removal_delay", "mean_false", "max_false", "mean_missed", "max_missed", "final_false",
           "final_missed", "n_landmarks_final")


def trial_seed(seed: int, trial: int) -> np.random.SeedSequence:
    """The stream of trial ``trial`` (1-based): ``SeedSequence(seed).spawn(n)[trial - 1]``."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed: expected an integer >= 0, got {seed!r}")
    if isinstance(trial, bool) or not isinstance(trial, (int, np.integer)) or trial < 1:
        raise InputError(f"trial: expected an integer >= 1 (trials are numbered from 1), got {trial!r}")
    return np.random.SeedSequence(seed, spawn_key=(trial - 1,))


def _per_step(m: dict, key: str, K: int) -> np.ndarray:
    """A per-step array of the metrics; a variant that does not track extents has no GWD: NaN (count 0)."""
    if key in m:
        return np.asarray(m[key])
    if key == "gwd_count":
        return np.zeros(K, dtype=int)
    return np.full(K, np.nan)


#: Configurations of the variants already applied, by the base configuration's repr and the
#: variant (:func:`variant_config`).
_VARIANT_CONFIGS: dict[tuple[str, str, str], Config] = {}


def variant_config(config: Config, variant: Variant) -> Config:
    """:func:`~.variants.apply_variant`, remembered per process: building and validating a
    configuration costs ~3.5 ms, its ``repr`` 70 us, and every trial of a run asks for the same
    ones. The configuration returned is shared: read it, do not change it."""
    key = (repr(config), variant.name, repr(variant.overlay))
    c = _VARIANT_CONFIGS.get(key)
    if c is None:
        if len(_VARIANT_CONFIGS) >= 64:
            _VARIANT_CONFIGS.clear()
        c = _VARIANT_CONFIGS[key] = apply_variant(config, variant)
    return c


def compute_trial(config: Config | dict, seed: int, trial: int,
                  variants: Sequence[Variant] = DEFAULT_VARIANTS, chash: str | None = None,
                  engine: str = "auto") -> bytes:
    """Run trial ``trial`` for every variant and return its encoded result (a picklable, top-level worker function).

    The scenario is simulated once from the base ``config``; each variant's configuration
    (:func:`~.variants.apply_variant`) runs the filter on it. Arrays are stored as
    ``"{variant}/{key}"`` beside the shared ``true_poses``; the meta lists the variant names in order
    and the trial's identity: seed, number and the configuration hash ``chash`` of its run (by
    default that of ``config`` and ``variants``). ``engine`` is :func:`~.single.run_filter`'s; the
    meta records which engine ran each variant (``engines``).
    """
    cfg = from_dict(config) if isinstance(config, dict) else config
    variants = check_variants(variants)
    t0 = time.perf_counter()
    ss = trial_seed(seed, trial)
    scenario = generate_scenario(cfg, np.random.default_rng(ss))
    arrays: dict[str, np.ndarray] = {"true_poses": scenario.truth.poses}
    K = scenario.truth.poses.shape[0]
    seconds, engines = {}, {}
    for v in variants:
        c = with_initial_estimate(variant_config(cfg, v), scenario, ss)   # b.5: fixed, or drawn per trial
        rec = run_filter(c, scenario.events, engine=engine)
        m = evaluate(c, scenario, rec)
        name = v.name
        arrays[f"{name}/poses"] = rec.poses
        arrays[f"{name}/n_landmarks"] = rec.n_landmarks
        for key in PER_STEP:
            arrays[f"{name}/{key}"] = _per_step(m, key, K)
        for key in PER_VEHICLE:
            arrays[f"{name}/{key}"] = np.asarray(m[key])
        arrays[f"{name}/scalars"] = np.array([float(m[k]) for k in SCALARS])
        seconds[name] = rec.seconds
        engines[name] = rec.engine
    meta = {"trial": trial, "seed": seed, "spawn_key": [trial - 1], "seconds": time.perf_counter() - t0,
            "filter_seconds": seconds, "engines": engines, "scalar_names": list(SCALARS), "variants": [v.name for v in variants],
            "config_hash": chash or config_hash(cfg, variants)}
    return encode_trial(arrays, meta)


def _limit_threads() -> None:
    """One BLAS thread per worker process (the matrices are tiny; oversubscription only hurts)."""
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover
        pass


def _init_pool_worker() -> None:
    """A pool worker: one BLAS thread; SIGTERM back to its default (end the process) and Ctrl-C
    ignored, the parent deciding (:func:`_run_pool` ends its workers when interrupted). A forked
    worker inherits the parent's handlers; when one raised KeyboardInterrupt, the parent's
    ``terminate`` made the worker block for ever sending that exception back on a queue nobody
    read, holding the parent's output pipes."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _limit_threads()


@dataclass
class MonteCarloSummary:
    out: Path
    n_trials: int
    computed: int
    resumed: int
    recomputed_corrupt: int
    seconds: float


#: How long a Dask client waits for its scheduler before the run is refused (s).
CONNECT_TIMEOUT_S = 20.0


def run_montecarlo(config: Config, seed: int, n_trials: int, out: str | Path, *, jobs: int = 1,
                   scheduler: str | None = None, dask_local: int | None = None, progress: bool = True,
                   log: Callable[[str], None] | None = None,
                   variants: Sequence[Variant] = DEFAULT_VARIANTS) -> MonteCarloSummary:
    """Run (or resume) ``n_trials`` trials into ``out``.

    Parameters
    ----------
    variants : sequence of Variant
        The configurations run on every trial's data, in order (the first is the report's
        baseline); a directory holds one list of variants and refuses another.
    jobs : int
        Local worker processes (1 = in this process).
    scheduler : str, optional
        Address ``tcp://HOST:PORT`` of a running Dask distributed scheduler.
    dask_local : int, optional
        Start a Dask ``LocalCluster`` with this many single-threaded worker processes on loopback.
    """
    log = log or (lambda s: print(s, file=sys.stderr))
    config = check_simulation_config(validate(config))
    if n_trials < 1:
        raise InputError(f"--trials: expected an integer >= 1, got {n_trials}")
    if jobs < 1:
        raise InputError(f"--jobs: expected an integer >= 1, got {jobs}")
    if scheduler is not None and dask_local is not None:
        raise InputError("--scheduler and --dask-local: give one or the other")
    variants = check_variants(variants)
    for v in variants:  # every overlay checked before anything is written or run
        apply_variant(config, v)
    store = TrialStore.open(out, config, seed, variants)
    with store.lock(), _sigterm_as_interrupt():
        return _run_locked(store, config, seed, n_trials, variants, jobs, scheduler, dask_local, progress, log)


def _run_locked(store, config, seed, n_trials, variants, jobs, scheduler, dask_local, progress, log):
    out = store.root
    for p in store.strays():
        log(f"montecarlo: ignoring stray file {p} (not a trial file)")
    good, bad = store.inventory(n_trials)
    for t, why in bad.items():
        log(f"montecarlo: trial {t} file is corrupt ({why}); recomputing it")
        store.path(t).unlink(missing_ok=True)
    todo = [t for t in range(1, n_trials + 1) if t not in set(good)]
    if good:
        log(f"montecarlo: resuming {out}: {len(good)} of {n_trials} trials already stored")
    bar = Progress(n_trials, len(good), enabled=progress)
    t0 = time.perf_counter()
    cfg_dict = to_dict(config)

    def finish(t: int, data: bytes) -> None:
        _, meta = decode_trial(data, expect_trial=t, expect_variants=store.variant_names)  # read back before storing
        check_identity(store.path(t), meta, seed, store.chash)
        store.save(t, data)
        bar.update()

    local_workers = dask_local is not None or (scheduler is None and min(jobs, len(todo)) > 1)
    rest, engine = todo, "auto"
    if todo and scheduler is None:
        # A cold numba cache is filled here, on two cores, before any trial or local worker starts
        # (compiling/warmup.py), and the progress output says so; the workers then load it
        # instead of each compiling the same code (benchmarks/bench_compile.py). A short local run
        # goes through the orchestrator meanwhile, the fused engine compiling in the background.
        engine = warm_up(config, variants, log, parallel=local_workers,
                         n_trials=len(todo) if dask_local is None else None, jobs=jobs)
        bar.restart()
    if rest:
        if scheduler is not None or dask_local is not None:
            _run_dask(cfg_dict, seed, variants, rest, finish, scheduler, dask_local, store.chash)
        elif min(jobs, len(rest)) == 1:
            for t in rest:
                finish(t, compute_trial(config, seed, t, variants, store.chash, engine))
        else:
            _run_pool(cfg_dict, seed, variants, rest, finish, min(jobs, len(rest)), store.chash, engine)
    return MonteCarloSummary(Path(out), n_trials, len(todo), len(good), len(bad), time.perf_counter() - t0)


@contextlib.contextmanager
def _sigterm_as_interrupt():
    """Within the block SIGTERM is handled like Ctrl-C (KeyboardInterrupt): finished trials stay
    stored, workers are ended, the command exits with 130. Only in the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


@contextlib.contextmanager
def _interrupts_as_flag():
    """Within the block Ctrl-C and SIGTERM only set the yielded event; the pool loop raises
    KeyboardInterrupt itself, between two waits. An exception raised by the signal handler at an
    arbitrary point could land inside ``concurrent.futures.wait`` while it holds some futures'
    locks (they are taken one by one, outside any ``try``); the pool's manager thread then blocked
    for ever on them, and the command on that thread at exit, after it had printed that it was
    interrupted (seen once in CI). Outside the main thread: no handler, an event never set."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    old = {s: signal.signal(s, lambda signum, frame: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _spooled_trial(spool: str, cfg_dict: dict, seed: int, trial: int, variants, chash: str, engine: str) -> str:
    """A pool worker's task: compute one trial, write its bytes to a file of ``spool`` and return
    only that file's name. A trial's bytes (about 90 kB) sent back over the pool's result pipe take
    several writes; a worker ended by an interrupt in the middle of them left the parent's manager
    thread waiting for the rest for ever (its own copy of the pipe's write end keeps it open), and
    the command hung at exit after saying it was interrupted (seen in CI). A name of a few dozen
    bytes goes in one write, which a pipe makes atomic (POSIX ``PIPE_BUF``)."""
    data = compute_trial(cfg_dict, seed, trial, variants, chash, engine)
    part = Path(spool) / f"trial_{trial}.part"
    part.write_bytes(data)
    done = part.with_suffix(".npz")
    part.replace(done)         # a worker ended while writing leaves only a .part, removed with the spool
    return done.name


def _run_pool(cfg_dict: dict, seed: int, variants: tuple[Variant, ...], todo: list[int], finish,
              jobs: int, chash: str, engine: str = "auto", poll_s: float = 0.2) -> None:
    import tempfile
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    with _interrupts_as_flag() as stop, tempfile.TemporaryDirectory(prefix="radarslam-pool-") as spool:
        ex = ProcessPoolExecutor(max_workers=jobs, initializer=_init_pool_worker)
        try:
            pending = {ex.submit(_spooled_trial, spool, cfg_dict, seed, t, variants, chash, engine): t for t in todo}
            while pending:
                done, _ = wait(pending, timeout=poll_s, return_when=FIRST_COMPLETED)
                for f in done:
                    t = pending.pop(f)
                    try:
                        name = f.result()
                    except BrokenProcessPool:
                        raise RadarSlamError("a worker process died; every finished trial is stored, "
                                             "rerun the same command to resume") from None
                    spooled = Path(spool) / name
                    data = spooled.read_bytes()
                    spooled.unlink()
                    finish(t, data)
                if stop.is_set():
                    raise KeyboardInterrupt
        except BaseException:
            # Interrupted (Ctrl-C, SIGTERM) or failed: cancel what has not started and end the
            # workers now, so that none is left running a trial after this process is gone.
            procs = list(getattr(ex, "_processes", {}).values())
            for proc in procs:
                proc.terminate()
            for proc in procs:       # one forked before its initializer ran still has the parent's handler
                proc.join(2.0)
                if proc.is_alive():
                    proc.kill()
            ex.shutdown(wait=False, cancel_futures=True)
            raise
        ex.shutdown(wait=True)


def _run_dask(cfg_dict: dict, seed: int, variants: tuple[Variant, ...], todo: list[int], finish,
              scheduler: str | None, dask_local: int | None, chash: str) -> None:
    try:
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise InputError("--scheduler/--dask-local: Dask is not installed; pip install 'radarslam[dask]'") from None
    cluster = None
    if dask_local is not None:
        if dask_local < 1:
            raise InputError(f"--dask-local: expected an integer >= 1, got {dask_local}")
        cluster = LocalCluster(n_workers=dask_local, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=None)
    try:
        try:
            client = Client(cluster if cluster is not None else scheduler, timeout=f"{CONNECT_TIMEOUT_S:g}s")
        except OSError as exc:
            raise InputError(f"--scheduler: cannot reach {scheduler} ({exc})") from None
        try:
            client.run(_limit_threads)
            futures = [client.submit(compute_trial, cfg_dict, seed, t, variants, chash, key=f"radarslam-trial-{seed}-{t}",
                                     pure=False) for t in todo]
            index = {f.key: t for f, t in zip(futures, todo)}
            for f in as_completed(futures):
                finish(index[f.key], f.result())
        finally:
            client.close()
    finally:
        if cluster is not None:
            cluster.close()


def load_results(out: str | Path, n_trials: int | None = None) -> dict:
    """Stack every valid stored trial of ``out``.

    Returns
    -------
    dict
        ``config`` (the base configuration), ``seed``, ``variants`` (tuple of :class:`~.variants.Variant`
        in the run's order; the first is the baseline), ``trials`` (numbers, ascending),
        ``true_poses`` (N, K, 3), and per variant name a dict of stacked arrays: per-step ``(N, K)``,
        per-vehicle ``(N, V)``, ``poses`` ``(N, K, 3)`` and ``scalars`` as a dict of ``(N,)``.
        ``corrupt`` maps skipped trial numbers to the reason (a file lacking a variant is one).
        ``seconds`` (N,) is each trial's wall time, ``filter_seconds`` {variant name: (N,)} its filter's.
    """
    store = TrialStore.read(out)
    numbers = store.stored() if n_trials is None else list(range(1, n_trials + 1))
    loaded, corrupt = [], {}
    for t in numbers:
        if not store.path(t).exists():
            continue
        try:
            arrays, meta = store.load(t)     # a ForeignTrial (another run's file) is raised, never used
        except CorruptTrial as exc:
            corrupt[t] = str(exc)
            continue
        loaded.append((t, arrays, meta))
    if not loaded:
        raise InputError(f"DIR: {out} holds no valid trial")
    res: dict = {"config": store.config, "seed": store.seed, "variants": store.variants,
                 "trials": np.array([t for t, _, _ in loaded]),
                 "corrupt": corrupt, "stray": [str(p) for p in store.strays()], "seconds": np.array([m["seconds"] for _, _, m in loaded]),
                 "filter_seconds": {v.name: np.array([m["filter_seconds"][v.name] for _, _, m in loaded])
                                    for v in store.variants},
                 "engines": {v.name: [m.get("engines", {}).get(v.name, "unrecorded") for _, _, m in loaded]
                             for v in store.variants}}
    res["true_poses"] = np.stack([a["true_poses"] for _, a, _ in loaded])
    names = loaded[0][2]["scalar_names"]
    for v in store.variants:
        prefix = v.name + "/"
        d = {}
        for key in loaded[0][1]:
            if key.startswith(prefix) and key != prefix + "scalars":
                d[key[len(prefix):]] = np.stack([a[key] for _, a, _ in loaded])
        sc = np.stack([a[prefix + "scalars"] for _, a, _ in loaded])
        d["scalars"] = {n: sc[:, i] for i, n in enumerate(names)}
        res[v.name] = d
    return res
