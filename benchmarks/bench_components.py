"""The filter's time per car-park trial of every shipped variant and built-in component, and per
Victoria Park scan of both input modes, with the engine each runs in.

Car park (profile ``apsipa``, seed 1, ``--trials`` trials, one core, warm cache): the default
variants (No extent, With extent, Consistent), then the consistent variant with one component
changed at a time: the associator (nearest-neighbour, batch, batch-joint, JCBB), the extent
estimator (MEM-EKF*, visible-arc), first-estimates Jacobians, the partial-view model (the
visible-faces spread model in the simulation and the filter), Doppler odometry, the Doppler gate,
the odometry-bias states; and the partial view with the nearest-neighbour associator, which
relinearises every landmark's arc after each update. Each configuration simulates its own trials
(the partial view and the Doppler need their own detections: the work is equal up to that), runs each once untimed (the
compiled code is loaded or built), then ``--repeat`` times timed: the figure is the median over the
repeats of the mean filter time per trial (``run_filter``: the whole event stream to the record).
The ratio is to the Consistent variant's time; the engine is the fused one when
``filter.fused``, else its steps form.

Victoria Park (``--vp-scans`` scans of each input mode, fused engine; ``--vp-steps`` adds
the engine's steps form): ms per scan, median of ``--repeat`` runs, by ``bench_dataset.bench``.

    python benchmarks/bench_components.py                      # 10 trials, 3 repeats, 1000 VP scans
    python benchmarks/bench_components.py --trials 20 --repeat 5 --vp-scans 0   # car park only

The machine (a VM) changes speed by up to 2x between minutes: compare rows of one invocation; the
script prints the load average before and after.
"""

import argparse
import copy
import os
import statistics
import time
from pathlib import Path

import _common  # noqa: F401  (single-threaded BLAS)
import numpy as np

from radarslam.config import from_dict, merge_tables, profile_config, to_dict
from radarslam.montecarlo.trials import trial_seed
from radarslam.slam.driver import run_filter
from radarslam.config.variants import CONSISTENT, PAPER_VARIANTS
from radarslam.simulation.scenario import generate_scenario


def _with(base: dict, overlay: dict) -> dict:
    return merge_tables(copy.deepcopy(base), overlay)


_C = CONSISTENT.overlay
#: The partial-view model: the visible-faces spread model in the simulation and the filter.
_PV = {"radar": {"spread_model": "visible-faces"}, "extent": {"spread_model": "visible-faces"}}
#: (name, overlay on the apsipa profile): the default variants, then the consistent one with one change.
ROWS = [(v.label, v.overlay) for v in PAPER_VARIANTS] + [("Consistent", _C)] + [
    ("  associator nearest-neighbour", _with(_C, {"landmarks": {"associator": "nearest-neighbour"}})),
    ("  associator batch", _with(_C, {"landmarks": {"associator": "batch"}})),
    ("  associator batch-joint (default)", _C),
    ("  associator jcbb", _with(_C, {"landmarks": {"associator": "jcbb"}})),
    ("  estimator mem-ekf", _with(_C, {"extent": {"estimator": "mem-ekf"}})),
    ("  estimator visible-arc", _with(_C, {"extent": {"estimator": "visible-arc"}})),
    ("  jacobians fej", _with(_C, {"filter": {"jacobians": "fej"}})),
    ("  partial view (visible-faces)", _with(_C, _PV)),
    ("  partial view, nearest-neighbour", _with(_C, _with(_PV, {"landmarks": {"associator": "nearest-neighbour"}}))),
    ("  Doppler odometry", _with(_C, {"radar": {"doppler": True}, "filter": {"odometry": "doppler"}})),
    ("  Doppler gate", _with(_C, {"radar": {"doppler": True}, "filter": {"doppler_gate": True}})),
    ("  odometry-bias states", _with(_C, {"filter": {"odometry_bias": "states"}})),
]


def carpark_row(overlay: dict, trials: int, repeat: int) -> tuple[float, str]:
    """Median over ``repeat`` of the mean filter seconds per trial, and the engine."""
    cfg = from_dict(merge_tables(to_dict(profile_config("apsipa")), overlay))
    streams = [generate_scenario(cfg, np.random.default_rng(trial_seed(1, k))).events for k in range(1, trials + 1)]
    engine = run_filter(cfg, streams[0]).engine
    run_filter(cfg, streams[0])                                    # compile or load the cache
    per = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        for events in streams:
            run_filter(cfg, events)
        per.append((time.perf_counter() - t0) / trials)
    return statistics.median(per), engine


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=10, help="car-park trials per configuration (default 10)")
    ap.add_argument("--repeat", type=int, default=3, help="timed passes over them (default 3): the median")
    ap.add_argument("--vp-scans", type=int, default=1000, help="Victoria Park scans per mode (0: skip; default 1000)")
    ap.add_argument("--vp-steps", action="store_true", help="time the engine's steps form on Victoria Park too")
    ap.add_argument("--only", default=None, help="car-park rows whose name contains this (default: all)")
    a = ap.parse_args()
    print(f"load average before: {os.getloadavg()}")
    print(f"car park, profile apsipa, seed 1, {a.trials} trials, median of {a.repeat} passes, one core, warm cache")
    print(f"{'configuration':38s} {'engine':13s} {'ms/trial':>9s} {'x Consistent':>13s}")
    base = None
    for name, overlay in ROWS:
        if a.only and a.only not in name and name != "Consistent":
            continue
        sec, engine = carpark_row(overlay, a.trials, a.repeat)
        if name == "Consistent":
            base = sec
        ratio = f"{sec / base:13.2f}" if base else f"{'':13s}"
        print(f"{name:38s} {engine:13s} {1e3 * sec:9.1f} {ratio}", flush=True)
    if a.vp_scans > 0:
        from bench_dataset import DEFAULT_PATH, bench

        if not Path(DEFAULT_PATH).is_dir():
            print(f"Victoria Park: {DEFAULT_PATH} not found, skipped")
        else:
            print(f"\nVictoria Park, first {a.vp_scans} scans, median of {a.repeat} runs")
            print(f"{'mode':10s} {'engine':13s} {'ms/scan':>9s}")
            engines = ("fused", "steps") if a.vp_steps else ("fused",)
            for mode in ("laser", "trees"):
                for engine in engines:
                    r = bench(DEFAULT_PATH, mode, engine, "numba", a.vp_scans, a.repeat)
                    print(f"{mode:10s} {r['ran']:13s} {statistics.median(r['ms']):9.3f}", flush=True)
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
