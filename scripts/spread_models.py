"""RMA, EFA and MEM-EKF* under four radar spread models: a Monte Carlo per model (docs/method.md
b.4.1, b.4.2, a.10, a.11).

For each ``radar.spread_model`` (surface, the paper's; contour; visible-faces; scatter-centres) the car park is
simulated ``--trials`` times, and every trial runs six variants on the same data, the estimators
using the spread factor of that model (``extent.spread_model``, a.11):

- ``noext-rma`` / ``noext-mem``: No extent with the RMA (and its EFA baseline) or MEM-EKF* (and
  its EFA baseline) tracked. The extent does not feed SLAM, so both see the same landmarks and
  poses: the three estimators side by side;
- ``ext-rma`` / ``ext-mem``: the paper's With extent, RMA or MEM-EKF* feeding SLAM (a.7.1, a.7.2);
- ``cons-rma`` / ``cons-mem``: the consistent filter of a.7.3 with either estimator.

Writes ``OUT/<model>/`` (the resumable Monte Carlo directories) and ``OUT/spread_models.md``,
``.json`` and ``.png``: Table 1 rows (position and heading average RMSE with 95% bootstrap CIs),
the shape GWD (the moment ellipse on the estimate's centroid, docs/method.md e item 4) and the GWD
(moment convention) of each estimator as Fig. 3-style RMSE over trials, and the filter time per
trial of each variant. Seed 1 is the reporting seed; no parameter is chosen here.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from radarslam.config import profile_config, to_dict
from radarslam.montecarlo.trials import load_results, run_montecarlo
from radarslam.montecarlo.report.tables import GWD_SETTLED_FROM, gwd_curves, table1
from radarslam.metrics.pose import avg_rmse
from radarslam.metrics.statistics import (bootstrap_avg_rmse, bootstrap_counts, percentile_interval,
                                          rmse_over_defined)
from radarslam.config.variants import CONSISTENT, Variant

MODELS = ("surface", "contour", "visible-faces", "scatter-centres")
#: What each variant's "rma" slot holds (its estimator's matrix); the "efa" slot is the EFA baseline.
ESTIMATOR = {"rma-efa": "RMA", "mem-ekf": "MEM-EKF*"}


def variants() -> tuple[Variant, ...]:
    out = []
    for est, tag in (("rma-efa", "rma"), ("mem-ekf", "mem")):
        name = ESTIMATOR[est]
        # the full view throughout (docs/method.md a.12.8): this script compares the estimators of a
        # centred ellipse; the partial-view model is `radarslam reproduce --study partial-view`
        full = {"estimator": est, "view_model": "full"}
        out += [Variant(f"noext-{tag}", f"No extent, {name} tracked", {"extent": {"use_in_slam": False, **full}}),
                Variant(f"ext-{tag}", f"With extent ({name})", {"extent": {"use_in_slam": True, **full}}),
                Variant(f"cons-{tag}", f"Consistent ({name})",
                        {**CONSISTENT.overlay, "extent": {**CONSISTENT.overlay["extent"], **full}})]
    order = ["noext-rma", "noext-mem", "ext-rma", "ext-mem", "cons-rma", "cons-mem"]
    return tuple(sorted(out, key=lambda v: order.index(v.name)))


def shape_curves(res: dict, name: str) -> dict[str, np.ndarray]:
    """Fig. 3-style RMSE over trials of the per-scan mean *shape* GWD (docs/method.md e, item 4)."""
    return {est: rmse_over_defined(res[name][f"gwd_{est}_shape"])[0] for est in ("rma", "efa")}


def _settled(curve: np.ndarray) -> float:
    c = np.asarray(curve, dtype=float)[GWD_SETTLED_FROM - 1:]
    return float(np.nanmean(c))


def summarise(out: Path) -> dict:
    res = load_results(out)
    t1 = table1(res)
    g = gwd_curves(res, "moment")
    rows, curves = {}, {}
    for name in t1["variants"]:
        c, sh = g["configs"][name], shape_curves(res, name)
        rows[name] = {
            "label": t1["labels"][name],
            "position_m": t1["position_avg_rmse_m"][name],
            "heading_deg": t1["heading_avg_rmse_deg"][name],
            "gwd_mean_k10": {"est": c["rma"]["mean_k10"], "efa": c["efa"]["mean_k10"]},
            "shape_mean_k10": {"est": _settled(sh["rma"]), "efa": _settled(sh["efa"])},
            "shape_final": {"est": float(sh["rma"][-1]), "efa": float(sh["efa"][-1])},
        }
        curves[name] = {"moment": (c["rma"]["rmse"].tolist(), c["efa"]["rmse"].tolist()),
                        "shape": (sh["rma"].tolist(), sh["efa"].tolist())}
    return {"n_trials": int(res["trials"].size), "rows": rows, "curves": curves,
            "seconds": {name: float(np.median(t)) for name, t in res["filter_seconds"].items()},
            "paired": paired_changes(res)}


def paired_changes(res: dict, n_boot: int = 2000, level: float = 0.95) -> dict:
    """Position average RMSE of MEM-EKF* feeding SLAM against the RMA feeding it, in percent, with
    the paired bootstrap interval (the same resampled trials for both; seed 0 as the report's)."""
    counts = bootstrap_counts(res["trials"].size, n_boot, np.random.default_rng(0))
    out = {}
    for mem, rma in (("ext-mem", "ext-rma"), ("cons-mem", "cons-rma")):
        a, b = res[mem]["position_error_m"], res[rma]["position_error_m"]
        boot = 100.0 * (bootstrap_avg_rmse(a, counts) / bootstrap_avg_rmse(b, counts) - 1.0)
        out[mem] = {"estimate": 100.0 * (avg_rmse(a) / avg_rmse(b) - 1.0), "ci": percentile_interval(boot, level)}
    return out


def _ci(d: dict, nd: int) -> str:
    lo, hi = d["ci"]
    return f"{d['estimate']:.{nd}f} [{lo:.{nd}f}, {hi:.{nd}f}]"


def markdown(summary: dict, seed: int) -> str:
    lines = [f"# RMA, EFA and MEM-EKF* under three spread models (seed {seed})", ""]
    lines += ["Shape GWD: the moment ellipse placed on the estimate's centroid (the shape alone, docs/method.md e "
              "item 4), RMSE over trials of the per-scan mean, averaged over scans k >= 10 / at the last scan. "
              "GWD: the same with the true centre (moment convention, Fig. 3), averaged over k >= 10, mostly the "
              "centroid's error. Filter time: median per trial and variant, one core, numba, two workers.", ""]
    for model, s in summary.items():
        lines += [f"## {model} ({s['n_trials']} trials)", "",
                  "| variant | position avg. RMSE (m) | heading avg. RMSE (deg) | shape GWD of its estimator (m) "
                  "| shape GWD of EFA (m) | GWD its estimator / EFA (m) | filter ms per trial |",
                  "|---|---|---|---|---|---|---|"]
        for name, r in s["rows"].items():
            est = "MEM-EKF*" if name.endswith("mem") else "RMA"
            lines.append(f"| {r['label']} | {_ci(r['position_m'], 3)} | {_ci(r['heading_deg'], 2)} | "
                         f"{est} {r['shape_mean_k10']['est']:.3f} / {r['shape_final']['est']:.3f} | "
                         f"{r['shape_mean_k10']['efa']:.3f} / {r['shape_final']['efa']:.3f} | "
                         f"{r['gwd_mean_k10']['est']:.3f} / {r['gwd_mean_k10']['efa']:.3f} | "
                         f"{1e3 * s['seconds'][name]:.0f} |")
        lines.append("")
        for mem, label in (("ext-mem", "With extent"), ("cons-mem", "Consistent")):
            c = s["paired"][mem]
            lines.append(f"- {label}: position avg. RMSE with MEM-EKF* feeding SLAM against the RMA, paired: "
                         f"{c['estimate']:+.1f}% [{c['ci'][0]:+.1f}, {c['ci'][1]:+.1f}]")
        lines.append("")
    return "\n".join(lines)


def figure(summary: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(summary), figsize=(4.2 * len(summary), 6.4), sharey="row", squeeze=False)
    for col, (model, s) in enumerate(summary.items()):
        for row, kind in enumerate(("shape", "moment")):
            ax = axes[row, col]
            rma, efa = (np.array(c, dtype=float) for c in s["curves"]["noext-rma"][kind])
            mem, _ = (np.array(c, dtype=float) for c in s["curves"]["noext-mem"][kind])
            k = np.arange(1, rma.size + 1)
            ax.plot(k, rma, label="RMA")
            ax.plot(k, mem, label="MEM-EKF*")
            ax.plot(k, efa, label="EFA", ls="--")
            ax.set_title(f"{model} ({s['n_trials']} trials)" if row == 0 else "")
            ax.set_xlabel("scan k" if row == 1 else "")
            ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel("RMSE of the shape GWD (m)")
    axes[1, 0].set_ylabel("RMSE of the GWD (m), moment")
    axes[0, 0].legend()
    fig.suptitle("Extents tracked side by side (No extent: the same landmarks for all three)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=300)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--models", default=",".join(MODELS))
    p.add_argument("--out", default="runs/spread-models")
    a = p.parse_args(argv)
    models = a.models.split(",")
    bad = [m for m in models if m not in MODELS]
    if bad:
        print(f"--models: expected names among {list(MODELS)}, got {bad}", file=sys.stderr)
        return 2
    out = Path(a.out)
    summary, configs = {}, {}
    for model in models:
        cfg = profile_config()
        cfg = replace(cfg, radar=replace(cfg.radar, spread_model=model),
                      extent=replace(cfg.extent, spread_model=model))
        run_montecarlo(cfg, a.seed, a.trials, out / model, jobs=a.jobs, variants=variants())
        summary[model] = summarise(out / model)
        configs[model] = to_dict(cfg)
    text = markdown(summary, a.seed)
    print(text)
    out.mkdir(parents=True, exist_ok=True)
    (out / "spread_models.md").write_text(text + "\n")
    (out / "spread_models.json").write_text(json.dumps({"seed": a.seed, "configs": configs, "summary": summary},
                                                       indent=1, default=float) + "\n")
    figure(summary, out / "spread_models.png")
    print(f"written: {out}/spread_models.md, .json, .png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
