"""Cost of the filter per scan against the number of landmarks in its state (a large car park).

Runs the filter once over the generated car park of the profile ``large-carpark`` (docs/method.md
b.1.1: about 500 parked cars in rows, a 2000-scan drive through the aisles; ``--steps`` changes the
length) and times every scan (with the predictions before it): the fused engine times its scans itself
(the default), its steps form (``--no-fused``) every ``EkfSlam.update`` and ``predict`` call. Prints the median cost per scan
in bins of the landmark count, the power-law exponent fitted to the bins above ``--fit-from``
landmarks (cost ~ N^b), and writes a figure of the curve (``--out``).

The variants: ``noext`` (sequential nearest-neighbour updates, one per detection: O(m N^2) per
scan), ``consistent`` (the default consistent filter: all landmarks of the scan in one stacked
update, ``batch-joint``, one pass over the N x N covariance) and ``per-landmark`` (the consistent
filter with one batch update per landmark seen, ``batch``: L passes).
"""

import argparse
import time
from dataclasses import replace
from pathlib import Path

import _common  # noqa: F401  (single-threaded BLAS)
import numpy as np

from radarslam.config import profile_config
from radarslam.core.types import Scan
from radarslam.config import merge_tables
from radarslam.config.variants import CONSISTENT, PAPER_VARIANTS, Variant, apply_variant
from radarslam.simulation.scenario import generate_scenario
from radarslam.slam import _fused
from radarslam.slam.filter import EkfSlam

#: The consistent filter with one batch update per landmark (``batch``).
PER_LANDMARK = Variant("per-landmark", "Consistent, one batch update per landmark",
                       merge_tables(CONSISTENT.overlay, {"landmarks": {"associator": "batch"}}))
VARIANTS = {v.name: v for v in PAPER_VARIANTS + (CONSISTENT, PER_LANDMARK)}


def run(cfg, scenario):
    """Per scan: landmarks in the state before it, seconds of (predict + update), detections. With
    the compiled engine (``filter.fused``) the engine times each scan itself."""
    slam = EkfSlam(cfg)
    if cfg.filter.fused:
        r, _ = _fused.run(slam, scenario.events, timing=True)
        before = np.concatenate([[0], r["n_landmarks"][:-1]])
        err = np.hypot(*(r["poses"][-1, :2] - scenario.truth.poses[-1, :2]))
        return np.column_stack([before, r["seconds"], r["n_detections"]]), err
    rows, pending = [], 0.0
    for ev in scenario.events:
        n = len(slam.landmarks)
        t0 = time.perf_counter()
        rep = slam.process(ev)
        dt = time.perf_counter() - t0
        if rep is None:
            pending += dt
            continue
        rows.append((n, pending + dt, rep.n_detections))
        pending = 0.0
    err = np.hypot(*(np.array([slam.pose[:2]]) - scenario.truth.poses[-1:, :2]).T)[0]
    return np.array(rows), err


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--variants", default="noext,per-landmark,consistent",
                    help="comma-separated: noext, ext, consistent (stacked update), per-landmark (consistent with associator batch)")
    ap.add_argument("--steps", type=int, default=None, help="scans (default: the profile's, 2000)")
    ap.add_argument("--rows", type=int, default=None, help="rows of cars (default: the profile's, 12)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--bin", type=int, default=50, help="landmark-count bin width")
    ap.add_argument("--fit-from", type=int, default=100, help="fit the exponent on bins from this count")
    ap.add_argument("--out", default="runs/bench_scaling.png", help="figure path")
    ap.add_argument("--no-fused", action="store_true", help="filter.fused = false: the engine's steps form, event by event")
    a = ap.parse_args()
    base = profile_config("large-carpark")
    if a.no_fused:
        base = replace(base, filter=replace(base.filter, fused=False))
    if a.steps:
        base = replace(base, trajectory=replace(base.trajectory, n_steps=a.steps))
    if a.rows:
        base = replace(base, world=replace(base.world, rows=a.rows))
    w = base.world
    t0 = time.perf_counter()
    scenario = generate_scenario(base, np.random.default_rng(a.seed))
    m = np.array([e.polar.shape[0] for e in scenario.events if isinstance(e, Scan)])
    print(f"large car park: {w.rows * w.cars_per_row} cars in {w.rows} rows, {m.size} scans, "
          f"{m.mean():.0f} detections per scan (max {m.max()}); simulated in {time.perf_counter() - t0:.1f} s")
    curves = {}
    for name in a.variants.split(","):
        cfg = apply_variant(base, VARIANTS[name])
        t0 = time.perf_counter()
        rows, err = run(cfg, scenario)
        total = time.perf_counter() - t0
        n, sec = rows[:, 0], rows[:, 1]
        engine = "fused" if cfg.filter.fused else "steps"
        print(f"\n{name} ({VARIANTS[name].label}; associator {cfg.landmarks.associator}, backend "
              f"{cfg.filter.backend}, {engine}): {total:.1f} s for {rows.shape[0]} scans, {int(n.max())} landmarks at most, "
              f"final position error {err:.1f} m")
        print(f"  {'landmarks':>12s} {'scans':>6s} {'median ms/scan':>15s} {'p90':>7s}")
        centers, medians = [], []
        for lo in range(0, int(n.max()) + 1, a.bin):
            sel = (n >= lo) & (n < lo + a.bin)
            if sel.sum() < 5:
                continue
            med = np.median(sec[sel])
            print(f"  {lo:5d}-{lo + a.bin - 1:<6d} {sel.sum():6d} {1e3 * med:15.2f} {1e3 * np.percentile(sec[sel], 90):7.2f}")
            centers.append(np.median(n[sel]))
            medians.append(med)
        c, md = np.array(centers), np.array(medians)
        fit = c >= a.fit_from
        if fit.sum() >= 2:
            b, log_a = np.polyfit(np.log(c[fit]), np.log(md[fit]), 1)
            at500 = np.exp(log_a) * 500.0 ** b
            print(f"  fitted cost ~ N^{b:.2f} over N >= {a.fit_from}; at N = 500: {1e3 * at500:.1f} ms per scan"
                  f"{' (extrapolated)' if c.max() < 475 else ''}")
        curves[name] = (n, sec, c, md)
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib not installed: no figure")
        return
    fig, ax = plt.subplots(figsize=(6, 4))
    for name, (n, sec, c, md) in curves.items():
        ax.plot(n, 1e3 * sec, ".", ms=1.5, alpha=0.25)
        ax.plot(c, 1e3 * md, "o-", label=f"{VARIANTS[name].label} (median per {a.bin} landmarks)")
    ax.axhline(10.0, color="k", lw=0.8, ls="--", label="10 ms")
    ax.set_xlabel("landmarks in the state N")
    ax.set_ylabel("filter time per scan (ms)")
    ax.set_yscale("log")
    engine = "fused" if base.filter.fused else "steps"
    ax.set_title(f"Large car park ({w.rows * w.cars_per_row} cars), one core, {base.filter.backend}, {engine}")
    ax.legend(fontsize=7)
    out = Path(a.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    fig.savefig(out, dpi=120)
    print(f"\nfigure: {out}")


if __name__ == "__main__":
    main()
