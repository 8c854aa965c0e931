"""The figures of a recording run: ``map.png``, the landmarks with their extents
coloured by the radar that made them over the truth (or dead reckoning's path),
``ego_velocity.png``, the speed and yaw rate from every radar's Doppler against the odometry's, and
``nees.png``, the pose NEES against the truth (docs/recordings.md "What metrics.json holds").

Everything drawn is given as arrays; nothing here estimates or evaluates anything.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError


def plot_recording_map(path: str | Path, poses: np.ndarray, landmarks: np.ndarray, extents: np.ndarray,
                       landmark_sensor: np.ndarray, sensor_names: dict, reference: np.ndarray | None, *,
                       reference_label: str = "truth", title: str = "recording") -> None:
    """Save the final map: each landmark's centroid and extent ellipse in the colour of the radar that
    created it (legend: the radars' names), the estimated path and ``reference`` (the truth or dead
    reckoning's path) beneath.

    Parameters
    ----------
    poses : ndarray (K, 3)
        The estimated poses.
    landmarks : ndarray (N, 2)
        Final centroids.
    extents : ndarray (N, 2, 2)
        Their extent matrices (NaN where none).
    landmark_sensor : ndarray of int (N,)
        The ``sensor_id`` of the scan that created each landmark (-1: unknown).
    sensor_names : dict of int to str
        The legend's name of each ``sensor_id``.
    reference : ndarray (R, 2) or None
        The path drawn beneath (NaN rows are gaps).
    """
    poses = np.asarray(poses, dtype=float).reshape(-1, 3)
    landmarks = np.asarray(landmarks, dtype=float).reshape(-1, 2)
    extents = np.asarray(extents, dtype=float).reshape(-1, 2, 2)
    landmark_sensor = np.asarray(landmark_sensor, dtype=np.int64).reshape(-1)
    if extents.shape[0] != landmarks.shape[0] or landmark_sensor.shape[0] != landmarks.shape[0]:
        raise InputError(f"extents, landmark_sensor: expected {landmarks.shape[0]} of each (one per landmark), got "
                         f"{extents.shape[0]} and {landmark_sensor.shape[0]}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 8))
    if reference is not None and len(reference):
        ref = np.asarray(reference, dtype=float).reshape(-1, 2)
        ax.plot(ref[:, 0], ref[:, 1], "-", color="tab:green", lw=2.5, alpha=0.5, label=reference_label)
    ax.plot(poses[:, 0], poses[:, 1], "-", color="m", lw=1.0, label="estimated path")
    colours = plt.get_cmap("tab10")
    ids = sorted(set(sensor_names) | set(np.unique(landmark_sensor).tolist()))
    for j, sid in enumerate(ids):
        mine = landmark_sensor == sid
        if not mine.any():
            continue
        name = sensor_names.get(sid, "unknown sensor" if sid < 0 else f"sensor {sid}")
        c = colours(j % 10)
        ax.plot(landmarks[mine, 0], landmarks[mine, 1], ".", color=c, ms=4,
                label=f"{name}: {int(mine.sum())} landmarks")
        xy = _extent_contours(landmarks[mine], extents[mine], 24)
        if xy.size:                    # every contour of this radar in one line (NaN rows between them)
            ax.plot(xy[:, 0], xy[:, 1], "-", color=c, lw=0.7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=3, fontsize=8)  # below: never over the map
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130, bbox_inches="tight")
    plt.close(fig)


def _extent_contours(centers: np.ndarray, Xs: np.ndarray, n: int) -> np.ndarray:
    """The contours ``{c + X^{1/2} u : |u| = 1}`` (``n`` points each) of every finite extent ``Xs[i]``
    (N, 2, 2) centred at ``centers[i]``, one after the other with a NaN row after each, ``(M, 2)``
    (:func:`radarslam.viz.carpark.draw_extents`'s ellipses as one path)."""
    ok = np.all(np.isfinite(Xs.reshape(-1, 4)), axis=1)
    if not ok.any():
        return np.empty((0, 2))
    X = Xs[ok]
    lam, U = np.linalg.eigh(0.5 * (X + np.swapaxes(X, 1, 2)))
    t = np.linspace(0.0, 2.0 * math.pi, n)
    circ = np.stack([np.cos(t), np.sin(t)])
    pts = centers[ok][:, :, None] + (U * np.sqrt(np.maximum(lam, 0.0))[:, None, :]) @ circ     # (N, 2, n)
    out = np.full((pts.shape[0], n + 1, 2), np.nan)
    out[:, :n] = np.swapaxes(pts, 1, 2)
    return out.reshape(-1, 2)


def plot_ego_velocity(path: str | Path, t: np.ndarray, theta: np.ndarray, cov: np.ndarray, valid: np.ndarray,
                      odometry: np.ndarray | None, *, title: str = "ego-motion from the radars' Doppler") -> None:
    """Save two panels over time: the forward speed ``v_x`` and the yaw rate from the Doppler fits
    (valid ones, with their 2-sigma band from ``cov``) against the odometry's speed and yaw rate.

    Parameters
    ----------
    t : ndarray (K,)
    theta : ndarray (K, 3)
        ``(v_x, v_y, omega)`` (m/s, m/s, rad/s).
    cov : ndarray (K, 3, 3)
    valid : ndarray of bool (K,)
    odometry : ndarray (T, 3) or None
        ``t_s, speed_mps, yaw_rate_rad_s``.
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(theta, dtype=float).reshape(-1, 3)
    cov = np.asarray(cov, dtype=float).reshape(-1, 3, 3)
    if theta.shape[0] != t.size or cov.shape[0] != t.size or np.shape(valid) != t.shape:
        raise InputError(f"theta, cov, valid: expected {t.size} rows each, got {theta.shape[0]}, {cov.shape[0]}, "
                         f"{np.shape(valid)}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = np.asarray(valid, dtype=bool) & np.isfinite(theta[:, 0])
    fig, axes = plt.subplots(2, 1, figsize=(11, 6.5), sharex=True)
    for ax, j, scale, unit, name in ((axes[0], 0, 1.0, "m/s", "speed"), (axes[1], 2, math.degrees(1.0), "deg/s",
                                                                         "yaw rate")):
        v = theta[ok, j] * scale
        s = 2.0 * np.sqrt(np.maximum(cov[ok, j, j], 0.0)) * scale
        ax.fill_between(t[ok], v - s, v + s, color="tab:blue", alpha=0.25, lw=0, label="Doppler fit 2-sigma")
        ax.plot(t[ok], v, "-", color="tab:blue", lw=0.7, label=f"{name} from the Doppler")
        if odometry is not None and len(odometry):
            o = np.asarray(odometry, dtype=float)
            ax.plot(o[:, 0], o[:, 1 if j == 0 else 2] * scale, "-", color="k", lw=0.9, label=f"odometry's {name}")
        ax.set_ylabel(f"{name} ({unit})")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    axes[1].set_xlabel("t (s)")
    axes[0].set_title(f"{title}: {int(ok.sum())} of {t.size} windows valid")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_pose_nees(path: str | Path, t: np.ndarray, nees: np.ndarray, band: tuple[float, float], time_average: float,
                   *, share_inside: float | None = None, prob: float = 0.95,
                   title: str = "pose NEES against the truth") -> None:
    """Save the pose NEES (3 dof) of every scan against time on a log axis, the one-scan ``prob`` band
    ``band`` as two horizontal lines and the time average ``time_average`` as a third.

    Parameters
    ----------
    t : ndarray (K,)
        Scan times (s).
    nees : ndarray (K,)
        The NEES per scan (NaN: none; values <= 0 are not drawn on the log axis).
    band : (low, high)
    share_inside : float or None
        The share of the scans inside ``band``, for the legend.
    """
    t = np.asarray(t, dtype=float).reshape(-1)
    nees = np.asarray(nees, dtype=float).reshape(-1)
    if nees.shape != t.shape:
        raise InputError(f"nees: expected {t.size} values (one per scan time), got {nees.size}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ok = np.isfinite(nees) & (nees > 0)
    fig, ax = plt.subplots(figsize=(11, 4.5))
    inside = "" if share_inside is None else f", {100 * share_inside:.0f}% inside the band"
    ax.plot(t[ok], nees[ok], "-", color="tab:blue", lw=0.8,
            label=f"NEES per scan ({int(np.isfinite(nees).sum())} scans{inside})")
    lo, hi = band
    for v, name in ((lo, "low"), (hi, "high")):
        ax.axhline(v, color="tab:green", lw=1.0, ls="--", label=f"{100 * prob:.0f}% band of one scan, {name} "
                                                                 f"({v:.3g})")
    if np.isfinite(time_average):
        ax.axhline(time_average, color="tab:red", lw=1.2, label=f"time average ({time_average:.3g}; 3 = consistent)")
    ax.set_yscale("log")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("pose NEES (3 dof)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.grid(alpha=0.1, which="minor")
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=2, fontsize=8)   # below: never over the curve
    fig.tight_layout()
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)
