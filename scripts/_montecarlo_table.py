"""Shared command line of the scripts that run one Monte Carlo of variants and print a table."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

from radarslam.config import profile_config, to_dict
from radarslam.core.registry import BACKENDS
from radarslam.metrics.pose import avg_rmse
from radarslam.metrics.statistics import bootstrap_avg_rmse, bootstrap_counts, percentile_interval
from radarslam.montecarlo.report import nees_summary, nis_summary
from radarslam.montecarlo.trials import load_results, run_montecarlo


def main(doc: str, variants: list, table: Callable[[dict], list[dict]], markdown: Callable[[list[dict], dict], str],
         stem: str, *, trials: int, seed: int, out: str, refuse_seed: int | None = None,
         argv: list[str] | None = None, after: Callable[[list[dict], dict, Path], None] | None = None) -> int:
    """Parse ``--trials --seed --jobs --backend --profile --out``, run (or resume) the Monte Carlo of
    ``variants``, print ``markdown(table(res), res)`` and write it with the rows as ``stem.md`` and
    ``stem.json`` (with the seed, trial count and configuration) into the run directory; then
    ``after(rows, res, run_dir)`` if given (e.g. a figure beside the table)."""
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("--trials", type=int, default=trials)
    p.add_argument("--seed", type=int, default=seed)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--backend", choices=BACKENDS, default="numba")
    p.add_argument("--profile", default="apsipa")
    p.add_argument("--out", default=out)
    p.add_argument("--report", action="store_true",
                   help="the final run on the reporting seed, once every parameter is fixed on training seeds")
    a = p.parse_args(argv)
    if refuse_seed is not None and a.seed == refuse_seed and not a.report:
        print(f"{stem}: --seed {a.seed} is the reporting seed; choose parameters on other seeds "
              f"(--report for the final run, parameters fixed)", file=sys.stderr)
        return 2
    cfg = profile_config(a.profile)
    cfg = type(cfg)(**{**cfg.__dict__, "filter": type(cfg.filter)(**{**cfg.filter.__dict__, "backend": a.backend})})
    run_montecarlo(cfg, a.seed, a.trials, a.out, jobs=a.jobs, variants=variants)
    res = load_results(a.out)
    rows = table(res)
    text = markdown(rows, res)
    print(text)
    Path(a.out, f"{stem}.md").write_text(text + "\n")
    Path(a.out, f"{stem}.json").write_text(json.dumps({"seed": a.seed, "trials": int(res["trials"].size),
                                                       "config": to_dict(cfg), "rows": rows}, indent=2) + "\n")
    if after is not None:
        after(rows, res, Path(a.out))
    return 0


def run_ablation_table(cfg, variants: list, seed: int, trials: int, out: str, jobs: int, stem: str,
                       title: str | None = None) -> str:
    """Run (or resume) the Monte Carlo of ``variants`` on ``cfg``'s simulated data, print the
    ablation-style table (position, heading, NEES, NIS; ``title`` in place of its first words) and
    write it as ``out/stem.md`` and, with the rows, seed and configuration, ``out/stem.json``."""
    run_montecarlo(cfg, seed, trials, out, jobs=jobs, variants=variants)
    res = load_results(out)
    rows = table(res)
    text = markdown(rows, res["trials"].size, res["seed"], nees_summary(res)["band"])
    if title:
        text = text.replace("Ablation of the consistent variant", title, 1)
    print(text)
    Path(out, f"{stem}.md").write_text(text + "\n")
    Path(out, f"{stem}.json").write_text(json.dumps({"seed": seed, "trials": int(res["trials"].size),
                                                     "config": to_dict(cfg), "rows": rows}, indent=2) + "\n")
    return text


def run_under_spread_model(variants: list, spread_model: str, seed: int, trials: int, out: str, jobs: int,
                           stem: str) -> str:
    """:func:`run_ablation_table` with the car park simulated under ``spread_model`` (radar and
    extent alike)."""
    from dataclasses import replace

    cfg = profile_config()
    cfg = replace(cfg, radar=replace(cfg.radar, spread_model=spread_model),
                  extent=replace(cfg.extent, spread_model=spread_model))
    return run_ablation_table(cfg, variants, seed, trials, out, jobs, stem)


# --- the ablation-style table (position, heading, NEES, NIS) of a Monte Carlo's variants ---


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
