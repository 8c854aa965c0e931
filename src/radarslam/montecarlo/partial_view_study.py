"""The partial-view study: the Monte Carlo under each radar spread model, side by side
(``radarslam reproduce --study partial-view``; docs/method.md a.12, b.4.1-b.4.2).

For each spread model (``surface``, the paper's; ``visible-faces``; ``scatter-centres``, the second
radar model) the car park is simulated ``trials`` times with ``radar.spread_model`` and
``extent.spread_model`` set to it, and every trial runs on the same data:

- the three default variants, "No extent", "With extent" and the consistent one, with their
  defaults: the full view on the surface model, the partial view (``extent.view_model = "auto"``)
  on the other two;
- on the partial-view models, the two extent variants with the full view as well (``-full``), the
  negative control of the partial-view model.

Each model's run is an ordinary Monte Carlo directory (``OUT/<model>/``, resumable, with its own
report); ``OUT/partial_view_study.md``, ``.json`` and ``.png`` put the models side by side: position and
heading average RMSE with 95% bootstrap intervals, the paired change against "No extent", the
time-averaged pose NEES and the fraction of scans inside its band, and the shape GWD of the
estimator that feeds SLAM against the RMA's on the same landmarks. Seed 1 is the reporting seed;
no parameter is chosen here (scripts/partial_view_sweep.py does that on training seeds).
"""

from __future__ import annotations

import copy
import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from radarslam.config import Config, PARTIAL_VIEW_SPREAD_MODELS, to_dict
from radarslam.montecarlo.trials import load_results, run_montecarlo
from radarslam.montecarlo.report import write_report
from radarslam.montecarlo.report.tables import nees_summary, table1
from radarslam.config.variants import CONSISTENT, DEFAULT_VARIANTS, PAPER_VARIANTS, Variant

MODELS = ("surface", "visible-faces", "scatter-centres")
#: Scans from which the shape GWD is averaged (the first ones hold the newborns' priors).
SETTLED_FROM = 10


def _full_view(v: Variant, name: str, label: str) -> Variant:
    ov = copy.deepcopy(v.overlay)
    ov.setdefault("extent", {})["view_model"] = "full"
    return Variant(name, label, ov)


def study_variants(model: str) -> tuple[Variant, ...]:
    """The default variants, plus their full-view forms on a partial-view spread model."""
    if model not in PARTIAL_VIEW_SPREAD_MODELS:
        return DEFAULT_VARIANTS
    return DEFAULT_VARIANTS + (_full_view(PAPER_VARIANTS[1], "ext-full", "With extent, full view"),
                               _full_view(CONSISTENT, "consistent-full", "Consistent, full view"))


def model_config(base: Config, model: str) -> Config:
    return replace(base, radar=replace(base.radar, spread_model=model),
                   extent=replace(base.extent, spread_model=model))


def _shape(res: dict, name: str) -> dict:
    """Mean over scans k >= SETTLED_FROM of the per-scan RMSE over trials of the shape GWD (the
    moment ellipse on the estimate's centroid, docs/method.md e item 4): the estimator feeding
    SLAM (slot ``rma``) and its baseline (slot ``efa``: the RMA under the partial view, the EFA
    otherwise)."""
    out = {}
    for slot in ("rma", "efa"):
        a = np.asarray(res[name][f"gwd_{slot}_shape"], dtype=float)[:, SETTLED_FROM - 1:]
        with np.errstate(invalid="ignore"):
            out[slot] = float(np.nanmean(np.sqrt(np.nanmean(a ** 2, axis=0))))
    return out


def summarise(out: Path) -> dict:
    res = load_results(out)
    t1, ns = table1(res), nees_summary(res)
    rows = {}
    for name in t1["variants"]:
        rows[name] = {"label": t1["labels"][name],
                      "position_m": t1["position_avg_rmse_m"][name],
                      "heading_deg": t1["heading_avg_rmse_deg"][name],
                      "change_position_pct": t1["position_avg_rmse_m"]["change_pct"].get(name),
                      "change_heading_pct": t1["heading_avg_rmse_deg"]["change_pct"].get(name),
                      "nees_time_avg": ns["configs"][name]["time_avg"],
                      "nees_inside": ns["configs"][name]["frac_inside"],
                      "shape_gwd": _shape(res, name),
                      "filter_ms": 1e3 * float(np.median(res["filter_seconds"][name]))}
    return {"n_trials": int(res["trials"].size), "rows": rows, "nees_band": list(ns["band"])}


def _ci(d: dict | None, nd: int, sign: bool = False) -> str:
    if not d:
        return "-"
    f = f"{{:+.{nd}f}}" if sign else f"{{:.{nd}f}}"
    lo, hi = d["ci"]
    return f"{f.format(d['estimate'])} [{f.format(lo)}, {f.format(hi)}]"


