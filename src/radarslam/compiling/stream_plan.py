"""The first run of a recorded stream on a machine (``radarslam run --dataset``, ``run --recording``):
the policy's plan (:mod:`.policy`) with the fused engine's background compile started when it asks,
and the orchestrator's compile split over the two cores (:func:`_compile_beside`)."""

from __future__ import annotations

from radarslam.compiling.costs import HEARTBEAT_S, ORCHESTRATOR_COMPILE_S, PYTHON_SCAN_S  # noqa: F401
from radarslam.compiling.heartbeat import _heartbeat  # noqa: F401  (runs.dataset's)
from radarslam.compiling.policy import Plan, Workload, plan
from radarslam.compiling.readiness import mark_compiled
from radarslam.config import Config, to_dict
from radarslam.core.types import Scan
from radarslam.slam.driver import drive
from radarslam.slam.filter import EkfSlam


#: How :func:`~radarslam.runs.dataset.run_dataset` runs the filter: the policy's :class:`~.policy.Plan`.
FirstRunPlan = Plan


def _with_backend(config: Config, backend: str) -> Config:
    from dataclasses import replace

    return replace(config, filter=replace(config.filter, backend=backend))


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


def first_run_plan(config: Config, n_scans: int, fused: bool, n_detections: int = 0) -> Plan:
    """What runs the filter over a stream of ``n_scans`` scans (and ``n_detections`` detections,
    when known): :func:`~.policy.plan` of kind ``"stream"``; the fused engine's background compile
    started when the plan asks for it, and said on the first line."""
    from dataclasses import replace

    p = plan(config, Workload("stream", n_scans=n_scans, n_detections=n_detections, fused=fused))
    if p.background:
        p = replace(p, announce=p.announce + _background_note(config))
    return p


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
    drive(est, events, slam=slam, engine="orchestrator")
    mark_compiled()                               # a pool's process ends without running atexit


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


