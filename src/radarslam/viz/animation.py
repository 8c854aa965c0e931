"""A run drawn scan by scan (``radarslam run --recording ... --animate FILE.gif``).

Each frame shows the estimated path so far, the vehicle and its 2-sigma position ellipse, the
scan's detections (in the world by the estimated pose) coloured by the landmark they were
associated with (grey: none), every landmark's centroid with its 2-sigma covariance ellipse and
its extent, and the truth when known. Frames are plain dicts (see :func:`animate_run`).
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError
from radarslam.viz.carpark import _ellipse_xy

#: Chi-square 95% quantile with 2 degrees of freedom: the "2-sigma" ellipse of a 2-D Gaussian.
CHI2_2DOF_95 = 5.991464547107979


def _bounds(frames: list[dict]) -> tuple[float, float, float, float]:
    pts = [f["pose"][None, :2] for f in frames] + [f["detections"] for f in frames] + [frames[-1]["positions"]]
    pts += [f["truth"][None, :2] for f in frames if f.get("truth") is not None and np.all(np.isfinite(f["truth"]))]
    xy = np.concatenate([p.reshape(-1, 2) for p in pts])
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    pad = 0.05 * max(hi - lo) + 1.0
    return lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad


def _draw(ax, frames: list[dict], k: int, limits) -> None:
    f = frames[k]
    ax.clear()
    ax.set_xlim(limits[0], limits[1]), ax.set_ylim(limits[2], limits[3])
    ax.set_aspect("equal"), ax.set_xlabel("x (m)"), ax.set_ylabel("y (m)")
    path = np.array([g["pose"][:2] for g in frames[: k + 1]])
    ax.plot(path[:, 0], path[:, 1], "-", color="tab:blue", lw=1.2, label="estimate")
    tr = [g["truth"][:2] for g in frames[: k + 1] if g.get("truth") is not None and np.all(np.isfinite(g["truth"]))]
    if tr:
        tr = np.array(tr)
        ax.plot(tr[:, 0], tr[:, 1], "--", color="k", lw=1.0, label="truth")
        ax.plot(tr[-1, 0], tr[-1, 1], "o", color="k", ms=4)
    det, lab = f["detections"], f["labels"]
    if det.size:
        un = lab < 0
        ax.scatter(det[un, 0], det[un, 1], s=6, c="0.6", label="detections (not associated)")
        if (~un).any():
            ax.scatter(det[~un, 0], det[~un, 1], s=9, c=lab[~un] % 20, cmap="tab20", vmin=0, vmax=19,
                       label="detections (by landmark)")
    for i, (c, P, X) in enumerate(zip(f["positions"], f["covs"], f["extents"])):
        e = _ellipse_xy(c, CHI2_2DOF_95 * P)
        ax.plot(e[:, 0], e[:, 1], "-", color="tab:red", lw=0.8, label="centroid 2-sigma" if i == 0 else None)
        if np.all(np.isfinite(X)):
            e = _ellipse_xy(c, X)
            ax.plot(e[:, 0], e[:, 1], "-", color="tab:green", lw=1.0, label="extent" if i == 0 else None)
    if len(f["positions"]):
        ax.plot(f["positions"][:, 0], f["positions"][:, 1], "+", color="tab:red", ms=6, label="landmarks")
    x, y, th = f["pose"]
    L = 0.04 * (limits[1] - limits[0])
    tri = np.array([[L, 0.0], [-0.5 * L, 0.4 * L], [-0.5 * L, -0.4 * L], [L, 0.0]])
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    body = tri @ R.T + [x, y]
    ax.plot(body[:, 0], body[:, 1], "-", color="tab:blue", lw=1.5)
    e = _ellipse_xy(np.array([x, y]), CHI2_2DOF_95 * f["pose_cov"][:2, :2])
    ax.plot(e[:, 0], e[:, 1], "-", color="tab:blue", lw=0.8, label="vehicle 2-sigma")
    ax.set_title(f"scan {k + 1} of {len(frames)}   t = {f['t']:.2f} s   {len(f['positions'])} landmarks")
    ax.legend(loc="upper right", fontsize=6)


def animate_run(path: str | Path, frames: list[dict], *, fps: int = 10, on_frame=None) -> Path:
    """Write the animation of ``frames`` to ``path`` (``.gif`` with Pillow, ``.mp4`` with ffmpeg).

    Parameters
    ----------
    path : path
        ``FILE.gif`` or ``FILE.mp4``.
    frames : list of dict
        Per scan: ``t`` (s), ``pose`` (3,), ``pose_cov`` (3, 3), ``detections`` (m, 2) world xy,
        ``labels`` (m,) landmark id or -1, ``positions`` (N, 2), ``covs`` (N, 2, 2), ``extents``
        (N, 2, 2) (NaN: none), ``truth`` (3,) or None.
    fps : int
    on_frame : callable, optional
        Called after each frame is drawn (a progress bar).
    """
    path = Path(path)
    if not frames:
        raise InputError("animation: expected at least one scan, got none")
    try:
        from radarslam.viz.report import _pyplot

        plt = _pyplot()
        from matplotlib import animation
    except ImportError:
        raise InputError("--animate: drawing needs matplotlib (pip install \"radarslam[viz]\")") from None
    if path.suffix == ".mp4":
        if shutil.which("ffmpeg") is None:
            raise InputError(f"--animate {path}: .mp4 needs ffmpeg on the PATH; write a .gif instead")
        writer = animation.FFMpegWriter(fps=fps)
    elif path.suffix == ".gif":
        writer = animation.PillowWriter(fps=fps)
    else:
        raise InputError(f"--animate: expected a .gif or .mp4 file, got {path}")
    fig, ax = plt.subplots(figsize=(7, 7), dpi=80)
    limits = _bounds(frames)
    try:
        with writer.saving(fig, str(path), dpi=80):
            for k in range(len(frames)):
                _draw(ax, frames, k, limits)
                writer.grab_frame()
                if on_frame is not None:
                    on_frame()
    finally:
        plt.close(fig)
    return path
