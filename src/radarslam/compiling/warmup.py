"""The first run on a machine: compile the numba backend on both cores, and say that it is doing so.

numba compiles on first use and caches the machine code on disk (docs/architecture.md "Backends").
On a machine whose cache is empty a Monte Carlo's first trial pays for all of it: the fused
engine (``slam/fused/engine.py: run_stream`` and the kernels it calls) and, independently of it, the
compiled scan simulation and the evaluation's matching. Those two parts share no compiled code, so
:func:`warm_up` compiles them at the same time: the fused engine in this process, on a stream of
two events made up for the purpose, and the simulation and the evaluation in a second process that
runs one trial with the Python filter (``filter.backend = "python"`` runs no compiled filter code).
Both write numba's cache, from which the first real trial and every worker then load. Results are
not touched: the warm-up's outputs are thrown away.

Compiling the fused engine's whole loop costs far more than compiling the kernels its steps form
calls (its steps as Python, slam/fused/engine.py ``form``), while a trial then runs about 4x faster.
A Monte Carlo short enough to end sooner without it (:func:`first_run_engine`, from the costs
measured by ``benchmarks/bench_compile.py``) therefore runs its trials in the steps form, the same
results, and leaves the whole loop to a detached low-priority process (:mod:`.background`) for the
runs that come after. Each trial's meta says which form ran it.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from radarslam.compiling.costs import FUSED_COMPILE_S, STEPS_WARM_UP_S
from radarslam.compiling.heartbeat import _heartbeat
from radarslam.compiling.policy import COMPILING, Workload, plan
from radarslam.compiling.readiness import mark_compiled
from radarslam.config import Config, from_dict, to_dict
from radarslam.config.variants import Variant, apply_variant
from radarslam.core.types import Odometry, Scan
from radarslam.slam.driver import run_filter

#: ... and when this run's few trials go through the Python reference (:func:`first_run_engine`).
PYTHON_SHORT = ("the numba kernels are not compiled on this machine yet and this run is short: its trials go "
                "through the Python reference (the same results)")
#: ... and when this run's trials go through the engine's steps form (:func:`first_run_engine`).
COMPILING_SHORT = ("compiling the numba kernels the engine's steps use (once per machine, about {s:.0f} s); "
                   "this run is short, so it does not wait for the fused engine")


def _tiny_stream() -> list:
    """Two events that take every part of the fused engine's code through the compiler (numba
    compiles a whole function whatever the data); with a gyro reading and a Doppler channel, so that
    variants driven by the Doppler (docs/method.md c.10.5) or gated by it (c.10.4) run too."""
    return [Odometry(0.1, 0.1, np.array([1.0, 0.0]), gyro_rad_s=0.0),      # a gyro for filter.odometry doppler
            Scan(0.1, 1, np.array([[5.0, 0.10], [5.1, 0.11], [5.2, 0.12]]),
                 channels={"doppler_mps": np.array([-1.0, -1.0, -1.0])})]


def compile_fused(config: Config, variants: tuple[Variant, ...]) -> None:
    """The warm-up's tiny stream through each variant of ``config``: numba compiles the fused
    engine of each variant's family whole (and, for a variant outside the engine, what it runs)."""
    for v in variants:
        run_filter(apply_variant(config, v), _tiny_stream())
    mark_compiled()


def _side(cfg_dict: dict, overlay: dict) -> None:
    """Second process: one simulated trial with the Python filter compiles the scan simulation and
    the evaluation's matching (and nothing of the filter): what a Monte Carlo trial runs of them."""
    from radarslam.simulation.trial import run_trial

    python = {**overlay, "filter": {**overlay.get("filter", {}), "backend": "python"}}
    run_trial(apply_variant(from_dict(cfg_dict), Variant("warmup", "warm-up", python)), np.random.SeedSequence(1))
    mark_compiled()          # a pool's process ends without running atexit


