"""Markdown and CSV text of the report's tables (one column, or column group, per variant).

Every function takes the dicts of :mod:`.tables` (or the whole report dict of
:func:`~.write.write_report`) and returns text; nothing here computes a statistic or touches a file.
CSV numbers are written with ``repr`` so they read back exactly.
"""

from __future__ import annotations

import csv
import io
import json
import math

import numpy as np

from radarslam.montecarlo.report.paper import PAPER_FIG3, PAPER_TABLE1, PAPER_TABLE2
from radarslam.montecarlo.report.tables import ESTIMATORS, GWD_KEY_STEPS, GWD_SETTLED_FROM, REPORT_CONVENTIONS
from radarslam.io.results import to_jsonable


def _fmt(x, nd: int = 3) -> str:
    if x is None:
        return "n/a"
    x = float(x)
    return f"{x:.{nd}f}" if math.isfinite(x) else "n/a"


def _ci(ci, nd: int = 3) -> str:
    return f"[{_fmt(ci[0], nd)}, {_fmt(ci[1], nd)}]"


def _csv_text(header: list[str], rows: list[list]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for r in rows:
        w.writerow([repr(float(v)) if isinstance(v, (float, np.floating)) else v for v in r])
    return buf.getvalue()


def _md_table(header: list[str], rows: list[list[str]]) -> str:
    def cell(c) -> str:
        return str(c).replace("|", "\\|")

    lines = ["| " + " | ".join(cell(c) for c in header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(cell(c) for c in r) + " |" for r in rows]
    return "\n".join(lines)


def trial_ranges(numbers: list[int]) -> str:
    """``[1, 2, 3, 5, 7, 8]`` -> ``"1-3, 5, 7-8"``."""
    parts, start = [], None
    for i, n in enumerate(numbers):
        if start is None:
            start = n
        if i + 1 == len(numbers) or numbers[i + 1] != n + 1:
            parts.append(str(n) if n == start else f"{start}-{n}")
            start = None
    return ", ".join(parts)


# --------------------------------------------------------------------------------------------- Table 1

_T1_ROWS = (("position_avg_rmse_m", "position avg. RMSE (m)"), ("heading_avg_rmse_deg", "heading avg. RMSE (deg)"))


def table1_markdown(t1: dict) -> str:
    """Table 1 as a GitHub Markdown table: per variant the estimate and its interval, per non-baseline
    variant the paired change against the baseline and its interval, and the paper's values."""
    pct = int(round(100 * t1["level"]))
    names, labels, base = t1["variants"], t1["labels"], t1["baseline"]
    header = ["metric"]
    for n in names:
        header += [labels[n], f"{labels[n]} {pct}% CI"]
    for n in names[1:]:
        header += [f"change {labels[n]} vs {labels[base]} (%)", f"change {labels[n]} {pct}% CI (paired)"]
    header.append("paper No / With extent")
    rows = []
    for key, title in _T1_ROWS:
        r = t1[key]
        p = PAPER_TABLE1[key]
        row = [title]
        for n in names:
            row += [_fmt(r[n]["estimate"]), _ci(r[n]["ci"])]
        for n in names[1:]:
            row += [_fmt(r["change_pct"][n]["estimate"], 1), _ci(r["change_pct"][n]["ci"], 1)]
        row.append(f"{p['noext']:.2f} / {p['ext']:.2f}")
        rows.append(row)
    return _md_table(header, rows)


def table1_csv(t1: dict) -> str:
    """Table 1 as CSV: ``metric``, per variant ``NAME, NAME_ci_low, NAME_ci_high``, per non-baseline
    variant ``change_pct_NAME, change_pct_NAME_ci_low, change_pct_NAME_ci_high``, the paper's values."""
    names = t1["variants"]
    header = ["metric"]
    for n in names:
        header += [n, f"{n}_ci_low", f"{n}_ci_high"]
    for n in names[1:]:
        header += [f"change_pct_{n}", f"change_pct_{n}_ci_low", f"change_pct_{n}_ci_high"]
    header += ["paper_noext", "paper_ext"]
    rows = []
    for key, _ in _T1_ROWS:
        r = t1[key]
        row: list = [key]
        for n in names:
            row += [r[n]["estimate"], *r[n]["ci"]]
        for n in names[1:]:
            row += [r["change_pct"][n]["estimate"], *r["change_pct"][n]["ci"]]
        row += [float(PAPER_TABLE1[key]["noext"]), float(PAPER_TABLE1[key]["ext"])]
        rows.append(row)
    return _csv_text(header, rows)


# --------------------------------------------------------------------------------------------- Table II

_T2_ROWS = (("position_avg_rmse_m", "platform position avg. RMSE (m)"),
            ("heading_avg_rmse_deg", "platform heading avg. RMSE (deg)"),
            ("landmark_mae_m", "landmark estimation MAE (m)"),
            ("mean_inclusion_delay", "landmark inclusion mean delay (scans)"),
            ("mean_removal_delay", "landmark removal mean delay (scans)"),
            ("false", "mean (max) false landmarks"),
            ("missed", "mean (max) missed landmarks"),
            ("mean_landmarks_final", "mean number of landmarks at the last scan"))

#: Rows of ``table2_landmarks.csv``.
T2_CSV_KEYS = ("position_avg_rmse_m", "heading_avg_rmse_deg", "landmark_mae_m", "n_trials_landmark_mae_m",
               "mean_inclusion_delay", "n_trials_mean_inclusion_delay", "mean_removal_delay",
               "n_trials_mean_removal_delay", "mean_false", "max_false", "mean_missed", "max_missed",
               "mean_landmarks_final", "n_trials")


def _t2_cell(row: dict, key: str) -> str:
    if key in ("false", "missed"):
        return f"{row[f'mean_{key}']:.3f} ({row[f'max_{key}']})"
    if key in ("landmark_mae_m", "mean_inclusion_delay", "mean_removal_delay"):
        n = row[f"n_trials_{key}"]
        s = _fmt(row[key], 2 if key != "landmark_mae_m" else 3)
        return s if n == row["n_trials"] else f"{s} ({n} of {row['n_trials']} trials)"
    return _fmt(row[key], 3 if key != "mean_landmarks_final" else 2)


def _paper(v) -> str:
    return str(v) if isinstance(v, int) else f"{v:.2f}"


def table2_markdown(t2: dict) -> str:
    """APSIPA Table II as a GitHub Markdown table, one column per variant, with APSIPA's values."""
    cfgs = t2["configs"]
    header = ["metric"] + [c["label"] for c in cfgs.values()] + ["APSIPA low / high clutter"]
    rows = []
    for key, title in _T2_ROWS:
        if key in ("false", "missed"):
            ref = PAPER_TABLE2[f"mean_{key}"], PAPER_TABLE2[f"max_{key}"]
            paper = f"{_paper(ref[0][0])} ({ref[1][0]}) / {_paper(ref[0][1])} ({ref[1][1]})"
        elif key in PAPER_TABLE2:
            paper = f"{_paper(PAPER_TABLE2[key][0])} / {_paper(PAPER_TABLE2[key][1])}"
        else:
            paper = "-"
        rows.append([title] + [_t2_cell(c, key) for c in cfgs.values()] + [paper])
    return _md_table(header, rows)


def table2_csv(t2: dict) -> str:
    """APSIPA Table II as CSV: one row per quantity (:data:`T2_CSV_KEYS`), one column per variant name."""
    cfgs = t2["configs"]
    rows = [[k] + [float(c[k]) for c in cfgs.values()] for k in T2_CSV_KEYS]
    return _csv_text(["metric"] + list(cfgs), rows)


# --------------------------------------------------------------------------------------------- Fig. 3


def gwd_csv(curves: dict) -> str:
    """One convention's Fig. 3 curves: ``k`` and per variant and estimator ``NAME_EST_rmse_m``, ``NAME_EST_n_runs``."""
    header, cols = ["k"], [np.asarray(curves["k"])]
    for name, c in curves["configs"].items():
        for est in ESTIMATORS:
            header += [f"{name}_{est}_rmse_m", f"{name}_{est}_n_runs"]
            cols += [np.asarray(c[est]["rmse"]), np.asarray(c[est]["n_runs"])]
    rows = [[int(col[i]) if col.dtype.kind in "iu" else float(col[i]) for col in cols] for i in range(len(cols[0]))]
    return _csv_text(header, rows)


def gwd_markdown(curves: dict) -> str:
    """Key values of one convention's Fig. 3 curves, and their summaries, as Markdown."""
    conv = curves["convention"]
    paper = conv == "full"  # the convention that reproduces the seed's magnitude (h.9)
    cfgs = curves["configs"]
    header = (["k"] + [f"{c['label']} {e.upper()}" for c in cfgs.values() for e in ESTIMATORS]
              + [f"runs ({c['label']})" for c in cfgs.values()])
    if paper:
        header += ["paper RMA (With extent)", "paper EFA (With extent)"]
    rows = []
    for k in GWD_KEY_STEPS:
        if k > len(curves["k"]):
            break
        r = [str(k)] + [_fmt(c[e]["at"][k]) for c in cfgs.values() for e in ESTIMATORS]
        r += [str(int(c["rma"]["n_runs"][k - 1])) for c in cfgs.values()]
        if paper:
            r += [_fmt(PAPER_FIG3["rma"].get(k), 3), _fmt(PAPER_FIG3["efa"].get(k), 3)]
        rows.append(r)
    summ_header = ["curve", "first k", f"mean k>={GWD_SETTLED_FROM}", f"std k>={GWD_SETTLED_FROM}",
                   f"max-min k>={GWD_SETTLED_FROM}", f"RMA < EFA at k>={GWD_SETTLED_FROM}"]
    summ = []
    for c in cfgs.values():
        for e in ESTIMATORS:
            s = c[e]
            summ.append([f"{c['label']} {e.upper()}", str(s["first_k"]) if s["first_k"] else "n/a",
                         _fmt(s["mean_k10"]), _fmt(s["std_k10"]), _fmt(s["range_k10"]),
                         (_fmt(100 * c["frac_rma_below_efa_k10"], 0) + "% of scans") if e == "rma" else ""])
    return _md_table(header, rows) + "\n\n" + _md_table(summ_header, summ)


# --------------------------------------------------------------------------------------------- NEES


def nees_csv(ns: dict) -> str:
    """Average NEES per scan: ``k``, ``NAME_avg_nees`` per variant, ``band_low``, ``band_high``."""
    names = list(ns["configs"])
    avg = [np.asarray(ns["configs"][n]["avg_nees"]) for n in names]
    K = len(avg[0])
    lo, hi = ns["band"]
    rows = [[k + 1] + [float(a[k]) for a in avg] + [lo, hi] for k in range(K)]
    return _csv_text(["k"] + [f"{n}_avg_nees" for n in names] + ["band_low", "band_high"], rows)


def nees_markdown(ns: dict) -> str:
    """The NEES table, with each variant's initial error (docs/method.md b.5: fixed offset or drawn from P_1)."""
    return _md_table(["variant", "scans inside band", "below", "above", "time-averaged NEES", "initial error"],
                     [[c["label"], f"{100 * c['frac_inside']:.1f}%", f"{100 * c['frac_below']:.1f}%",
                       f"{100 * c['frac_above']:.1f}%", _fmt(c["time_avg"], 2), c.get("initial_error", "fixed")]
                      for c in ns["configs"].values()])


def nis_csv(ns: dict) -> str:
    """Mean NIS per scan: ``k``, then ``NAME_mean_nis``, ``NAME_count``, ``NAME_band_low``,
    ``NAME_band_high`` per variant."""
    names = list(ns["configs"])
    cols = ["k"] + [f"{n}_{c}" for n in names for c in ("mean_nis", "count", "band_low", "band_high")]
    K = len(next(iter(ns["configs"].values()))["mean_nis"]) if names else 0
    rows = [[k + 1] + [float(ns["configs"][n][c][k]) for n in names
                       for c in ("mean_nis", "count", "band_low", "band_high")] for k in range(K)]
    return _csv_text(cols, rows)


def nis_markdown(ns: dict) -> str:
    return _md_table(["variant", "scans inside band", "mean NIS of all updates (consistent: 2)", "updates"],
                     [[c["label"], f"{100 * c['frac_inside']:.1f}%", _fmt(c["overall"], 3),
                       f"{int(np.sum(c['count']))}"] for c in ns["configs"].values()])


# --------------------------------------------------------------------------------------------- report.md


def variants_markdown(variants: list[dict]) -> str:
    """The variants of the run: name, label and overlay (compact JSON; null stands for a non-finite number)."""
    rows = [[f"`{v['name']}`", v["label"],
             "`" + json.dumps(to_jsonable(v["overlay"]), sort_keys=True, separators=(", ", ": ")) + "`"]
            for v in variants]
    return _md_table(["name", "label", "overlay over the run's configuration"], rows)


def claims_markdown(cl: list[dict], labels: dict) -> str:
    verdict = {True: "**reproduced**", False: "**not reproduced**", None: "undefined"}
    return _md_table(["claim of the paper", "variant", "this run", "numbers"],
                     [[c["claim"], labels.get(c["variant"], c["variant"]), verdict[c["holds"]], c["evidence"]]
                      for c in cl])


def report_markdown(rep: dict) -> str:
    """The readable summary (report.md) of a :func:`~.write.write_report` dict."""
    meta = rep["meta"]
    t1 = rep["table1"]
    ns = rep["nees"]
    L = [f"# Monte Carlo report: {meta['dir']}", "",
         f"- trials: {meta['n_trials']} (numbers {meta['trial_range']}), seed {meta['seed']}, "
         f"profile `{meta['profile']}`, K = {meta['n_steps']} scans",
         f"- compute time stored with the trials: {meta['trial_seconds']:.1f} s"]
    if meta["corrupt"]:
        L.append(f"- corrupt trial files skipped: {len(meta['corrupt'])}")
        L += [f"  - trial {t}: {why}" for t, why in sorted(meta["corrupt"].items())]
    else:
        L.append("- corrupt trial files skipped: none")
    base_label = t1["labels"][t1["baseline"]]
    if rep.get("claims"):
        n_yes = sum(c["holds"] is True for c in rep["claims"])
        L += ["", "## What this run reproduces", "",
              f"{n_yes} of the {len(rep['claims'])} checks of the seed paper's claims hold in this run "
              "(Table 1: paired 95% CI of the change below zero, and the With-extent value at most the "
              "paper's; Fig. 3: RMA below EFA at every scan k >= 10, and flatter).", "",
              claims_markdown(rep["claims"], t1["labels"])]
    L += ["", "## Variants", "",
          f"Every variant ran on the same simulated data of every trial; the first, {base_label}, is the "
          "baseline of the relative changes.", "", variants_markdown(meta["variants"])]
    pct = int(round(100 * t1["level"]))
    L += ["", "## Table 1: platform pose error (seed Table 1)", "",
          f"avg. RMSE = mean over k of sqrt(mean over trials of e^2). {pct}% percentile bootstrap intervals over "
          f"trials ({t1['n_boot']} resamples, seed {t1['rng_seed']}); each change against {base_label} uses the "
          "paired bootstrap (the same trials for every variant). Paper: 1000 runs.", "",
          table1_markdown(t1)]
    for conv in REPORT_CONVENTIONS:
        note = {"moment": "ground truth (L/sqrt 3, W/sqrt 3), what a perfect estimator converges to",
                "full": "ground truth (L, W), the convention that reproduces the seed's magnitude (h.9); "
                        "paper values read off seed Fig. 3 (+-0.01)"}.get(conv, "")
        L += ["", f"## Fig. 3: RMSE of the average GWD (m), convention `{conv}`", "", note, "",
              gwd_markdown(rep["gwd"][conv])]
    L += ["", "## Table II: landmark management (APSIPA Table II)", "",
          "Delays and MAE are means over the trials that define them; removal delay is defined only when the "
          "departed car had a landmark and the platform came back in range before the end.", "",
          table2_markdown(rep["landmarks"])]
    lo, hi = ns["band"]
    L += ["", "## Pose NEES (3 dof)", "",
          f"Two-sided {int(round(100 * ns['prob']))}% band of the average over {ns['n_runs']} trials: "
          f"[{lo:.3f}, {hi:.3f}] (consistent filter: average 3). Initial error (docs/method.md b.5): "
          "`fixed` = `filter.initial_pose` in every trial (the paper's offset), `draw` = a draw from the "
          "filter's initial covariance per trial.", "", nees_markdown(ns)]
    nis = rep.get("nis")
    if nis and nis["configs"]:
        L += ["", "## NIS of the EKF updates (2 dof)", "",
              f"Mean normalised innovation squared per scan, pooled over trials, against the two-sided "
              f"{int(round(100 * nis['prob']))}% band of a mean of that many chi-square(2) values.", "",
              nis_markdown(nis)]
    fig2 = rep.get("fig2")
    if fig2 is not None:
        L += ["", "## Fig. 2", "", f"Trial 1 re-run ('{fig2['label']}'): estimated poses "
              + ("equal the stored ones bit for bit." if fig2["matches_stored"]
                 else "DIFFER from the stored ones (the code or environment changed since the run).")]
    L += ["", "Files: " + ", ".join(rep["files"]), ""]
    return "\n".join(L)
