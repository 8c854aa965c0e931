"""The map figure of one car-park run (seed Fig. 2 style)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np


def _ellipse_xy(center: np.ndarray, X: np.ndarray, n: int = 60) -> np.ndarray:
    """Contour ``{c + X^{1/2} u : |u| = 1}`` of the ellipse x^T X^-1 x = 1."""
    lam, U = np.linalg.eigh(0.5 * (X + X.T))
    t = np.linspace(0.0, 2.0 * math.pi, n)
    circ = np.stack([np.cos(t), np.sin(t)])
    return (center[:, None] + (U * np.sqrt(np.maximum(lam, 0.0))) @ circ).T


def draw_extents(ax, centers: np.ndarray, Xs: np.ndarray, *, color: str, label: str, lw: float = 1.0,
                 n: int = 60) -> None:
    """Draw the ellipse contour of every finite extent ``Xs[i]`` (N, 2, 2) centred at ``centers[i]``,
    labelling the first one only; landmarks without an extent (NaN) are skipped."""
    first = True
    for c, X in zip(centers, Xs):
        if np.all(np.isfinite(X)):
            e = _ellipse_xy(c, X, n)
            ax.plot(e[:, 0], e[:, 1], "-", color=color, lw=lw, label=label if first else None)
            first = False


def plot_carpark_run(path: str | Path, result, k: int | None = None, *, show_extents: bool = True,
                     title: str | None = None) -> None:
    """Save the map after scan ``k`` (default: the last) of a car-park :class:`TrialResult`.

    True rectangles (grey; dashed once departed), detections (black) and clutter (orange x) of
    scan ``k``, estimated landmarks (diamonds), RMA ellipses (red) and EFA ellipses (blue), the
    true (green) and estimated (magenta) paths, and the radar range disc.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Rectangle

    from radarslam.models.radar import polar_to_xy

    sc, rec = result.scenario, result.record
    K = rec.poses.shape[0]
    k = K if k is None else k
    truth = sc.truth
    fig, ax = plt.subplots(figsize=(9.5, 7.5))
    labelled = set()
    for v in truth.vehicles:
        gone = not v.present(k)
        label = "departed vehicle" if gone else "vehicles (true rectangles)"
        ax.add_patch(Rectangle((v.x_left, v.y_bottom), v.size_x, v.size_y, fill=not gone, alpha=0.35 if not gone else 1,
                               facecolor="0.6", edgecolor="0.3", linestyle="--" if gone else "-",
                               label=None if label in labelled else label))
        labelled.add(label)
    pose_t = truth.poses[k - 1]
    ax.add_patch(Circle(pose_t[:2], result.config.radar.max_range_m, color="tab:cyan", alpha=0.08,
                        label=f"radar range ({result.config.radar.max_range_m:g} m)"))
    scan = sc.scans[k - 1]
    xy = polar_to_xy(pose_t, scan.polar)
    src = truth.sources[k - 1]
    ax.plot(xy[src >= 0, 0], xy[src >= 0, 1], ".", color="k", ms=3, label="detections")
    ax.plot(xy[src < 0, 0], xy[src < 0, 1], "x", color="tab:orange", ms=4, label="clutter")
    ax.plot(truth.poses[:k, 0], truth.poses[:k, 1], "-", color="tab:green", lw=1.5, label="true path")
    ax.plot(rec.poses[:k, 0], rec.poses[:k, 1], "--", color="m", lw=1.5, label="estimated path")
    m = rec.maps[k - 1]
    ax.plot(m.positions[:, 0], m.positions[:, 1], "D", color="k", mfc="gold", ms=6, label="landmarks")
    if show_extents:
        draw_extents(ax, m.positions, m.rma, color="red", label="RMA", lw=1.3)
        draw_extents(ax, m.positions, m.efa, color="blue", label="EFA", lw=1.0)
    ax.set_aspect("equal")
    # the car park's frame, widened to whatever the trajectory and the landmarks reach
    pts = np.concatenate([truth.poses[:k, :2], rec.poses[:k, :2], m.positions.reshape(-1, 2)])
    ax.set_xlim(min(-20.0, pts[:, 0].min() - 3.0), max(40.0, pts[:, 0].max() + 3.0))
    ax.set_ylim(min(-15.0, pts[:, 1].min() - 3.0), max(40.0, pts[:, 1].max() + 3.0))
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title or f"car park, scan k = {k}")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)  # outside: never over the map
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")  # keep the outside legend
    plt.close(fig)
