"""Wall time of a whole recorded dataset (default: Victoria Park, all scans) on one core: loading,
the filter (EKF-SLAM + landmark management + extents), and the evaluation; ms per scan and the
landmarks in the state at the end, in either input mode (``--input laser|trees``)."""

import argparse
import time
from dataclasses import replace
from pathlib import Path

import _common  # noqa: F401  (single-threaded BLAS)

from radarslam.config import profile_config
from radarslam.experiments.dataset import (compare_tree_diameters, evaluate_against_gps, run_dataset,
                                           victoria_park_options)
from radarslam.io.datasets.victoria_park import INPUT_PROFILES

DEFAULT_PATH = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--path", type=Path, default=DEFAULT_PATH, help="the dataset directory")
    ap.add_argument("--scans", type=int, default=None, help="only the first N scans (default: all)")
    ap.add_argument("--backend", choices=("python", "numba"), default="numba",
                    help="filter.backend (default: the profile's, numba)")
    ap.add_argument("--input", choices=("laser", "trees"), default="laser",
                    help="raw laser returns (profile victoria-park) or ACFR's tree detections (victoria-park-trees)")
    a = ap.parse_args()
    cfg = profile_config(INPUT_PROFILES[a.input])
    cfg = replace(cfg, filter=replace(cfg.filter, backend=a.backend))
    loader = victoria_park_options(cfg, a.input)
    if a.backend == "numba":  # compile outside the timing
        run_dataset("victoria-park", a.path, cfg, n_scans=20, progress=False, loader_options=loader)
    t0 = time.perf_counter()
    run = run_dataset("victoria-park", a.path, cfg, n_scans=a.scans, progress=False, loader_options=loader)
    t1 = time.perf_counter()
    ev = evaluate_against_gps(run)
    diam = compare_tree_diameters(run) if a.input == "laser" else None
    t2 = time.perf_counter()
    n = run.times.size
    print(f"victoria-park ({a.input}), {n} scans, backend {a.backend}, one core:")
    print(f"  load {run.load_seconds:.1f} s   filter {run.seconds:.1f} s ({n / run.seconds:.0f} scans/s, "
          f"{1e3 * run.seconds / n:.2f} ms/scan)   evaluation {t2 - t1:.1f} s   total {t2 - t0:.1f} s")
    print(f"  landmarks in the state at the end {run.final_map.ids.size} (max {int(run.n_landmarks.max())})   "
          f"GPS-aligned RMSE {ev['rmse_m']:.2f} m   max {ev['max_m']:.2f} m"
          + ("" if diam is None else f"   matched trees {diam['n_matched']}"))


if __name__ == "__main__":
    main()
