"""Compilation cost of the numba backend on first use, and what later processes pay to load it.

numba compiles the package's kernels the first time they run and caches the machine code on disk
(``cache=True``: in the package's ``__pycache__`` folders, or ``NUMBA_CACHE_DIR``). This script
runs the same job in fresh interpreters against an empty cache directory:

1. cold: the first process compiles everything it uses and writes the cache;
2. warm: a second process loads the cache (what every later run and every Monte Carlo worker pays);
3. python: the same job with ``filter.backend = "python"`` (no numba code runs).

The job is one complete car-park trial (all three Monte Carlo variants, so the batch associator and
every compiled step run) after ``import radarslam``. Each figure is the wall time of the whole
process, interpreter start included; the compile time is cold minus warm.
"""

import argparse
import os
import subprocess
import sys
import tempfile
import time

JOB = """
import time
t0 = time.perf_counter()
from dataclasses import replace
from radarslam.config import profile_config
from radarslam.experiments.montecarlo import compute_trial
cfg = profile_config()
cfg = replace(cfg, filter=replace(cfg.filter, backend={backend!r}))
t1 = time.perf_counter()
compute_trial(cfg, 1, 1)
t2 = time.perf_counter()
compute_trial(cfg, 1, 2)
t3 = time.perf_counter()
print(f"{{t1 - t0:.3f}} {{t2 - t1:.3f}} {{t3 - t2:.3f}}")
"""


def run(backend: str, cache_dir: str) -> tuple[float, list[float]]:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", JOB.format(backend=backend)], env=env, check=True,
                         capture_output=True, text=True).stdout
    return time.perf_counter() - t0, [float(v) for v in out.split()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="radarslam-numba-cache-") as cache:
        rows = [("cold (compiles, writes the cache)", *run("numba", cache)),
                ("warm (loads the cache)", *run("numba", cache)),
                ("python backend (no numba)", *run("python", cache))]
        size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(cache) for f in fs)
    print("one process: import + first trial + second trial (3 variants), fresh NUMBA_CACHE_DIR")
    print(f"  {'run':36s} {'process':>8s} {'import':>8s} {'trial 1':>8s} {'trial 2':>8s}")
    for name, wall, (imp, t1, t2) in rows:
        print(f"  {name:36s} {wall:7.2f}s {imp:7.2f}s {t1:7.2f}s {t2:7.2f}s")
    (_, cw, (_, c1, _)), (_, ww, (_, w1, _)) = rows[0], rows[1]
    print(f"compilation on first use: {c1 - w1:.1f} s (trial 1 cold - warm), {cw - ww:.1f} s per process; "
          f"cache {size / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
