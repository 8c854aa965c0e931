"""Compile, in a process of its own, code that later tests need, while the session's warm-up holds
the other core's worker waiting (tests/conftest.py): on a cold cache the warm-up compiles the
default family's fused engine for about 140 s of CPU in one process, and its second process, the
simulation and the evaluation, ends after about 17 s, leaving a core idle for two minutes. This
process fills that time with what the tests would otherwise compile later on one of their two
workers: the per-event orchestrator's kernels of the default variants (about 30 s, every fused =
orchestrator test) and JCBB's fused family (about 80 s, tests/test_fused.py, test_fused_bias.py,
test_odometry_bias.py). Not the partial view's: the session's evidence (tests/family_evidence.py),
taken right after the warm-up, checks that a cache holding only the default family says the
partial view's is not ready, and this process would race it (in a trial CI run it finished the
partial view's family 0.1 s before that evidence was written). Nothing is measured or asserted
here; numba's cache (written atomically, file by file) is all it leaves.

    python tests/precompile.py          # what conftest.py starts
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

#: JCBB's family (slam/fused/engine.py Family(jcbb=True)), as a variant overlay.
JCBB = {"landmarks": {"associator": "jcbb"}}


def start(log: Path) -> subprocess.Popen:
    """This module as a process of its own, its output in ``log``."""
    with open(log, "w") as out:
        return subprocess.Popen([sys.executable, str(Path(__file__).resolve())], stdin=subprocess.DEVNULL,
                                stdout=out, stderr=subprocess.STDOUT)


def main() -> int:
    from radarslam.config import profile_config
    from radarslam.experiments.single import run_filter
    from radarslam.experiments.variants import DEFAULT_VARIANTS, Variant, apply_variant
    from radarslam.experiments.warmup import _orchestrator_trial, _tiny_stream

    cfg = profile_config()
    _orchestrator_trial(cfg, DEFAULT_VARIANTS)
    print("precompile: the orchestrator's kernels", flush=True)
    run_filter(apply_variant(cfg, Variant("jcbb", "jcbb", JCBB)), _tiny_stream())
    print("precompile: JCBB's family", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
