"""Wall time of one scan of many detections through the whole filter update (sifting, association,
M/N, extent step, clustering, alpha test, confirmation, merging), on a map built from the car park.

    python benchmarks/bench_large_scan.py --detections 10000 [--backend numba] [--repeats 5]

The scan holds the car park's detections of one step plus uniform clutter over a 120 m square up to
the requested count; the filter first runs 30 ordinary scans so that its map holds the cars. No
step builds an m x m array (clustering uses scikit-learn's kd-tree above 512 points, sifting works
in chunks of rows).
"""

import argparse
import copy
import time
from dataclasses import replace

import _common  # noqa: F401  (single-threaded BLAS)
import numpy as np

from radarslam.config import profile_config
from radarslam.core.registry import BACKENDS
from radarslam.core.types import Scan
from radarslam.simulation.scenario import generate_scenario
from radarslam.slam import EkfSlam


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--detections", type=int, default=10_000)
    ap.add_argument("--backend", choices=BACKENDS, default="python")
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    cfg = profile_config("apsipa")
    cfg = replace(cfg, filter=replace(cfg.filter, backend=a.backend), extent=replace(cfg.extent, use_in_slam=True))
    sc = generate_scenario(cfg, np.random.default_rng(a.seed))
    slam = EkfSlam(cfg)
    scans = 0
    last = None
    for ev in sc.events:
        slam.process(ev)
        if isinstance(ev, Scan):
            scans += 1
            last = ev
            if scans == 30:
                break
    rng = np.random.default_rng(a.seed)
    n_extra = max(0, a.detections - last.polar.shape[0])
    pose = slam.pose
    pts = pose[:2] + rng.uniform(-60.0, 60.0, (n_extra, 2))
    d = pts - pose[:2]
    clutter = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
    polar = np.concatenate([last.polar, clutter])
    times = []
    for r in range(a.repeats):
        s = copy.deepcopy(slam)
        t0 = time.perf_counter()
        rep = s.update(Scan(last.t + 0.16 * (r + 1), last.index + 1, polar))
        times.append(time.perf_counter() - t0)
    t = np.array(times)
    print(f"one scan of {polar.shape[0]} detections, {len(slam.landmarks)} landmarks in the map, backend {a.backend}:")
    print(f"  median {np.median(t):.3f} s  min {t.min():.3f} s  max {t.max():.3f} s  "
          f"({rep.n_candidates} candidates, {rep.n_associated} associated, {rep.n_clusters} clusters)")


if __name__ == "__main__":
    main()
