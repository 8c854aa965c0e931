"""The detached compile process that :mod:`.background` starts (``python -m
radarslam.compiling.background_job JOB``): under the lock, the warm-up's tiny stream through each
variant with the fused engine, so that numba compiles and caches it for later runs."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from radarslam.compiling.background import held_lock, lock_path


def main(job: str) -> int:
    """The detached process: under the lock, run the warm-up's tiny stream through each variant
    with the fused engine (numba compiles it whole and caches it). 0 when done or not needed."""
    from radarslam.config import from_dict
    from radarslam.config.variants import variants_from_json
    from radarslam.compiling.warmup import compile_fused

    try:
        data = json.loads(Path(job).read_text())
    finally:
        Path(job).unlink(missing_ok=True)
    with held_lock(lock_path()) as mine:
        if not mine:
            print("radarslam: another process is compiling for this cache; nothing to do", flush=True)
            return 0
        config = from_dict(data["config"])
        variants = variants_from_json(data["variants"])
        compile_fused(config, variants)
        print("radarslam: the fused engine is compiled and cached", flush=True)
        if config.filter.motion_model == "unicycle":       # the car park's simulation and evaluation too
            from radarslam.compiling.warmup import _side

            _side(data["config"], dict(variants[0].overlay) if variants else {})
            print("radarslam: the scan simulation and the evaluation's matching are compiled and cached", flush=True)
    return 0


if __name__ == "__main__":  # pragma: no cover - the detached process
    raise SystemExit(main(sys.argv[1]))