def _steps_trial(config: Config, variants: tuple[Variant, ...], evaluation: bool = False,
                 simulation: bool = False) -> None:
    """One car park through every variant by the engine's steps form: what a real trial makes numba
    compile of the kernels the steps call; with ``evaluation``, the evaluation's matching of the
    first variant's run too; with ``simulation``, the car park by the compiled scan simulation
    (else by its reference, which compiles nothing)."""
    from radarslam.simulation.trial import evaluate
    from radarslam.simulation.scenario import generate_scenario

    scenario = generate_scenario(config, np.random.default_rng(0), compiled=simulation)
    for i, v in enumerate(variants):
        rec = run_filter(apply_variant(config, v), scenario.events, engine="fused-steps")
        if evaluation and i == 0:
            evaluate(apply_variant(config, v), scenario, rec)
    mark_compiled()


def _short_side(cfg_dict: dict, variants: tuple[Variant, ...]) -> None:
    """Second process of a short first run: the scan simulation, then ``variants`` through the
    engine's steps form (the main process takes the others and the evaluation), so that the kernels
    compile on both cores."""
    _steps_trial(from_dict(cfg_dict), variants, simulation=True)


def _background(config: Config, variants: tuple[Variant, ...], log: Callable[[str], None]) -> None:
    """Start the detached compilation of the fused engine (:mod:`.background`), or say that one runs."""
    from radarslam.compiling import background
    from radarslam.config.variants import variants_to_json

    where = f"log {background.lock_path().with_suffix('.log')}"
    if background.enabled() and background.busy():
        log(f"montecarlo: the fused engine is still compiling in the background ({where}); this run uses its "
            "steps form, with the same results")
        return
    pid = background.start(to_dict(config), variants_to_json(variants))
    if pid is not None:
        log(f"montecarlo: the fused engine compiles in the background at low priority (pid {pid}, {where}) for "
            "later runs, about 4x faster per trial")


def warm_up(config: Config, variants: tuple[Variant, ...], log: Callable[[str], None], parallel: bool = True,
            n_trials: int | None = None, jobs: int = 1) -> str:
    """Compile the backend before the first trial when the cache is cold (module docstring); a
    no-op, silent, when it is warm or the backend is ``python``. Returns the ``engine`` the trials
    run with (:func:`~radarslam.montecarlo.trials.compute_trial`): ``"python"`` (the reference whole,
    nothing compiled) or ``"fused-steps"`` when ``n_trials`` (None: unknown,
    compile the fused engine) on ``jobs`` workers end sooner so (:func:`first_run_engine`), the
    fused engine then compiling in the background (:mod:`.background`); else ``"auto"``."""
    p = plan(config, Workload("trials", n_trials=n_trials if n_trials is not None else 0, jobs=jobs,
                              variants=tuple(variants)))
    if p.engine == "auto" and not p.compiles:    # warm, or the reference: nothing to compile
        return "auto"
    if p.engine == "python":                     # a few trials end sooner through the reference whole
        log(f"montecarlo: {PYTHON_SHORT}")
        _background(config, variants, log)
        return "python"
    short = p.engine == "steps"
    if short:
        _background(config, variants, log)
        if not p.compiles:
            return "fused-steps"
    log(f"montecarlo: {COMPILING_SHORT.format(s=STEPS_WARM_UP_S) if short else COMPILING}")
    side = None
    mine, theirs = variants, ()
    if parallel:
        side = ProcessPoolExecutor(max_workers=1)
        if short:     # the last variant's kernels beside the simulation; this process evaluates
            mine, theirs = (variants[:-1], variants[-1:]) if len(variants) > 1 else (variants, ())
            job = side.submit(_short_side, to_dict(config), theirs)
        else:
            job = side.submit(_side, to_dict(config), dict(variants[0].overlay))
    expected = STEPS_WARM_UP_S if short else FUSED_COMPILE_S
    beat = _heartbeat(expected, "montecarlo: still compiling the numba kernels")
    beat.__enter__()
    try:
        if short:
            _steps_trial(config, mine, evaluation=side is not None)
        else:
            compile_fused(config, variants)      # each variant's family
        if side is None:                         # one core: the simulation and the evaluation next, here
            _side(to_dict(config), dict(variants[0].overlay))
    finally:
        if side is not None:
            try:
                job.result()
            except Exception as exc:             # only a warm-up: the first trial compiles what is missing
                log(f"montecarlo: the second compiling process failed ({type(exc).__name__}); compiling on one core")
            side.shutdown(wait=True)
        beat.__exit__(None, None, None)
    return "fused-steps" if short else "auto"
