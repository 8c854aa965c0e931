"""The figure of a dataset run: estimated path and map over the GPS track."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def plot_dataset_run(path: str | Path, run, gps_eval: dict, *, title: str | None = None) -> None:
    """Save the estimated sensor path and landmarks (RMA ellipses in red), rotated and translated
    into the GPS frame by the alignment of ``gps_eval``, over the GPS fixes (outliers grey)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from radarslam.viz.carpark import draw_extents

    R, t = gps_eval["R"], gps_eval["translation_m"]
    gps = run.data.gps
    fig, ax = plt.subplots(figsize=(9, 8))
    from radarslam.metrics.alignment import gps_speed_outliers

    m = (gps.t >= run.times[0]) & (gps.t <= run.times[-1])
    gxy = np.asarray(gps.xy)[m]
    jump = gps_speed_outliers(np.asarray(gps.t)[m], gxy, 8.0)
    ax.plot(gxy[~jump, 0], gxy[~jump, 1], ".", color="tab:green", ms=2, label="GPS fixes")
    if jump.any():
        ax.plot(gxy[jump, 0], gxy[jump, 1], "x", color="0.6", ms=3, label="GPS jumps (> 8 m/s, left out)")
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
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
