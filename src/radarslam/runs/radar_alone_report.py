"""The checks, files and figures of a radar-alone SLAM run (docs/recordings.md "A radar alone";
docs/method.md c.10.6). A recording without ground truth is checked against what is known of it
(when it stood still, how fast one walks) and against an independent sensor (the accelerometer)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.runs.radar_alone import LevelledRecording

#: Window (s) over which the velocity's change is compared with the integrated accelerometer.
ACCEL_WINDOW_S = 1.0


def world_velocity(lev: LevelledRecording) -> np.ndarray:
    """Platform velocity in the gyro's levelled world frame, ``Rz(heading) v`` (K, 3) m/s."""
    c, s = np.cos(lev.heading), np.sin(lev.heading)
    v = lev.v
    return np.column_stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]])


def accel_agreement(lev: LevelledRecording, window_s: float = ACCEL_WINDOW_S) -> dict:
    """The velocity's change over ``window_s`` against the accelerometer integrated over it.

    The specific force ``a`` (body frame) is rotated into the map frame by the attitude (and the
    map frame's yaw) and gravity removed: ``R a - g e_z`` with ``g`` the mean ``|a|`` over the scans at rest (the
    accelerometer's own scale). Its integral over ``[t_k, t_j]`` (trapezoid), ``t_j`` the scan
    closest to ``t_k + window_s``, is compared with ``v(t_j) - v(t_k)`` in x and y (horizontal):
    Pearson correlation of the stacked components and the RMS of the vector difference.
    """
    imu, R = lev.imu, lev.attitude
    near_rest = lev.at_rest[np.clip(np.searchsorted(lev.t, imu.t), 0, lev.t.size - 1)]   # the next scan's flag
    g = float(np.linalg.norm(imu.accel[near_rest], axis=1).mean()) if near_rest.any() else 9.80665
    c, s = math.cos(lev.frame_yaw), math.sin(lev.frame_yaw)
    aw = np.einsum("ij,kjl,kl->ki", np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]]), R, imu.accel)  # map frame
    aw[:, 2] -= g
    V = np.vstack([np.zeros(3), np.cumsum(0.5 * (aw[1:] + aw[:-1]) * np.diff(imu.t)[:, None], axis=0)])
    vw = world_velocity(lev)
    dv_d, dv_i = [], []
    for k in range(lev.t.size):
        j = int(np.argmin(np.abs(lev.t - (lev.t[k] + window_s))))
        if j <= k or abs(lev.t[j] - lev.t[k] - window_s) > 0.06 or not (lev.valid[k] and lev.valid[j]):
            continue
        dv_d.append(vw[j, :2] - vw[k, :2])
        dv_i.append([np.interp(lev.t[j], imu.t, V[:, i]) - np.interp(lev.t[k], imu.t, V[:, i]) for i in range(2)])
    if len(dv_d) < 3:
        return {"windows": len(dv_d), "correlation": None, "rms_difference_mps": None, "gravity_mps2": g}
    d, i = np.array(dv_d), np.array(dv_i)
    corr = float(np.corrcoef(d.ravel(), i.ravel())[0, 1])
    return {"windows": len(dv_d), "correlation": corr,
            "rms_difference_mps": float(np.sqrt(np.mean(np.sum((d - i) ** 2, axis=1)))), "gravity_mps2": g}


def dead_reckoning(lev: LevelledRecording) -> dict:
    """The gyro's levelled heading and the Doppler velocity integrated alone (no map): total turn
    (deg), path length and end-to-start distance (m); zero-order hold as the filter predicts."""
    vw = world_velocity(lev)
    held = np.zeros((lev.t.size, 2))
    last = np.zeros(2)
    for k in range(lev.t.size):
        if lev.valid[k]:
            last = vw[k, :2]
        held[k] = last
    steps = held[:-1] * np.diff(lev.t)[:, None]
    pos = np.vstack([np.zeros(2), np.cumsum(steps, axis=0)])
    return {"turn_deg": math.degrees(float(lev.heading[-1] - lev.heading[0])),
            "path_m": float(np.sum(np.hypot(steps[:, 0], steps[:, 1]))),
            "end_start_m": float(np.hypot(*pos[-1])), "positions": pos}


