"""The first run of ``radarslam run --dataset`` on a machine (:mod:`.first_run` for the other single
commands): which engine runs a recorded dataset while numba's cache is empty, what it says, and the
foreground compile's heartbeat."""

from __future__ import annotations

from dataclasses import dataclass

from radarslam.compiling.costs import (ANNOUNCE_S, FUSED_SCAN_S, HEARTBEAT_S, ORCHESTRATOR_COMPILE_S,  # noqa: F401
                                     ORCHESTRATOR_SCAN_S, PYTHON_SCAN_S, first_run_engine_scans)
from radarslam.compiling.first_run import _filter_ready, ready
from radarslam.compiling.heartbeat import _heartbeat  # noqa: F401  (runs.dataset's)
from radarslam.compiling.readiness import fused_families
from radarslam.compiling.warmup import COMPILING
from radarslam.config import Config, to_dict
from radarslam.core.types import Odometry, Scan
from radarslam.slam.filter import EkfSlam


@dataclass(frozen=True)
class FirstRunPlan:
    """How :func:`run_dataset` runs the filter (:func:`first_run_plan`).

    Attributes
    ----------
    engine : str
        "fused", "orchestrator" or "python" (the reference, the same results to 1e-9).
    compiles : bool
        numba compiles the orchestrator's kernels within the first two scans of this run.
    compile_s : float
        The expected seconds of that compile (0 when none).
    announce : str
        The first line of stderr ("" for none): what runs, why, and how long it is expected to take.
    """

    engine: str
    compiles: bool = False
    compile_s: float = 0.0
    announce: str = ""


def _one_call_note(n_scans: int) -> str:
    """What the first line says of a warm fused run of ``n_scans`` scans: nothing when it is short
    (under :data:`ANNOUNCE_S`), else the scans, the one compiled call and its expected seconds."""
    expected = n_scans * FUSED_SCAN_S
    if expected < ANNOUNCE_S:
        return ""
    return (f"{n_scans} scans through the compiled fused engine in one call (about {expected:.0f} s at "
            f"{1e3 * FUSED_SCAN_S:.1f} ms a scan; it prints nothing until it returns)")


def _with_backend(config: Config, backend: str) -> Config:
    from dataclasses import replace

    return replace(config, filter=replace(config.filter, backend=backend))


def _orchestrator_ready() -> bool:
    """True when the kernels of a recording's run event by event are compiled or cached: the
    associators, the M/N rules and the extent step (the last to compile)."""
    from radarslam.extent.rows import rma_efa_rows
    from radarslam.landmarks.confirmation import rule12
    from radarslam.slam._numba import associate_scan, batch_associate_scan

    return (ready(rule12) and ready(rma_efa_rows)) and (ready(batch_associate_scan) or ready(associate_scan))


def _fused_ready(*families) -> bool:
    """True when the machine code of the fused engine of ``families`` (none given: the default
    family's) is ready (:func:`.first_run._filter_ready`)."""
    return _filter_ready(*families)


def _background_note(config: Config) -> str:
    """Start the background compile of the fused engine (:mod:`.background`); what the first line says of it."""
    from radarslam.compiling import background
    from radarslam.config.variants import Variant, variants_to_json

    where = f"log {background.lock_path().with_suffix('.log')}"
    if background.enabled() and background.busy():
        return f"; the fused engine still compiles in the background ({where})"
    pid = background.start(to_dict(config), variants_to_json([Variant("run", "run", {})]))
    if pid:
        return f"; the fused engine compiles in the background at low priority (pid {pid}, {where}) for later runs"
    return "; background compiling is off (RADARSLAM_BACKGROUND_COMPILE=0)"


def first_run_plan(config: Config, n_scans: int, fused: bool) -> FirstRunPlan:
    """What runs the filter over ``n_scans`` scans: the fused engine when ``fused`` (it covers the
    configuration) and its machine code is ready, or when a run this long ends sooner compiling it
    (:func:`~radarslam.compiling.warmup.first_run_engine_scans`); else event by event, the
    compiled orchestrator when its kernels are ready, else what ends sooner by the costs above:
    the Python reference at once, or the orchestrator after numba compiles its kernels (announced
    with the expected seconds). The fused engine then compiles in the background for later runs.
    Nothing is announced when everything this run needs is ready."""

    if config.filter.backend != "numba":
        return FirstRunPlan("python")
    if fused and _fused_ready(*fused_families(config)):
        return FirstRunPlan("fused", announce=_one_call_note(n_scans))
    if fused and first_run_engine_scans(n_scans) == "auto":
        return FirstRunPlan("fused", announce=COMPILING)
    later = _background_note(config) if fused else ""
    if _orchestrator_ready():
        return FirstRunPlan("orchestrator", announce=(
            f"the fused engine is not compiled on this machine yet and {n_scans} scans end sooner without it: this "
            f"run goes event by event (the same results){later}") if fused else "")
    python_s = n_scans * PYTHON_SCAN_S
    run_s = n_scans * ORCHESTRATOR_SCAN_S
    if python_s <= ORCHESTRATOR_COMPILE_S + run_s:
        return FirstRunPlan("python", announce=(
            f"first run on this machine: the compiled code is not built yet, so these {n_scans} scans go through "
            f"the Python reference (about {python_s:.0f} s; compiling first would take about "
            f"{ORCHESTRATOR_COMPILE_S + run_s:.0f} s; the same results){later}"))
    return FirstRunPlan("orchestrator", True, ORCHESTRATOR_COMPILE_S, (
        f"first run on this machine: compiling the per-event engine's kernels (once per machine, about "
        f"{ORCHESTRATOR_COMPILE_S:.0f} s on two cores), then {n_scans} scans event by event (about {run_s:.0f} s; the "
        f"Python reference would take about {python_s:.0f} s; the same results){later}"))


def _side_compile(cfg_dict: dict, events: list) -> None:
    """Second process: the first scans with the Python associator and clustering, so that numba
    compiles the other steps (the M/N rules, merging, the extent step), while the run's own
    process compiles the association; both write the cache, each loads what the other wrote first."""
    from radarslam.config import from_dict
    from radarslam.core.registry import ASSOCIATORS
    from radarslam.slam.kernels import cluster_kernel

    est = from_dict(cfg_dict).estimator
    slam = EkfSlam(est, associator=ASSOCIATORS.create(est.landmarks.associator, est, backend="python"))
    slam._clusters = cluster_kernel("python")     # its reference; the compiled one is the run's to compile
    for ev in events:
        slam.predict(ev) if isinstance(ev, Odometry) else slam.update(ev)


def _compile_beside(config: Config, events) -> object | None:
    """Start :func:`_side_compile` on the events up to the fourth scan; the executor, or None."""
    from concurrent.futures import ProcessPoolExecutor

    head, k = [], 0
    for ev in events:
        head.append(ev)
        k += isinstance(ev, Scan)
        if k == 4:
            break
    try:
        ex = ProcessPoolExecutor(max_workers=1)
        ex.submit(_side_compile, to_dict(config), head)
    except (OSError, RuntimeError):                 # only a speed-up: the run compiles what it needs
        return None
    return ex


