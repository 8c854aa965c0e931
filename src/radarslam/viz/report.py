"""Figures of the Monte Carlo report: seed Fig. 3 (GWD curves), the NEES plot and seed Fig. 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: Line style per configuration: "With extent" solid, "No extent" dashed.
_STYLE = {"ext": "-", "noext": "--"}
_COLOR = {"rma": "red", "efa": "blue"}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_gwd_curves(path: str | Path, curves: dict, convention: str, *, reference: dict | None = None) -> None:
    """Save seed Fig. 3: RMSE of the average GWD against the scan k.

    Parameters
    ----------
    path : str or Path
    curves : dict
        From :func:`radarslam.experiments.report.gwd_curves`.
    convention : str
        The ground-truth convention, named in the title.
    reference : dict, optional
        ``{"rma": {k: value}, "efa": {k: value}}`` drawn as markers (values read off the paper).
    """
    plt = _pyplot()
    k = np.asarray(curves["k"])
    fig, ax = plt.subplots(figsize=(7.0, 4.2))
    for cname in ("ext", "noext"):
        c = curves["configs"][cname]
        for est in ("rma", "efa"):
            ax.plot(k, c[est]["rmse"], _STYLE[cname], color=_COLOR[est], lw=1.6 if cname == "ext" else 1.1,
                    label=f"{est.upper()}, {c['label']}")
    if reference:
        for est, pts in reference.items():
            ks = sorted(x for x in pts if x <= k[-1])
            ax.plot(ks, [pts[x] for x in ks], "o", mfc="none", color=_COLOR[est], ms=5,
                    label=f"{est.upper()}, paper Fig. 3")
    ax.set_xlabel("scan k")
    ax.set_ylabel("RMSE of the average GWD (m)")
    ax.set_title(f"RMSE of the average GWD, ground truth '{convention}'")
    ax.set_xlim(1, k[-1])
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_nees(path: str | Path, summary: dict) -> None:
    """Save the average pose NEES per scan of both configurations with the chi-square band shaded.

    Parameters
    ----------
    path : str or Path
    summary : dict
        From :func:`radarslam.experiments.report.nees_summary`.
    """
    plt = _pyplot()
    lo, hi = summary["band"]
    fig, ax = plt.subplots(figsize=(7.0, 4.2))
    K = None
    ymin, ymax = lo, hi
    for cname in ("ext", "noext"):
        c = summary["configs"][cname]
        a = np.asarray(c["avg_nees"], dtype=float)
        K = a.shape[0]
        ax.plot(np.arange(1, K + 1), a, _STYLE[cname], color="k" if cname == "ext" else "tab:purple", lw=1.3,
                label=f"{c['label']} ({100 * c['frac_inside']:.0f}% inside)")
        fin = a[np.isfinite(a) & (a > 0)]
        if fin.size:
            ymin, ymax = min(ymin, fin.min()), max(ymax, fin.max())
    ax.axhspan(lo, hi, color="tab:green", alpha=0.2,
               label=f"{100 * summary['prob']:.0f}% band, {summary['n_runs']} runs")
    ax.axhline(summary["dof"], color="tab:green", lw=0.8)
    if ymax / max(ymin, 1e-12) > 10:  # log scale only when the values span a decade
        ax.set_yscale("log")
    ax.set_xlabel("scan k")
    ax.set_ylabel("average pose NEES (3 dof)")
    ax.set_title("pose NEES averaged over trials")
    ax.set_xlim(1, K)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_fig2(path: str | Path, trial) -> None:
    """Save the final map of a re-run trial (seed Fig. 2): RMA red, EFA blue.

    Parameters
    ----------
    path : str or Path
    trial : TrialResult
        Trial 1 "With extent", re-run by :func:`radarslam.experiments.report.write_report`.
    """
    from radarslam.viz.carpark import plot_carpark_run

    K = trial.record.poses.shape[0]
    plot_carpark_run(path, trial, title=f"trial 1, k = {K}, With extent")