def trajectory_figures(poses: np.ndarray) -> dict:
    """Total turn (deg, the unwrapped heading's change), path length and end-to-start distance (m)."""
    th = np.unwrap(poses[:, 2])
    d = np.diff(poses[:, :2], axis=0)
    return {"turn_deg": math.degrees(float(th[-1] - th[0])), "path_m": float(np.sum(np.hypot(d[:, 0], d[:, 1]))),
            "end_start_m": float(np.hypot(*(poses[-1, :2] - poses[0, :2])))}


def _check(value, low=None, high=None) -> dict:
    ok = value is not None and (low is None or value >= low) and (high is None or value <= high)
    exp = (f">= {low:g}" if high is None else f"<= {high:g}" if low is None else f"{low:g}-{high:g}")
    return {"value": value, "expected": exp, "pass": bool(ok)}


def summary(run, lev: LevelledRecording, *, rest_windows=((0.0, 13.0), (34.0, 40.0)),
            walking_speed=(1.0, 1.5), min_valid=0.99, min_correlation=0.95) -> dict:
    """The run's checks (each ``value``, ``expected``, ``pass``) and figures for ``summary.json``.

    The expectations are this recording's (docs/recordings.md): at rest in ``rest_windows`` (s),
    walking at ``walking_speed`` (m/s, the median over the scans not at rest), a velocity for at
    least ``min_valid`` of the scans, the accelerometer agreement at least ``min_correlation``."""
    speed = np.hypot(lev.v[:, 0], lev.v[:, 1])
    walk = lev.valid & ~lev.at_rest
    rest = {}
    for lo, hi in rest_windows:
        sel = (lev.t >= lo) & (lev.t <= hi)
        rest[f"{lo:g}-{hi:g} s"] = float(lev.at_rest[sel].mean()) if sel.any() else None
    acc = accel_agreement(lev)
    dr = dead_reckoning(lev)
    tr = trajectory_figures(run.record.poses)
    cb, sb = math.cos(lev.boresight_yaw), math.sin(lev.boresight_yaw)
    lat = np.abs(sb * lev.v[walk, 0] + cb * lev.v[walk, 1])           # in the levelled body frame
    checks = {
        "valid_fraction": _check(float(lev.valid.mean()), low=min_valid),
        **{f"at_rest_fraction_{k}": _check(v, low=1.0) for k, v in rest.items()},
        "walking_speed_median_mps": _check(float(np.median(speed[walk])) if walk.any() else None, *walking_speed),
        "accel_correlation": _check(acc["correlation"], low=min_correlation),
    }
    return {
        "checks": checks, "all_pass": all(c["pass"] for c in checks.values()),
        "scans": int(lev.t.size), "scans_valid": int(lev.valid.sum()), "scans_at_rest": int(lev.at_rest.sum()),
        "lateral_speed_median_mps": float(np.median(lat)) if lat.size else None,     # body y, while walking
        "accel": acc,
        "trajectory": tr,
        "gyro_dead_reckoning": {k: v for k, v in dr.items() if k != "positions"},
        "gyro_bias_rad_s": lev.gyro_bias.tolist(), "notes": lev.notes,
        "landmarks_final": int(run.record.n_landmarks[-1]),
        "landmarks_max": int(run.record.n_landmarks.max()),
        "detections": int(lev.n_detections.sum()), "detections_moving": int(lev.n_moving.sum()),
        "detections_kept": int(lev.n_kept.sum()), "associated": int(run.record.n_associated.sum()),
        "filter_seconds": run.record.seconds,
    }


def write_ego_velocity(path, lev: LevelledRecording) -> None:
    """``ego_velocity.csv``: per scan the levelled platform velocity (forward x, lateral y, up z;
    m/s) with the upper triangle of its covariance, the horizontal speed and its std, the yaw rate
    and heading of the levelled gyro, and the detection counts."""
    from radarslam.io.results import atomic_write_text

    cov_cols = [f"cov_{a}{b}_m2s2" for i, a in enumerate("xyz") for b in "xyz"[i:]]
    head = (["t_s", "valid", "at_rest", "n_detections", "n_inliers", "n_moving", "n_kept", "vx_mps", "vy_mps",
             "vz_mps"] + cov_cols + ["speed_mps", "speed_std_mps", "yaw_rate_rad_s", "heading_rad"])
    sp = np.hypot(lev.v[:, 0], lev.v[:, 1])
    q = np.einsum("ka,kab,kb->k", lev.v[:, :2], lev.cov[:, :2, :2], lev.v[:, :2])
    with np.errstate(invalid="ignore", divide="ignore"):
        ss = np.where(sp > 1e-9, np.sqrt(np.abs(q)) / np.where(sp > 1e-9, sp, 1.0),
                      np.sqrt(np.abs(np.trace(lev.cov[:, :2, :2], axis1=1, axis2=2))))
    lines = [",".join(head)]
    for k in range(lev.t.size):
        c = [lev.cov[k, i, j] for i in range(3) for j in range(i, 3)]
        ints = [int(lev.valid[k]), int(lev.at_rest[k]), int(lev.n_detections[k]), int(lev.n_inliers[k]),
                int(lev.n_moving[k]), int(lev.n_kept[k])]
        floats = [*lev.v[k], *c, sp[k], ss[k], lev.yaw_rate[k], lev.heading[k]]
        lines.append(",".join([repr(float(lev.t[k]))] + [str(i) for i in ints] + [repr(float(v)) for v in floats]))
    atomic_write_text(path, "\n".join(lines) + "\n")


