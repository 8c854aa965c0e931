"""The first run of a single command on a machine: run what is compiled, never wait for a compile.

numba caches machine code on disk (docs/architecture.md "Backends"). On a machine whose cache is
empty, compiling the fused engine costs minutes, the scan simulation about 13 s and the
evaluation's matching about 4 s of one core, while one car-park trial through the Python
reference takes about a second and a recording of a thousand scans some seconds. Every compiled
part has a Python reference that gives the same results (the simulation and the matching to the
bit, the filter to 1e-9 with the same associations; tests/test_backends.py, tests/test_metrics.py).
So a single command (``radarslam run``) runs each part compiled only when its machine code is
ready (cached or already compiled in this process) and otherwise through its reference, says so
on its first line, and leaves the compile to a detached low-priority process
(:mod:`.background`) for the runs that come after. The Monte Carlo applies the same rule through
:func:`radarslam.compiling.warmup.warm_up`.
"""

from __future__ import annotations

import sys

from radarslam.compiling.policy import Plan, Workload, plan

#: What the first line says when a part runs through its reference.
ANNOUNCE = ("run: first run on this machine: the compiled code is not built yet, so this run takes the Python "
            "reference ({parts}; the same results){later}")


#: Which parts of a single run go compiled: the policy's :class:`~.policy.Plan` (``filter_backend``,
#: ``simulation_compiled``, ``matching_compiled``, ``reference_parts``).
FirstRun = Plan


def choose(backend: str, *, simulation: bool = False, matching: bool = False, config=None) -> Plan:
    """The plan of one simulated trial or a short run (:func:`~.policy.plan`, kind ``"trial"``): each
    part compiled when its machine code is ready, the filter's for the family of ``config`` (None:
    the default family's). With ``backend`` "python" everything is the reference already and
    nothing is announced."""
    from dataclasses import replace

    from radarslam.config import profile_config

    cfg = config if config is not None else profile_config()
    cfg = replace(cfg, filter=replace(cfg.filter, backend=backend))
    return plan(cfg, Workload("trial", simulation=simulation, matching=matching))


def announce(choice: FirstRun, config, stream=None) -> int | None:
    """Say what :func:`choose` decided (nothing when every part is ready) and start the
    background compile of what is missing; the background process's pid, or None."""
    if not choice.reference_parts:
        return None
    from radarslam.config import to_dict
    from radarslam.compiling import background
    from radarslam.config.variants import Variant, variants_to_json

    stream = stream or sys.stderr
    busy = background.enabled() and background.busy()
    pid = None if busy else background.start(to_dict(config), variants_to_json([Variant("run", "run", {})]))
    where = f"log {background.lock_path().with_suffix('.log')}"
    later = ("; the compiled code is still building in the background (" + where + ")" if busy else
             f"; the compiled code builds in the background at low priority (pid {pid}, {where}, a few minutes "
             "of one core) for the runs that come after" if pid else
             "; background compiling is off (RADARSLAM_BACKGROUND_COMPILE=0): a later run compiles")
    print(ANNOUNCE.format(parts=", ".join(choice.reference_parts), later=later), file=stream, flush=True)
    return pid
