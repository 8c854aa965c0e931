"""The Monte Carlo experiment of the seed paper (Table 1, Figs. 2-3), over any list of variants.

Trial ``t`` (1-based) draws everything from ``SeedSequence(seed).spawn(n)[t - 1]``, i.e.
``SeedSequence(seed, spawn_key=(t - 1,))``, simulates one car park and runs, on that same data,
every configuration variant (:mod:`.variants`; by default "No extent" and "With extent", both
tracking RMA and EFA extents). A trial depends on nothing but the configuration, the variants, the
seed and its number, so results are identical bit for bit whatever runs them: one process, a local
pool, or a Dask cluster. Each finished trial is stored at once (:mod:`.store`); a rerun resumes.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam.config import Config, from_dict, to_dict, validate
from radarslam.core.errors import InputError
from radarslam.simulation.trial import check_simulation_config, evaluate, with_initial_estimate
from radarslam.slam.driver import run_filter
from radarslam.runs.progress import Progress
from radarslam.runs.workers import (init_pool_worker as _init_pool_worker,  # noqa: F401
                                    interrupts_as_flag as _interrupts_as_flag, limit_threads as _limit_threads,
                                    run_dask, run_pool, sigterm_as_interrupt as _sigterm_as_interrupt)
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
    default that of ``config`` and ``variants``). ``engine`` is :func:`~.single.run_filter`'s, or
    ``"python"``: the Python reference whole, the scan simulation, the engine's Python form and the
    evaluation's matching, nothing compiled (a short first run, :func:`~radarslam.compiling.costs.first_run_engine`;
    the same results). The meta records which engine ran each variant (``engines``).
    """
    cfg = from_dict(config) if isinstance(config, dict) else config
    variants = check_variants(variants)
    t0 = time.perf_counter()
    ss = trial_seed(seed, trial)
    python = engine == "python"
    scenario = generate_scenario(cfg, np.random.default_rng(ss), compiled=not python)
    arrays: dict[str, np.ndarray] = {"true_poses": scenario.truth.poses}
    K = scenario.truth.poses.shape[0]
    seconds, engines = {}, {}
    for v in variants:
        c = with_initial_estimate(variant_config(cfg, v), scenario, ss)   # b.5: fixed, or drawn per trial
        rec = run_filter(c, scenario.events, engine="fused-python" if python else engine)
        m = evaluate(c, scenario, rec, not python)
        name = v.name
        arrays[f"{name}/poses"] = rec.poses
        arrays[f"{name}/n_landmarks"] = rec.n_landmarks
        for key in PER_STEP:
            arrays[f"{name}/{key}"] = _per_step(m, key, K)
        for key in PER_VEHICLE:
            arrays[f"{name}/{key}"] = np.asarray(m[key])
        arrays[f"{name}/scalars"] = np.array([float(m[k]) for k in SCALARS])
        seconds[name] = rec.seconds
        engines[name] = "python" if python else rec.engine
    meta = {"trial": trial, "seed": seed, "spawn_key": [trial - 1], "seconds": time.perf_counter() - t0,
            "filter_seconds": seconds, "engines": engines, "scalar_names": list(SCALARS), "variants": [v.name for v in variants],
            "config_hash": chash or config_hash(cfg, variants)}
    return encode_trial(arrays, meta)


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
        # goes through the engine's steps form meanwhile, the whole loop compiling in the background.
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


def _run_pool(cfg_dict: dict, seed: int, variants: tuple[Variant, ...], todo: list[int], finish,
              jobs: int, chash: str, engine: str = "auto", poll_s: float = 0.2) -> None:
    """Trials ``todo`` on ``jobs`` local worker processes (:func:`~radarslam.runs.workers.run_pool`)."""
    run_pool({t: (compute_trial, (cfg_dict, seed, t, variants, chash, engine)) for t in todo}, finish, jobs,
             unit="trial", poll_s=poll_s)


def _run_dask(cfg_dict: dict, seed: int, variants: tuple[Variant, ...], todo: list[int], finish,
              scheduler: str | None, dask_local: int | None, chash: str) -> None:
    """Trials ``todo`` on a Dask cluster (:func:`~radarslam.runs.workers.run_dask`)."""
    run_dask({t: (compute_trial, (cfg_dict, seed, t, variants, chash), f"radarslam-trial-{seed}-{t}") for t in todo},
             finish, scheduler, dask_local, timeout_s=CONNECT_TIMEOUT_S)


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
