"""The seed paper's claim that the landmark extent reduces the dependence on empirical thresholds.

    python scripts/threshold_study.py --trials 200 --seed 777 --jobs 1 --out runs/threshold-study

For "No extent", "With extent" and the consistent variant (docs/method.md a.7.3), each threshold of
landmark management (docs/method.md c.1) is varied on its own to x0.5, x0.75, x1.5 and x2 of the
profile's value (integer thresholds rounded half up, at least 1; a factor that rounds back to the
profile's value is the profile's run): the association log distance ``beta``, the sifting radius
``sift_radius_m`` (gamma_s), the tentative gate ``tentative_gate_m`` (gamma_a), DBSCAN's
``cluster_eps_m`` (gamma_c) and ``cluster_min_samples`` (N_c2), the new-landmark log distance
``alpha``, and the confirmation counts ``confirm_points`` (N_c1, Rule 1) and ``confirm_hits`` (N of
the M/N Rule 2; above ``confirm_window`` Rule 2 can never confirm). All settings are variant
overlays of one Monte Carlo, so they share every trial's simulated data. Training seeds only: the
reporting seed 1 is refused.

Writes into the run directory ``threshold_study.md`` / ``.json`` (position and heading avg. RMSE per
setting and variant; per variant and threshold the spread, max - min over the threshold's five
values, absolute and relative to the profile's error) and ``threshold_study.png`` (one panel per
threshold, error against factor, one line per variant; position solid, heading dashed on the right
axis).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import _montecarlo_table
import numpy as np

from radarslam.config import profile_config
from radarslam.config.variants import DEFAULT_VARIANTS, Variant
from radarslam.metrics.pose import avg_rmse

#: The landmark-management thresholds studied (docs/method.md c.1) and their symbols.
THRESHOLDS = {"beta": "beta", "sift_radius_m": "gamma_s", "tentative_gate_m": "gamma_a", "cluster_eps_m": "gamma_c",
              "cluster_min_samples": "N_c2", "alpha": "alpha", "confirm_points": "N_c1", "confirm_hits": "N (M/N)"}
FACTORS = (0.5, 0.75, 1.0, 1.5, 2.0)
#: The variants compared: the paper's two and the consistent one (their overlays touch no threshold).
BASES = DEFAULT_VARIANTS


def scaled(value, factor: float):
    """``value * factor``; an integer threshold rounded half up and at least 1."""
    if isinstance(value, int):
        return max(1, int(math.floor(value * factor + 0.5)))
    return float(value) * factor


def _tag(factor: float) -> str:
    return "x" + f"{factor:g}".replace(".", "p")


def settings(profile: str = "apsipa") -> list[tuple[str, str, float, object, str]]:
    """Every run setting as ``(base variant, threshold, factor, value, variant name)``; the name of a
    setting whose value equals the profile's is its base variant's."""
    lc = profile_config(profile).landmarks
    out, seen = [], {}
    for b in BASES:
        for key in THRESHOLDS:
            base_value = getattr(lc, key)
            for f in FACTORS:
                v = scaled(base_value, f)
                name = b.name if v == base_value else f"{b.name}-{key.replace('_', '-')}-{_tag(f)}"
                name = seen.setdefault((b.name, key, v), name)   # two factors rounding alike: one run
                out.append((b.name, key, f, v, name))
    return out


def study_variants(profile: str = "apsipa") -> list[Variant]:
    """The base variants, then one overlay per setting that differs from the profile."""
    by_name = {b.name: b for b in BASES}
    vs = list(BASES)
    done = {b.name for b in BASES}
    for base, key, f, v, name in settings(profile):
        if name in done:
            continue
        done.add(name)
        b = by_name[base]
        overlay = {**b.overlay, "landmarks": {**b.overlay.get("landmarks", {}), key: v}}
        vs.append(Variant(name, f"{b.label}, {key} = {v:g} ({_tag(f)})", overlay))
    return vs


def table(res: dict) -> list[dict]:
    """One row per (variant, threshold, factor): value, position (m) and heading (deg) avg. RMSE."""
    profile = res["config"].profile
    rows = []
    for base, key, f, v, name in settings(profile):
        b = res[name]
        rows.append({"variant": base, "threshold": key, "factor": f, "value": v, "run": name,
                     "position_m": avg_rmse(b["position_error_m"]),
                     "heading_deg": avg_rmse(np.degrees(b["heading_error_rad"]))})
    return rows


def spreads(rows: list[dict]) -> list[dict]:
    """Per variant and threshold: max - min of each error over the factors, and relative to x1."""
    out = []
    for base in dict.fromkeys(r["variant"] for r in rows):
        for key in THRESHOLDS:
            sel = [r for r in rows if r["variant"] == base and r["threshold"] == key]
            one = next(r for r in sel if r["factor"] == 1.0)
            pos = [r["position_m"] for r in sel]
            head = [r["heading_deg"] for r in sel]
            out.append({"variant": base, "threshold": key, "position_spread_m": max(pos) - min(pos),
                        "position_rel": (max(pos) - min(pos)) / one["position_m"],
                        "heading_spread_deg": max(head) - min(head),
                        "heading_rel": (max(head) - min(head)) / one["heading_deg"]})
    return out


def markdown(rows: list[dict], res: dict) -> str:
    labels = {b.name: b.label for b in BASES}
    n, seed = res["trials"].size, res["seed"]
    out = [f"Threshold study, {n} trials, training seed {seed}: avg. RMSE position (m) / heading (deg)", "",
           "| threshold | factor | value | " + " | ".join(labels[b.name] for b in BASES) + " |",
           "|---|---|---|" + "---|" * len(BASES)]
    for key in THRESHOLDS:
        for f in FACTORS:
            cells = [r for r in rows if r["threshold"] == key and r["factor"] == f]
            out.append(f"| {key} ({THRESHOLDS[key]}) | {f:g} | {cells[0]['value']:g} | "
                       + " | ".join(f"{r['position_m']:.3f} / {r['heading_deg']:.2f}" for r in cells) + " |")
    sp = spreads(rows)
    out += ["", "Spread over x0.5..x2 (max - min): position m [relative to x1] / heading deg [relative]", "",
            "| threshold | " + " | ".join(labels[b.name] for b in BASES) + " |", "|---|" + "---|" * len(BASES)]
    for key in THRESHOLDS:
        cells = [s for s in sp if s["threshold"] == key]
        out.append(f"| {key} | " + " | ".join(
            f"{s['position_spread_m']:.3f} [{100 * s['position_rel']:.0f}%] / {s['heading_spread_deg']:.2f} "
            f"[{100 * s['heading_rel']:.0f}%]" for s in cells) + " |")
    tot = {b.name: [s for s in sp if s["variant"] == b.name] for b in BASES}
    out += ["", "Sum of the spreads over the thresholds: " + "; ".join(
        f"{labels[k]}: {sum(s['position_spread_m'] for s in v):.3f} m / {sum(s['heading_spread_deg'] for s in v):.2f} deg"
        for k, v in tot.items())]
    return "\n".join(out)


def figure(rows: list[dict], res: dict, out: Path) -> Path:
    """``threshold_study.png`` in ``out``: one panel per threshold, error against factor per variant."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = {b.name: b.label for b in BASES}
    fig, axes = plt.subplots(2, 4, figsize=(16, 7), sharex=True)
    for ax, key in zip(axes.flat, THRESHOLDS):
        ax2 = ax.twinx()
        for i, b in enumerate(BASES):
            sel = [r for r in rows if r["variant"] == b.name and r["threshold"] == key]
            fs = [r["factor"] for r in sel]
            ax.plot(fs, [r["position_m"] for r in sel], "-o", color=f"C{i}", label=f"{labels[b.name]} position")
            ax2.plot(fs, [r["heading_deg"] for r in sel], "--s", color=f"C{i}", alpha=0.6,
                     label=f"{labels[b.name]} heading")
        ax.set_title(f"{key} ({THRESHOLDS[key]})")
        ax.set_xticks(FACTORS)
        ax.set_ylabel("position avg. RMSE (m)")
        ax2.set_ylabel("heading avg. RMSE (deg)")
    for ax in axes[1]:
        ax.set_xlabel("factor of the profile's value")
    h1, l1 = axes.flat[0].get_legend_handles_labels()
    fig.legend(h1, l1, loc="lower center", ncol=len(BASES), fontsize=9)
    fig.suptitle(f"Threshold study: {res['trials'].size} trials, seed {res['seed']} (heading dashed, right axis)")
    fig.tight_layout(rect=(0, 0.05, 1, 0.96))
    path = out / "threshold_study.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: list[str] | None = None) -> int:
    return _montecarlo_table.main(__doc__, study_variants(), table, markdown, "threshold_study", trials=200, seed=777,
                                  out="runs/threshold-study", refuse_seed=1, argv=argv,
                                  after=lambda rows, res, out: figure(rows, res, out))


if __name__ == "__main__":
    sys.exit(main())
