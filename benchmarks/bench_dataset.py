"""Wall time of a whole recorded dataset (default: Victoria Park, all 7,230 scans) on one core:
loading, the filter (EKF-SLAM + landmark management + RMA/EFA extents), and the evaluation."""

import argparse
import time
from dataclasses import replace
from pathlib import Path

import _common  # noqa: F401  (single-threaded BLAS)

from radarslam.config import profile_config
from radarslam.experiments.dataset import compare_tree_diameters, evaluate_against_gps, run_dataset

DEFAULT_PATH = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--path", type=Path, default=DEFAULT_PATH, help="the dataset directory")
    ap.add_argument("--scans", type=int, default=None, help="only the first N scans (default: all)")
    ap.add_argument("--backend", choices=("python", "numba"), default="numba",
                    help="filter.backend (numba needs the [fast] extra)")
    a = ap.parse_args()
    cfg = profile_config("victoria-park")
    cfg = replace(cfg, filter=replace(cfg.filter, backend=a.backend))
    if a.backend == "numba":  # compile outside the timing
        run_dataset("victoria-park", a.path, cfg, n_scans=20, progress=False)
    t0 = time.perf_counter()
    run = run_dataset("victoria-park", a.path, cfg, n_scans=a.scans, progress=False)
    t1 = time.perf_counter()
    ev = evaluate_against_gps(run)
    diam = compare_tree_diameters(run)
    t2 = time.perf_counter()
    n = run.times.size
    print(f"victoria-park, {n} scans, backend {a.backend}, one core:")
    print(f"  load {run.load_seconds:.1f} s   filter {run.seconds:.1f} s ({n / run.seconds:.0f} scans/s, "
          f"{1e3 * run.seconds / n:.1f} ms/scan)   evaluation {t2 - t1:.1f} s   total {t2 - t0:.1f} s")
    print(f"  landmarks {run.final_map.ids.size}   GPS-aligned RMSE {ev['rmse_m']:.2f} m   max {ev['max_m']:.2f} m   "
          f"matched trees {diam['n_matched']}")


if __name__ == "__main__":
    main()
