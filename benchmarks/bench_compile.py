"""Compilation cost of the numba backend on first use, and what later processes pay to load it.

numba compiles the package's kernels the first time they run and caches the machine code on disk
(``cache=True``: in the package's ``__pycache__`` folders, or ``NUMBA_CACHE_DIR``). This script
runs the same job in fresh interpreters against an empty cache directory:

1. cold: the first process compiles everything it uses and writes the cache;
2. warm: a second process loads the cache (what every later run and every Monte Carlo worker pays);
3. both again with the trials run by the engine's steps form (``engine="fused-steps"``, what a
   short first run uses while the fused engine compiles in the background, compiling/warmup.py);
4. python: the same job with ``filter.backend = "python"`` (no numba code runs).

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
from radarslam.montecarlo.trials import compute_trial
cfg = profile_config()
cfg = replace(cfg, filter=replace(cfg.filter, backend={backend!r}))
t1 = time.perf_counter()
compute_trial(cfg, 1, 1, engine={engine!r})
t2 = time.perf_counter()
for t in range(2, 2 + {more}):
    compute_trial(cfg, 1, t, engine={engine!r})
t3 = time.perf_counter()
print(f"{{t1 - t0:.3f}} {{t2 - t1:.3f}} {{(t3 - t2) / {more}:.4f}}")
"""


def run(backend: str, engine: str, cache_dir: str, more: int) -> tuple[float, list[float]]:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, OMP_NUM_THREADS="1", OPENBLAS_NUM_THREADS="1")
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", JOB.format(backend=backend, engine=engine, more=more)], env=env,
                         check=True, capture_output=True, text=True).stdout
    return time.perf_counter() - t0, [float(v) for v in out.split()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=10, help="warm trials timed after the first (default 10)")
    args = ap.parse_args()
    rows = []
    for engine in ("auto", "fused-steps"):
        name = "fused engine" if engine == "auto" else "steps form"
        with tempfile.TemporaryDirectory(prefix="radarslam-numba-cache-") as cache:
            rows.append((f"{name}: cold (compiles)", *run("numba", engine, cache, args.trials)))
            rows.append((f"{name}: warm (loads the cache)", *run("numba", engine, cache, args.trials)))
            if engine == "auto":
                size = sum(os.path.getsize(os.path.join(d, f)) for d, _, fs in os.walk(cache) for f in fs)
    with tempfile.TemporaryDirectory(prefix="radarslam-numba-cache-") as cache:
        rows.append(("python backend (no numba)", *run("python", "auto", cache, max(1, args.trials // 5))))
    print("one process: import + first trial + mean of the next trials (3 variants each), fresh NUMBA_CACHE_DIR")
    print(f"  {'run':36s} {'process':>8s} {'import':>8s} {'trial 1':>8s} {'per trial':>9s}")
    for name, wall, (imp, t1, tn) in rows:
        print(f"  {name:36s} {wall:7.2f}s {imp:7.2f}s {t1:7.2f}s {tn:8.4f}s")
    for i, name in ((0, "fused engine"), (2, "steps form")):
        (_, _, (_, c1, _)), (_, _, (_, w1, tn)) = rows[i], rows[i + 1]
        print(f"{name}: compilation on first use {c1 - w1:.1f} s on one core; {tn / 3 * 1e3:.1f} ms per variant "
              f"and trial warm (compiling/costs.py FUSED_S / STEPS_S)")
    print(f"fused engine's cache {size / 1e6:.1f} MB")


if __name__ == "__main__":
    main()
