"""Ablation of the consistent variant (docs/method.md a.7.3): each part switched off in turn.

    python scripts/ablation_consistent.py --trials 200 --seed 1 --jobs 2 --out runs/ablation

Prints, for "No extent", "With extent", the consistent variant and the consistent variant without
each of its parts: position / heading avg. RMSE with 95% bootstrap CIs, the fraction of scans whose
average pose NEES lies in its two-sided 95% chi-square band, the time-averaged NEES (3 for a
consistent filter) and the mean NIS of the updates (2 for a consistent filter).
"""

from __future__ import annotations

import copy
import sys

import _montecarlo_table
import numpy as np

from radarslam.montecarlo.report import nees_summary, nis_summary
from radarslam.config.variants import CONSISTENT, DEFAULT_VARIANTS, Variant
from radarslam.metrics.pose import avg_rmse
from radarslam.metrics.statistics import bootstrap_avg_rmse, bootstrap_counts, percentile_interval


def _without(name: str, label: str, section: str, key: str, value) -> Variant:
    overlay = copy.deepcopy(CONSISTENT.overlay)
    overlay.setdefault(section, {})[key] = value
    return Variant(name, label, overlay)


def ablation_variants() -> list[Variant]:
    return list(DEFAULT_VARIANTS) + [
        _without("no-pre-init-spread", "consistent without the pre-initialisation spread", "extent",
                 "pre_init_spread", "none"),
        _without("scatter-spread", "consistent, buffered scatter instead of the prior spread", "extent",
                 "pre_init_spread", "scatter"),
        _without("nearest-init", "consistent without the cluster-mean initialisation", "landmarks", "init", "nearest"),
        _without("sequential", "consistent without the batch update (sequential)", "landmarks", "associator",
                 "nearest-neighbour"),
    ]


def table(res: dict, n_boot: int = 2000) -> list[dict]:
    n = res["trials"].size
    counts = bootstrap_counts(n, n_boot, np.random.default_rng(0))
    ns, nis = nees_summary(res), nis_summary(res)
    rows = []
    for v in res["variants"]:
        b = res[v.name]
        pe, he = b["position_error_m"], np.degrees(b["heading_error_rad"])
        c = ns["configs"][v.name]
        rows.append({"variant": v.name, "label": v.label,
                     "position_m": avg_rmse(pe), "position_ci": percentile_interval(bootstrap_avg_rmse(pe, counts)),
                     "heading_deg": avg_rmse(he), "heading_ci": percentile_interval(bootstrap_avg_rmse(he, counts)),
                     "nees_inside": c["frac_inside"], "nees_time_avg": c["time_avg"],
                     "nis_mean": nis["configs"][v.name]["overall"] if v.name in nis["configs"] else float("nan"),
                     "nis_inside": nis["configs"][v.name]["frac_inside"] if v.name in nis["configs"] else float("nan")})
    return rows


def markdown(rows: list[dict], n: int, seed: int, band) -> str:
    out = [f"Ablation of the consistent variant, {n} trials, seed {seed}; NEES band [{band[0]:.2f}, {band[1]:.2f}]", "",
           "| variant | position avg. RMSE (m) [95% CI] | heading avg. RMSE (deg) [95% CI] | NEES inside band "
           "| time-avg. NEES (3) | mean NIS (2) | NIS inside band |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['label']} | {r['position_m']:.3f} [{r['position_ci'][0]:.3f}, {r['position_ci'][1]:.3f}] "
                   f"| {r['heading_deg']:.2f} [{r['heading_ci'][0]:.2f}, {r['heading_ci'][1]:.2f}] "
                   f"| {100 * r['nees_inside']:.0f}% | {r['nees_time_avg']:.2f} | {r['nis_mean']:.2f} "
                   f"| {100 * r['nis_inside']:.0f}% |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    return _montecarlo_table.main(__doc__, ablation_variants(), table, lambda rows, res: markdown(rows, res['trials'].size, res['seed'], nees_summary(res)['band']), "ablation", trials=200, seed=1,
                                  out="runs/ablation", refuse_seed=None, argv=argv)


if __name__ == "__main__":
    sys.exit(main())
