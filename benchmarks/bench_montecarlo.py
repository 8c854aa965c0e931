"""Trials per second of the Monte Carlo runner with J local worker processes."""

import argparse
import tempfile
import time
from dataclasses import replace

import _common  # noqa: F401

from radarslam.config import profile_config
from radarslam.montecarlo.trials import run_montecarlo


def rate(trials: int, jobs: int, backend: str) -> float:
    cfg = profile_config()
    cfg = replace(cfg, filter=replace(cfg.filter, backend=backend))
    with tempfile.TemporaryDirectory() as d:
        t0 = time.perf_counter()
        run_montecarlo(cfg, 1, trials, d, jobs=jobs, progress=False)
        return trials / (time.perf_counter() - t0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=60)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--backend", choices=("python", "numba"), default="python")
    a = ap.parse_args()
    r1 = rate(a.trials, 1, a.backend)
    rj = rate(a.trials, a.jobs, a.backend)
    print(f"montecarlo, backend {a.backend}, {a.trials} trials: --jobs 1 {r1:.2f} trials/s; "
          f"--jobs {a.jobs} {rj:.2f} trials/s "
          f"(speed-up {rj / r1:.2f}x)")


if __name__ == "__main__":
    main()
