"""The table of ``radarslam evaluate``: one row per scene read from the files ``radarslam run`` wrote
for it, ``evaluation.csv``, ``evaluation.md``, ``summary.json`` (mean, median and a bootstrap 95%
interval of the mean of each figure over the scenes) and ``ratios.png`` (docs/datasets.md "A whole
dataset: radarslam evaluate")."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radarslam.io.results import atomic_write_text, write_json

#: The columns: (name, where in the scene's metrics.json or run.json it comes from, format in evaluation.md).
COLUMNS = (
    ("scene", "the scene's name (its folder in scenes/)", "s"),
    ("status", "ok, or error: the one line the scene's run failed with", "s"),
    ("scans", "metrics.json scans", "d"),
    ("seconds", "run.json wall_seconds (reading and running the scene)", ".1f"),
    ("position_rmse_m", "metrics.json position_rmse_m", ".3f"),
    ("heading_rmse_deg", "metrics.json heading_rmse_deg", ".3f"),
    ("ratio_position", "metrics.json ratio_to_dead_reckoning.position_rmse", ".3f"),
    ("ratio_heading", "metrics.json ratio_to_dead_reckoning.heading_rmse", ".3f"),
    ("nees_time_average", "metrics.json pose_nees.time_average (3 for a consistent filter)", ".2f"),
    ("nees_share_inside", "metrics.json pose_nees.share_inside_band (0.95 for a consistent filter)", ".3f"),
    ("nees_along_track", "metrics.json pose_nees.components.along_track.time_average (1 for a consistent filter)",
     ".2f"),
    ("nees_cross_track", "metrics.json pose_nees.components.cross_track.time_average (1)", ".2f"),
    ("nees_heading", "metrics.json pose_nees.components.heading.time_average (1)", ".2f"),
    ("ego_speed_rmse_mps", "metrics.json ego_velocity.against_odometry.speed_mps.rmse", ".3f"),
    ("ego_yaw_rate_rmse_deg_s", "metrics.json ego_velocity.against_odometry.yaw_rate_deg_s.rmse", ".3f"),
    ("road_users_in_map", "metrics.json moving_scores.road_user_updated (labelled road users' detections that "
                          "updated a landmark)", "d"),
    ("road_users_in_map_share", "metrics.json moving_scores.road_user_updated_share", ".4f"),
)
NAMES = tuple(c[0] for c in COLUMNS)
#: The figures the summary takes over the scenes that ran (every numeric column).
FIGURES = NAMES[2:]
#: The bootstrap of the summary: resamples, seed (numpy SeedSequence), level (docs/method.md f.1).
BOOTSTRAP = {"resamples": 2000, "seed": 0, "level": 0.95}


def _get(d: dict | None, *keys):
    for k in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(k)
    return d


def row_from_outputs(name: str, metrics: dict, run: dict) -> dict:
    """The row of scene ``name`` from its ``metrics.json`` and ``run.json`` (the keys of
    :data:`COLUMNS`; None where the run has no such figure: no truth, no Doppler, no labels)."""
    ego = _get(metrics, "ego_velocity", "against_odometry")
    values = {"scans": metrics.get("scans"), "seconds": run.get("wall_seconds"),
              "position_rmse_m": metrics.get("position_rmse_m"), "heading_rmse_deg": metrics.get("heading_rmse_deg"),
              "ratio_position": _get(metrics, "ratio_to_dead_reckoning", "position_rmse"),
              "ratio_heading": _get(metrics, "ratio_to_dead_reckoning", "heading_rmse"),
              "nees_time_average": _get(metrics, "pose_nees", "time_average"),
              "nees_share_inside": _get(metrics, "pose_nees", "share_inside_band"),
              **{f"nees_{k}": _get(metrics, "pose_nees", "components", k, "time_average")
                 for k in ("along_track", "cross_track", "heading")},
              "ego_speed_rmse_mps": _get(ego, "speed_mps", "rmse"),
              "ego_yaw_rate_rmse_deg_s": _get(ego, "yaw_rate_deg_s", "rmse"),
              "road_users_in_map": _get(metrics, "moving_scores", "road_user_updated"),
              "road_users_in_map_share": _get(metrics, "moving_scores", "road_user_updated_share")}
    return {"scene": name, "status": "ok", **values}


def error_row(name: str, message: str, seconds: float | None = None) -> dict:
    """The row of a scene whose run failed: its status ``error: <one line>``, no figures."""
    line = " ".join(str(message).split()) or "failed"
    return {"scene": name, "status": f"error: {line[:400]}", **{k: None for k in FIGURES}, "seconds": seconds}


def _number(v) -> float:
    return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) else math.nan


def summary(rows: list[dict]) -> dict:
    """Over the scenes that ran (status ok), each figure's count, mean, median and the bootstrap
    percentile interval of its mean (:data:`BOOTSTRAP`; radarslam.metrics.statistics), None without
    a value."""
    from radarslam.metrics.statistics import bootstrap_counts, percentile_interval

    ok = [r for r in rows if r["status"] == "ok"]
    out = {}
    for key in FIGURES:
        x = np.array([_number(r.get(key)) for r in ok])
        x = x[np.isfinite(x)]
        if x.size == 0:
            out[key] = {"scenes": 0, "mean": None, "median": None, "ci95_mean": None}
            continue
        rng = np.random.default_rng(np.random.SeedSequence(BOOTSTRAP["seed"]))
        counts = bootstrap_counts(int(x.size), BOOTSTRAP["resamples"], rng)
        means = counts @ x / x.size
        out[key] = {"scenes": int(x.size), "mean": float(x.mean()), "median": float(np.median(x)),
                    "ci95_mean": percentile_interval(means, BOOTSTRAP["level"])}
    return {"scenes": len(rows), "ok": len(ok), "failed": len(rows) - len(ok),
            "failed_scenes": [r["scene"] for r in rows if r["status"] != "ok"],
            "bootstrap": {**BOOTSTRAP, "what": "resample the scenes with replacement; the percentile interval of "
                                               "the resamples' means (radarslam.metrics.statistics)"},
            "figures": out}


def _csv_cell(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v) if math.isfinite(v) else ""
    text = str(v)
    return '"' + text.replace('"', '""') + '"' if any(c in text for c in ',"\n') else text


def _md_cell(v, fmt: str) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return ""
    if fmt == "s":
        return str(v).replace("|", "\\|")
    return format(int(v) if fmt == "d" else float(v), fmt)


def table_md(rows: list[dict]) -> str:
    """The rows as a markdown table (empty cells where a scene has no such figure)."""
    lines = ["| " + " | ".join(NAMES) + " |", "|" + "---|" * len(NAMES)]
    for r in rows:
        lines.append("| " + " | ".join(_md_cell(r.get(n), f) for n, _, f in COLUMNS) + " |")
    return "\n".join(lines)


def summary_md(s: dict) -> str:
    """The summary as a markdown table."""
    lines = [f"{s['ok']} of {s['scenes']} scenes ran" + (f" ({', '.join(s['failed_scenes'])} failed)"
                                                         if s["failed"] else "") + "; bootstrap "
             f"{s['bootstrap']['resamples']} resamples of the scenes, seed {s['bootstrap']['seed']}.", "",
             "| figure | scenes | mean | median | 95% interval of the mean |", "|---|---|---|---|---|"]
    fmt = {n: f for n, _, f in COLUMNS}
    for key, v in s["figures"].items():
        f = ".1f" if fmt[key] == "d" else fmt[key]
        ci = v["ci95_mean"]
        lines.append(f"| {key} | {v['scenes']} | {_md_cell(v['mean'], f)} | {_md_cell(v['median'], f)} | "
                     + (f"[{_md_cell(ci[0], f)}, {_md_cell(ci[1], f)}]" if ci else "") + " |")
    return "\n".join(lines)


def write_table(out: Path, rows: list[dict], command: str) -> list[str]:
    """``evaluation.csv``, ``evaluation.md``, ``summary.json`` and (with matplotlib) ``ratios.png`` in
    ``out``; returns their names."""
    lines = [",".join(NAMES)] + [",".join(_csv_cell(r.get(n)) for n in NAMES) for r in rows]
    atomic_write_text(out / "evaluation.csv", "\n".join(lines) + "\n")
    s = summary(rows)
    write_json(out / "summary.json", s)
    columns = "\n".join(f"- `{n}`: {what}" for n, what, _ in COLUMNS)
    atomic_write_text(out / "evaluation.md", f"# radarslam evaluate\n\n`{command}`\n\n## Scenes\n\n{table_md(rows)}\n\n"
                                             f"## Summary over the scenes\n\n{summary_md(s)}\n\n"
                                             f"## Columns\n\n{columns}\n")
    names = ["evaluation.csv", "evaluation.md", "summary.json"]
    from radarslam.viz import have_matplotlib

    if have_matplotlib() and rows:
        from radarslam.viz.evaluation import plot_ratios

        plot_ratios(out / "ratios.png", [r["scene"] for r in rows], np.array([_number(r["ratio_position"]) for r in rows]),
                    np.array([_number(r["ratio_heading"]) for r in rows]),
                    notes=["no truth" if r["status"] == "ok" else "failed" for r in rows])
        names.append("ratios.png")
    return names
