"""The figure of a dataset run: estimated path and map over the GPS track."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def plot_dataset_run(path: str | Path, run, gps_eval: dict, *, title: str | None = None,
                     dead_reckoning: tuple[np.ndarray, dict] | None = None, diameters: dict | None = None) -> None:
    """Save the estimated sensor path and landmarks (RMA ellipses in red), rotated and translated
    into the GPS frame by the alignment of ``gps_eval``, over the GPS fixes (outliers grey).

    ``dead_reckoning = (poses (K, 3), its GPS evaluation)`` adds the odometry-only path (aligned by
    its own fit); ``diameters`` (:func:`~radarslam.experiments.dataset.compare_tree_diameters`) adds
    a second panel of RMA against reference trunk diameters.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from radarslam.viz.carpark import draw_extents

    R, t = gps_eval["R"], gps_eval["translation_m"]
    gps = run.data.gps
    if diameters is not None and diameters.get("n_matched", 0):
        fig, (ax, ax2) = plt.subplots(1, 2, figsize=(15, 7.5), gridspec_kw={"width_ratios": [2, 1]})
    else:
        fig, ax = plt.subplots(figsize=(9, 8))
        ax2 = None
    from radarslam.metrics.alignment import gps_speed_outliers

    m = (gps.t >= run.times[0]) & (gps.t <= run.times[-1])
    gxy = np.asarray(gps.xy)[m]
    jump = gps_speed_outliers(np.asarray(gps.t)[m], gxy, 8.0)
    ax.plot(gxy[~jump, 0], gxy[~jump, 1], ".", color="tab:green", ms=2, label="GPS fixes")
    if jump.any():
        ax.plot(gxy[jump, 0], gxy[jump, 1], "x", color="0.6", ms=3, label="GPS jumps (> 8 m/s, left out)")
    if dead_reckoning is not None:
        dp, dev = dead_reckoning
        q = dp[:, :2] @ dev["R"].T + dev["translation_m"]
        ax.plot(q[:, 0], q[:, 1], "-", color="tab:orange", lw=0.6, alpha=0.8,
                label=f"odometry only (RMSE {dev['rmse_m']:.1f} m)")
    p = run.poses[:, :2] @ R.T + t
    ax.plot(p[:, 0], p[:, 1], "-", color="m", lw=0.8, label="estimated laser path")
    mp = run.final_map
    L = mp.positions @ R.T + t
    ax.plot(L[:, 0], L[:, 1], "+", color="k", ms=3, label=f"landmarks ({len(L)})")
    draw_extents(ax, L, R @ mp.rma @ R.T, color="red", label="RMA extent", lw=0.6, n=24)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.set_title(title or f"{run.name}: GPS-aligned RMSE {gps_eval['rmse_m']:.2f} m")
    ax.legend(loc="best", fontsize=8)
    ax.grid(alpha=0.3)
    if ax2 is not None:
        ref, est = diameters["reference_m"], diameters["rma_m"]
        ax2.plot(ref, est, ".", ms=4, color="tab:red")
        hi = float(max(ref.max(), est.max())) * 1.05
        ax2.plot([0, hi], [0, hi], "k--", lw=0.8, label="equal")
        ax2.set_xlim(0, hi)
        ax2.set_ylim(0, hi)
        ax2.set_aspect("equal")
        ax2.set_xlabel("reference trunk diameter (m)")
        ax2.set_ylabel("RMA trunk diameter (m)")
        ax2.set_title(f"{diameters['n_matched']} matched trees: median |diff| "
                      f"{diameters['median_abs_diff_m']:.2f} m, Spearman {diameters['spearman']:.2f}", fontsize=9)
        ax2.legend(loc="upper left", fontsize=8)
        ax2.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
