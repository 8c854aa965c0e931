"""Median wall time of one complete trial on one core."""

import argparse
import time
from dataclasses import replace

import _common  # noqa: F401  (single-threaded BLAS)
import numpy as np

from radarslam.config import profile_config
from radarslam.experiments.montecarlo import compute_trial


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=30)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--backend", choices=("python", "numba"), default="python",
                    help="filter.backend (numba needs the [fast] extra)")
    a = ap.parse_args()
    cfg = profile_config()
    cfg = replace(cfg, filter=replace(cfg.filter, backend=a.backend))
    compute_trial(cfg, a.seed, 1)  # warm-up: imports, caches
    t = []
    for k in range(1, a.trials + 1):
        t0 = time.perf_counter()
        compute_trial(cfg, a.seed, k)
        t.append(time.perf_counter() - t0)
    t = np.array(t)
    print(f"complete trial (simulation + No extent + With extent + RMA/EFA + evaluation), backend {a.backend}, "
          f"{a.trials} trials, one core:")
    print(f"  median {np.median(t):.3f} s   p10 {np.percentile(t, 10):.3f} s   p90 {np.percentile(t, 90):.3f} s"
          f"   min {t.min():.3f} s   max {t.max():.3f} s")


if __name__ == "__main__":
    main()