def markdown(summary: dict, seed: int) -> str:
    lines = [f"# The partial-view study (seed {seed})", "",
             "Position / heading: average RMSE with 95% bootstrap intervals over trials; change: paired against "
             "No extent. NEES: time average of the average pose NEES (3 for a consistent filter) and the share of "
             "scans inside its 95% band. Shape GWD: the moment ellipse on the estimate's centroid (the shape "
             f"alone), RMSE over trials per scan, mean over scans k >= {SETTLED_FROM}; 'its estimator' is the one "
             "feeding SLAM (the partial-view estimator under the partial view), 'baseline' the RMA under the "
             "partial view and the EFA otherwise. Filter ms: median per trial, one core.", ""]
    for model, s in summary.items():
        lines += [f"## {model} ({s['n_trials']} trials)", "",
                  "| variant | position (m) | heading (deg) | change position (%) | change heading (%) "
                  "| NEES time-avg | NEES inside band | shape GWD its estimator / baseline (m) | filter ms |",
                  "|---|---|---|---|---|---|---|---|---|"]
        for r in s["rows"].values():
            g = r["shape_gwd"]
            lines.append(f"| {r['label']} | {_ci(r['position_m'], 3)} | {_ci(r['heading_deg'], 2)} | "
                         f"{_ci(r['change_position_pct'], 1, True)} | {_ci(r['change_heading_pct'], 1, True)} | "
                         f"{r['nees_time_avg']:.2f} | {100 * r['nees_inside']:.0f}% | "
                         f"{g['rma']:.3f} / {g['efa']:.3f} | {r['filter_ms']:.0f} |")
        lines.append("")
    return "\n".join(lines)


def figure(summary: dict, path: Path) -> None:
    """Position avg. RMSE (with its 95% interval) and time-averaged NEES of every variant, a
    column of bars per spread model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    models = list(summary)
    names = list(dict.fromkeys(n for s in summary.values() for n in s["rows"]))
    width = 0.8 / len(names)
    for i, name in enumerate(names):
        xs, pos, lo, hi, nees = [], [], [], [], []
        for m, model in enumerate(models):
            r = summary[model]["rows"].get(name)
            if r is None:
                continue
            xs.append(m + (i - (len(names) - 1) / 2) * width)
            pos.append(r["position_m"]["estimate"])
            lo.append(pos[-1] - r["position_m"]["ci"][0])
            hi.append(r["position_m"]["ci"][1] - pos[-1])
            nees.append(r["nees_time_avg"])
        label = next(s["rows"][name]["label"] for s in summary.values() if name in s["rows"])
        axes[0].bar(xs, pos, width, yerr=[lo, hi], label=label)
        axes[1].bar(xs, nees, width, label=label)
    for ax, title in zip(axes, ("position avg. RMSE (m), 95% CI", "time-averaged pose NEES (3 = consistent)")):
        ax.set_xticks(range(len(models)), models)
        ax.set_title(title)
        ax.grid(alpha=0.3, axis="y")
    axes[1].set_yscale("log")
    axes[1].axhline(3.0, color="k", lw=0.8, ls="--")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def write_summary(out: Path, summary: dict, seed: int, configs: dict) -> None:
    """``partial_view_study.md``, ``.json`` and ``.png`` (with each model's configuration)."""
    (out / "partial_view_study.md").write_text(markdown(summary, seed) + "\n", encoding="utf-8")
    (out / "partial_view_study.json").write_text(json.dumps({"seed": seed, "configs": configs, "summary": summary},
                                                            indent=1, default=float) + "\n", encoding="utf-8")
    figure(summary, out / "partial_view_study.png")


def run_study(base: Config, seed: int, trials: int, out: str | Path, *, jobs: int = 1, progress: bool = True,
              log: Callable[[str], None] | None = None, models: tuple[str, ...] = MODELS) -> dict:
    """Run (or resume) every model's Monte Carlo into ``out/<model>`` and write the side-by-side
    summary ``out/partial_view_study.md`` and ``.json`` (with each model's configuration)."""
    out = Path(out)
    summary, configs = {}, {}
    for model in models:
        cfg = model_config(base, model)
        if log:
            log(f"partial-view study: {model}, {trials} trials")
        run_montecarlo(cfg, seed, trials, out / model, jobs=jobs, progress=progress, log=log,
                       variants=study_variants(model))
        write_report(out / model)
        summary[model] = summarise(out / model)
        configs[model] = to_dict(cfg)
    write_summary(out, summary, seed, configs)
    return summary
