"""Wall time of a whole recorded dataset (default: Victoria Park, all scans) on one core: the filter's
time per scan (EKF-SLAM + landmark management + extents) of each input mode (raw laser, ACFR's tree
detections) and each form of the engine (compiled; its steps form, the steps as Python over the compiled kernels),
each run ``--repeat`` times (min and median), with the landmarks at the end and the GPS-aligned RMSE
(which the two engines share), then loading and evaluation of the last run.

    python benchmarks/bench_dataset.py                        # both modes, both engines, 3 runs each
    python benchmarks/bench_dataset.py --input laser --engine fused --repeat 5
"""

import argparse
import statistics
import time
from dataclasses import replace
from pathlib import Path

import _common  # noqa: F401  (single-threaded BLAS)

from radarslam.config import profile_config
from radarslam.runs.dataset import compare_tree_diameters, evaluate_against_gps, run_dataset, victoria_park_options
from radarslam.io.datasets.victoria_park import INPUT_PROFILES

DEFAULT_PATH = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"
ENGINES = ("fused", "steps")


def _config(mode: str, engine: str, backend: str):
    cfg = profile_config(INPUT_PROFILES[mode])
    return replace(cfg, filter=replace(cfg.filter, backend=backend, fused=engine == "fused"))


def bench(path: Path, mode: str, engine: str, backend: str, scans, repeat: int) -> dict:
    """``repeat`` runs of one mode and engine: ms per scan of each, and the last run."""
    cfg = _config(mode, engine, backend)
    loader = victoria_park_options(cfg, mode)
    if backend == "numba":  # compile (or load the cache) outside the timing
        run_dataset("victoria-park", path, cfg, n_scans=20, progress=False, loader_options=loader)
    ms, run = [], None
    for _ in range(repeat):
        run = run_dataset("victoria-park", path, cfg, n_scans=scans, progress=False, loader_options=loader)
        ms.append(1e3 * run.seconds / max(run.times.size, 1))
    ran = run.engine
    return {"ms": ms, "run": run, "ran": ran}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--path", type=Path, default=DEFAULT_PATH, help="the dataset directory")
    ap.add_argument("--scans", type=int, default=None, help="only the first N scans (default: all)")
    ap.add_argument("--backend", choices=("python", "numba"), default="numba",
                    help="filter.backend (default: the profile's, numba; the fused engine needs numba)")
    ap.add_argument("--input", choices=("laser", "trees", "both"), default="both",
                    help="raw laser returns (profile victoria-park), ACFR's tree detections (victoria-park-trees), "
                         "or both (default)")
    ap.add_argument("--engine", choices=(*ENGINES, "both"), default="both",
                    help="filter.fused true (the compiled engine) or false (its steps form), or both (default)")
    ap.add_argument("--repeat", type=int, default=3, help="runs of each (default 3): min and median")
    a = ap.parse_args()
    modes = ("laser", "trees") if a.input == "both" else (a.input,)
    engines = ENGINES if a.engine == "both" else (a.engine,)
    print(f"victoria-park, backend {a.backend}, one core, {a.repeat} run(s) each; filter time per scan:")
    print(f"  {'input':6} {'engine':13} {'scans':>6} {'min ms':>8} {'median ms':>10} {'landmarks':>10} {'RMSE m':>7}")
    last = None
    for mode in modes:
        for engine in engines:
            r = bench(a.path, mode, engine, a.backend, a.scans, a.repeat)
            run = r["run"]
            ev = evaluate_against_gps(run)
            name = engine if r["ran"] == engine else f"{engine}->{r['ran']}"
            print(f"  {mode:6} {name:13} {run.times.size:6d} {min(r['ms']):8.3f} {statistics.median(r['ms']):10.3f} "
                  f"{run.final_map.ids.size:10d} {ev['rmse_m']:7.2f}", flush=True)
            last = (mode, run)
    mode, run = last
    t0 = time.perf_counter()
    evaluate_against_gps(run)
    diam = compare_tree_diameters(run) if mode == "laser" else None
    print(f"  last run ({mode}): load {run.metrics['load_seconds']:.1f} s   evaluation {time.perf_counter() - t0:.1f} s"
          + ("" if diam is None else f"   matched trees {diam['n_matched']}"))


if __name__ == "__main__":
    main()
