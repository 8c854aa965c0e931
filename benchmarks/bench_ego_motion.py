"""Time of one ego-velocity fit (docs/method.md c.10): a scan of 100 detections, 30% outliers, 2-D
and 3-D, the default 50 / 80 RANSAC iterations; target <= 0.1 ms per scan.

    PYTHONPATH=src python benchmarks/bench_ego_motion.py
"""

from __future__ import annotations

import time

import numpy as np

from radarslam.models.doppler import directions, fit_ego_velocity


def main(n: int = 100, reps: int = 2000) -> dict:
    rng = np.random.default_rng(0)
    out = {}
    for dim, iters in ((2, 50), (3, 80)):
        polar = np.column_stack([rng.uniform(1, 20, n), rng.uniform(-1.4, 1.4, n)])
        U = directions(polar, rng.uniform(-2, 2, n) if dim == 3 else None)
        v = np.array([3.0, 0.5, 0.1][:dim])
        d = -U @ v + 0.1 * rng.standard_normal(n)
        d[: int(0.3 * n)] = rng.uniform(-5, 5, int(0.3 * n))
        fit_ego_velocity(U, d, rng, iterations=iters)                  # compile / load the cache
        t0 = time.perf_counter()
        for _ in range(reps):
            fit_ego_velocity(U, d, rng, iterations=iters)
        out[f"{dim}-D"] = 1e3 * (time.perf_counter() - t0) / reps
    for k, ms in out.items():
        print(f"ego-velocity fit, {k}, {n} detections: {ms:.4f} ms per scan")
    return out


if __name__ == "__main__":
    main()
