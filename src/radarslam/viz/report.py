"""Figures of the Monte Carlo report: seed Fig. 3 (GWD curves), the NEES plot and seed Fig. 2.

Every variant of the report is drawn, each in its own line style (and, on the NEES plot, colour),
and named in the legend. The plotting functions return the legend entries they drew as
``(label, linestyle, colour)`` so that callers and tests can check what the figure shows.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: Line style of the i-th variant (the default two: "No extent" dashed, "With extent" solid).
LINESTYLES = ("--", "-", ":", "-.", (0, (5, 1, 1, 1, 1, 1)), (0, (1, 3)), (0, (8, 2)), (0, (3, 1, 1, 1)))
#: Shades of the estimator colour per variant on the GWD figure.
_GWD_COLORS = {"rma": ("red", "darkred", "salmon", "orangered", "firebrick", "lightcoral", "maroon", "tomato"),
               "efa": ("blue", "navy", "deepskyblue", "slateblue", "royalblue", "lightblue", "midnightblue", "teal")}
#: Colour of the i-th variant on the NEES figure.
_NEES_COLORS = ("tab:purple", "k", "tab:orange", "tab:brown", "tab:olive", "tab:cyan", "tab:pink", "tab:gray")


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _style(i: int):
    return LINESTYLES[i % len(LINESTYLES)]


def _entries(ax) -> list[tuple[str, object, str]]:
    """``(label, linestyle, colour)`` of every legend entry of ``ax``."""
    from matplotlib.colors import to_hex

    handles, labels = ax.get_legend_handles_labels()
    out = []
    for h, lab in zip(handles, labels):
        ls = h.get_linestyle() if hasattr(h, "get_linestyle") else None
        col = h.get_color() if hasattr(h, "get_color") else h.get_facecolor()
        out.append((lab, ls, to_hex(col)))
    return out


def plot_gwd_curves(path: str | Path, curves: dict, convention: str, *,
                    reference: dict | None = None) -> list[tuple[str, object, str]]:
    """Save seed Fig. 3: RMSE of the average GWD against the scan k, for every variant.

    Parameters
    ----------
    path : str or Path
    curves : dict
        From :func:`radarslam.montecarlo.report.gwd_curves`.
    convention : str
        The ground-truth convention, named in the title.
    reference : dict, optional
        ``{"rma": {k: value}, "efa": {k: value}}`` drawn as markers (values read off the paper).

    Returns
    -------
    list of (label, linestyle, colour)
        The legend entries: RMA and EFA of each variant (colour: red shades RMA, blue shades EFA;
        line style: one per variant), then the reference markers.
    """
    plt = _pyplot()
    k = np.asarray(curves["k"])
    fig, ax = plt.subplots(figsize=(10.0, 4.2))
    cfgs = list(curves["configs"].values())
    for i, c in enumerate(cfgs):
        for est in ("rma", "efa"):
            shades = _GWD_COLORS[est]
            ax.plot(k, c[est]["rmse"], linestyle=_style(i), color=shades[i % len(shades)],
                    lw=1.6 if i == len(cfgs) - 1 else 1.1, label=f"{est.upper()}, {c['label']}")
    if reference:
        for est, pts in reference.items():
            ks = sorted(x for x in pts if x <= k[-1])
            ax.plot(ks, [pts[x] for x in ks], "o", mfc="none", color=_GWD_COLORS[est][0], ms=5,
                    label=f"{est.upper()}, paper Fig. 3")
    return _finish(fig, ax, path, "RMSE of the average GWD (m)", f"RMSE of the average GWD, ground truth '{convention}'", k[-1], 8)


def _finish(fig, ax, path, ylabel: str, title: str, k_max: int, fontsize: int) -> list[tuple[str, object, str]]:
    """Label a per-scan plot, put its legend outside the axes (never over the curves), save it and
    return the legend entries."""
    plt = _pyplot()
    ax.set_xlabel("scan k")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.set_xlim(1, k_max)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=fontsize, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    entries = _entries(ax)
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")  # keep the outside legend
    plt.close(fig)
    return entries


def plot_nees(path: str | Path, summary: dict) -> list[tuple[str, object, str]]:
    """Save the average pose NEES per scan of every variant with the chi-square band shaded.

    Parameters
    ----------
    path : str or Path
    summary : dict
        From :func:`radarslam.montecarlo.report.nees_summary`.

    Returns
    -------
    list of (label, linestyle, colour)
        The legend entries: one line per variant, then the band.
    """
    plt = _pyplot()
    lo, hi = summary["band"]
    fig, ax = plt.subplots(figsize=(10.0, 4.2))
    K = None
    ymin, ymax = lo, hi
    for i, c in enumerate(summary["configs"].values()):
        a = np.asarray(c["avg_nees"], dtype=float)
        K = a.shape[0]
        ax.plot(np.arange(1, K + 1), a, linestyle=_style(i), color=_NEES_COLORS[i % len(_NEES_COLORS)], lw=1.3,
                label=f"{c['label']} ({100 * c['frac_inside']:.0f}% inside)")
        fin = a[np.isfinite(a) & (a > 0)]
        if fin.size:
            ymin, ymax = min(ymin, fin.min()), max(ymax, fin.max())
    ax.axhspan(lo, hi, color="tab:green", alpha=0.2,
               label=f"{100 * summary['prob']:.0f}% band, {summary['n_runs']} runs")
    ax.axhline(summary["dof"], color="tab:green", lw=0.8)
    if ymax / max(ymin, 1e-12) > 10:  # log scale only when the values span a decade
        ax.set_yscale("log")
    return _finish(fig, ax, path, "average pose NEES (3 dof)", "pose NEES averaged over trials", K, 8)


def plot_fig2(path: str | Path, trial, label: str = "With extent") -> None:
    """Save the final map of a re-run trial (seed Fig. 2): RMA red, EFA blue.

    Parameters
    ----------
    path : str or Path
    trial : TrialResult
        Trial 1 in one variant, re-run by :func:`radarslam.montecarlo.report.write_report`.
    label : str
        The variant's label, named in the title.
    """
    from radarslam.viz.carpark import plot_carpark_run

    K = trial.record.poses.shape[0]
    plot_carpark_run(path, trial, title=f"trial 1, k = {K}, {label}")


def plot_nis(path: str | Path, summary: dict) -> list[tuple[str, object, str]]:
    """Save the mean NIS per scan of every variant with its chi-square band (one band per variant:
    it depends on the number of updates).

    Parameters
    ----------
    summary : dict
        From :func:`radarslam.montecarlo.report.tables.nis_summary`.
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(10.0, 4.2))
    K = 1
    for i, c in enumerate(summary["configs"].values()):
        a = np.asarray(c["mean_nis"], dtype=float)
        K = a.shape[0]
        k = np.arange(1, K + 1)
        col = _NEES_COLORS[i % len(_NEES_COLORS)]
        ax.plot(k, a, linestyle=_style(i), color=col, lw=1.3,
                label=f"{c['label']} ({100 * c['frac_inside']:.0f}% inside, mean {c['overall']:.2f})")
        ax.fill_between(k, c["band_low"], c["band_high"], color=col, alpha=0.12,
                        label=f"{100 * summary['prob']:.0f}% band, {c['label']}")
    ax.axhline(summary["dof"], color="k", lw=0.8, label="consistent mean (2)")
    return _finish(fig, ax, path, "mean NIS of the updates (2 dof)", "normalised innovation squared, pooled over trials", K, 7)