def plot_speed_yaw(path, lev: LevelledRecording) -> None:
    """Horizontal speed (with +-2 std) and lateral speed over time, scans at rest shaded; the
    levelled gyro's yaw rate below."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, bx) = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    sp = np.hypot(lev.v[:, 0], lev.v[:, 1])
    sd = np.sqrt(np.abs(np.trace(lev.cov[:, :2, :2], axis1=1, axis2=2)))
    for a in (ax, bx):
        a.fill_between(lev.t, 0, 1, where=lev.at_rest, transform=a.get_xaxis_transform(), color="0.88",
                       label="at rest (zero-velocity test)" if a is ax else None)
    ax.fill_between(lev.t, sp - 2 * sd, sp + 2 * sd, color="tab:blue", alpha=0.25, label="+-2 std")
    ax.plot(lev.t, sp, "-", color="tab:blue", lw=1.2, label="horizontal speed (Doppler, levelled)")
    lat = math.sin(lev.boresight_yaw) * lev.v[:, 0] + math.cos(lev.boresight_yaw) * lev.v[:, 1]
    ax.plot(lev.t, lat, "-", color="tab:orange", lw=0.8, label="lateral velocity (body y, levelled)")
    ax.set_ylabel("m/s")
    ax.legend(loc="upper right", fontsize=8)
    bx.plot(lev.t, np.degrees(lev.yaw_rate), "-", color="tab:green", lw=1.0, label="yaw rate (gyro, levelled)")
    bx.set_ylabel("deg/s")
    bx.set_xlabel("t (s)")
    bx.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def plot_map(path, run, lev: LevelledRecording, dr_positions: np.ndarray | None = None) -> None:
    """The final map (centroids, 2-sigma covariance and extent ellipses) over the estimated
    trajectory, with every kept detection placed by its scan's estimated pose (grey)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from radarslam.models.radar import polar_to_xy
    from radarslam.viz.carpark import _ellipse_xy, draw_extents

    poses = run.record.poses
    scans = [e for e in run.events if hasattr(e, "polar")]
    pts = [polar_to_xy(p, s.polar) for p, s in zip(poses, scans) if s.polar.size]
    fig, ax = plt.subplots(figsize=(8, 8))
    if pts:
        P = np.concatenate(pts)
        ax.plot(P[:, 0], P[:, 1], ".", ms=1.5, color="0.65", label="kept detections (estimated poses)")
    if dr_positions is not None:
        ax.plot(dr_positions[:, 0], dr_positions[:, 1], ":", color="tab:purple", lw=1.0,
                label="dead reckoning (Doppler + gyro)")
    ax.plot(poses[:, 0], poses[:, 1], "-", color="tab:blue", lw=1.5, label="SLAM trajectory")
    ax.plot(*poses[0, :2], "o", color="tab:green", label="start")
    ax.plot(*poses[-1, :2], "s", color="tab:red", label="end")
    mp = run.record.maps[-1]
    if mp.positions.size:
        ax.plot(mp.positions[:, 0], mp.positions[:, 1], "k+", ms=7, label=f"landmarks ({mp.positions.shape[0]})")
        for c, C in zip(mp.positions, mp.covs):
            e = _ellipse_xy(c, 4.0 * C)
            ax.plot(e[:, 0], e[:, 1], "-", color="k", lw=0.5)
        draw_extents(ax, mp.positions, mp.rma, color="tab:red", label="extent (RMA)")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(loc="best", fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
