"""The first run of a recorded stream on a machine (``radarslam run --dataset``, ``run --recording``):
the policy's plan (:mod:`.policy`) with the fused engine's background compile started when it asks."""

from __future__ import annotations

from radarslam.compiling.policy import Plan, Workload, plan
from radarslam.config import Config, to_dict


#: How :func:`~radarslam.runs.dataset.run_dataset` runs the filter: the policy's :class:`~.policy.Plan`.
FirstRunPlan = Plan


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
