"""Wall time of one complete Monte Carlo trial on one core, and every stage's share of it.

A trial is what a Monte Carlo worker does (``montecarlo.trials.compute_trial``): simulate the
car park, run the filter of each variant on it (RMA and EFA tracked), evaluate every run and encode
the result. Two passes over the same trials:

1. plain: ``compute_trial`` as the Monte Carlo calls it; median, p10, p90 (what the issue's
   target is about);
2. by stage: the same trials with a timer around each stage (simulation, configuration, the
   filter, evaluation, encoding). Within the filter, the engine's parts (the event stream as arrays,
   the run in parts, the record), compiled (the default, ``filter.fused``), in its steps form
   (``--no-fused``) or in its Python form (``--backend python``, docs/architecture.md "Backends").
   The timers cost ~1 us per call, so the stages add up to a little more than pass 1.

The machine this runs on (a VM) changes speed by up to 2x between minutes: compare figures from
one invocation, or runs interleaved (``--repeat``), not numbers taken at different times.
"""

import argparse
import time
from collections import defaultdict
from dataclasses import replace

import _common  # noqa: F401  (single-threaded BLAS)
import numpy as np

from radarslam.config import profile_config
from radarslam.montecarlo import trials as montecarlo
from radarslam.config.variants import DEFAULT_VARIANTS, PAPER_VARIANTS
from radarslam.slam.fused import plan as _fused
#: Module-level stages of compute_trial timed in pass 2.
TRIAL_STAGES = {"generate_scenario": "simulation", "variant_config": "configuration",
                "evaluate": "evaluation", "encode_trial": "encoding", "run_filter": "filter"}
#: The fused engine's parts (radarslam.slam.fused.plan, where run finds them) timed in pass 2.
FUSED_PARTS = {"_stream_arrays": "fused: events as arrays", "_parts": "fused: compiled run (run_stream, in parts)"}


def _timed(fn, name, acc):
    def wrapper(*a, **k):
        t0 = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            acc[name] += time.perf_counter() - t0
    return wrapper


def stage_times(cfg, seed, trials, variants):
    """Seconds per trial of each stage (pass 2); restores everything it wraps."""
    acc = defaultdict(float)
    saved_mc = {n: getattr(montecarlo, n) for n in TRIAL_STAGES}
    saved_fused = {n: getattr(_fused, n) for n in FUSED_PARTS}
    try:
        for n, label in TRIAL_STAGES.items():
            setattr(montecarlo, n, _timed(saved_mc[n], label, acc))
        for n, label in FUSED_PARTS.items():
            setattr(_fused, n, _timed(saved_fused[n], label, acc))
        t0 = time.perf_counter()
        for k in trials:
            montecarlo.compute_trial(cfg, seed, k, variants)
        total = time.perf_counter() - t0
    finally:
        for n, f in saved_mc.items():
            setattr(montecarlo, n, f)
        for n, f in saved_fused.items():
            setattr(_fused, n, f)
    n = len(trials)
    rows = {label: acc[label] / n for label in TRIAL_STAGES.values() if label != "filter"}
    steps = {label: acc[label] / n for label in FUSED_PARTS.values()}
    steps["run_filter (rest: EkfSlam, record)"] = (acc["filter"] - sum(acc[v] for v in FUSED_PARTS.values())) / n
    rows["other (compute_trial)"] = total / n - sum(rows.values()) - acc["filter"] / n
    return total / n, rows, steps


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trials", type=int, default=30)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--backend", choices=("python", "numba"), default=None,
                    help="filter.backend (default: the configuration's, numba)")
    ap.add_argument("--variants", choices=("paper", "default"), default="paper",
                    help="paper: No extent + With extent (the issue's trial); default: the Monte Carlo's three")
    ap.add_argument("--no-fused", action="store_true", help="filter.fused = false: the engine's steps form")
    ap.add_argument("--no-stages", action="store_true", help="skip pass 2")
    ap.add_argument("--reference", action="store_true",
                    help="the Python reference whole (compute_trial engine 'python': simulation, filter and "
                         "matching uncompiled), what a short first run takes; with NUMBA_CACHE_DIR=$(mktemp -d) "
                         "the first trial shows that it compiles nothing")
    a = ap.parse_args()
    cfg = profile_config()
    if a.backend:
        cfg = replace(cfg, filter=replace(cfg.filter, backend=a.backend))
    if a.no_fused:
        cfg = replace(cfg, filter=replace(cfg.filter, fused=False))
    variants = PAPER_VARIANTS if a.variants == "paper" else DEFAULT_VARIANTS
    engine = "python" if a.reference else "auto"
    t0 = time.perf_counter()
    montecarlo.compute_trial(cfg, a.seed, 1, variants, engine=engine)  # warm-up: imports, compiled-code cache
    warm = time.perf_counter() - t0
    trials = range(1, a.trials + 1)
    t = []
    for k in trials:
        t0 = time.perf_counter()
        montecarlo.compute_trial(cfg, a.seed, k, variants, engine=engine)
        t.append(time.perf_counter() - t0)
    t = np.array(t)
    names = " + ".join(v.name for v in variants)
    engine = ("reference whole" if a.reference else "fused-python" if cfg.filter.backend == "python" else
              "fused" if cfg.filter.fused else "fused-steps")
    print(f"complete trial (simulation, {names}, RMA + EFA, evaluation), backend {cfg.filter.backend}, {engine}, "
          f"{a.trials} trials, one core (first trial incl. warm-up: {warm:.2f} s):")
    print(f"  median {1e3 * np.median(t):.1f} ms   p10 {1e3 * np.percentile(t, 10):.1f} ms   "
          f"p90 {1e3 * np.percentile(t, 90):.1f} ms   min {1e3 * t.min():.1f} ms")
    if a.no_stages or a.reference:
        return
    total, rows, steps = stage_times(cfg, a.seed, trials, variants)
    print(f"\nby stage (pass 2, timers on; {1e3 * total:.1f} ms per trial):")
    print(f"  {'stage':40s} {'ms/trial':>9s} {'share':>7s}")
    filt = sum(steps.values())
    for label, s in rows.items():
        print(f"  {label:40s} {1e3 * s:9.2f} {100 * s / total:6.1f}%")
    print(f"  {'filter (all variants)':40s} {1e3 * filt:9.2f} {100 * filt / total:6.1f}%")
    for label, s in sorted(steps.items(), key=lambda kv: -kv[1]):
        print(f"    {label:38s} {1e3 * s:9.2f} {100 * s / total:6.1f}%")


if __name__ == "__main__":
    main()
