"""Ego-motion of a recording from its Doppler alone (docs/method.md c.10, docs/recordings.md
"A radar alone"): every scan's sensor velocity with its covariance and the at-rest flag, moved
into the platform (body) frame with the 3-D mounting of ``[sensor]``, written as a CSV and a figure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.config import Config
from radarslam.core.errors import InputError
from radarslam.models.doppler import directions, fit_ego_velocity


def mounting_3d(sensor) -> tuple[np.ndarray, np.ndarray]:
    """``(R (3, 3), l (3,))``: the rotation from the sensor frame to the platform frame and the
    sensor's position in the platform frame (m), from ``[sensor]``: ``mount_quaternion`` ``[x, y,
    z, w]`` when given, else roll, pitch and yaw (ZYX: ``R = Rz(yaw) Ry(pitch) Rx(roll)``)."""
    q = list(sensor.mount_quaternion)
    if q:
        x, y, z, w = np.asarray(q, dtype=float) / math.sqrt(sum(v * v for v in q))
        R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                      [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                      [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    else:
        r, p, yw = (math.radians(sensor.mount_roll_deg), math.radians(sensor.mount_pitch_deg),
                    math.radians(sensor.mount_yaw_deg))
        cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(yw), math.sin(yw)
        Rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
        Ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
        Rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
        R = Rz @ Ry @ Rx
    return R, np.array([sensor.mount_x_m, sensor.mount_y_m, sensor.mount_z_m], dtype=float)


@dataclass
class EgoMotionRun:
    """Per-scan ego-velocity of a recording (``K`` scans, ``dim`` 2 or 3).

    Attributes
    ----------
    t : ndarray, shape (K,)
        Scan times (s).
    v : ndarray, shape (K, dim)
        Platform velocity at the platform origin, platform frame (m/s); NaN where not valid.
    cov : ndarray, shape (K, dim, dim)
        Its covariance (m^2/s^2).
    valid, at_rest : ndarray of bool, shape (K,)
    zero_stat, sigma_mps : ndarray, shape (K,)
        The at-rest chi-square statistic and the residual std (m/s).
    n_detections, n_inliers : ndarray of int, shape (K,)
    """

    t: np.ndarray
    v: np.ndarray
    cov: np.ndarray
    valid: np.ndarray
    at_rest: np.ndarray
    zero_stat: np.ndarray
    sigma_mps: np.ndarray
    n_detections: np.ndarray
    n_inliers: np.ndarray

    @property
    def speed(self) -> np.ndarray:
        """``|v|`` (m/s), ``(K,)``."""
        return np.linalg.norm(self.v, axis=1)

    @property
    def speed_std(self) -> np.ndarray:
        """First-order std of ``|v|`` (m/s): ``sqrt(v^T C v) / |v|`` (``sqrt(trace C)`` at 0)."""
        s = self.speed
        q = np.einsum("ka,kab,kb->k", self.v, self.cov, self.v)
        tr = np.trace(self.cov, axis1=1, axis2=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.where(s > 1e-9, np.sqrt(np.abs(q)) / np.where(s > 1e-9, s, 1.0), np.sqrt(np.abs(tr)))


def ego_motion(rec, config: Config, rng: np.random.Generator, gyro=None) -> EgoMotionRun:
    """Fit every scan of ``rec`` (c.10.2-c.10.3) and move the velocity into the platform frame.

    In 3-D (the recording has ``z_m``) the sensor velocity ``v_s`` gives the platform's as
    ``v = R v_s - omega x l`` (c.10.1) with ``omega`` the gyro's rate at the scan time when
    ``gyro = (t (n,) s, rates (n, 3) rad/s)`` is given (else 0); in 2-D ``R`` is the yaw rotation.
    """
    f = config.filter
    if "doppler_mps" not in rec.channels:
        raise InputError(f"{rec.source}: ego-motion from Doppler expected a Doppler field in the cloud, got "
                         f"channels {sorted(rec.channels)}; name it with --doppler-field NAME")
    three = "z_m" in rec.channels
    R, lever = mounting_3d(config.sensor)
    dim = 3 if three else 2
    if not three:
        R, lever = R[:2, :2], lever[:2]
    st = rec.scan_times()
    order = np.argsort(rec.det_t, kind="stable")
    t = rec.det_t[order]
    starts, ends = np.searchsorted(t, st, side="left"), np.searchsorted(t, st, side="right")
    polar, dop = rec.det_polar[order], rec.channels["doppler_mps"][order]
    z = rec.channels["z_m"][order] if three else None
    K = st.size
    out = EgoMotionRun(st, np.full((K, dim), np.nan), np.full((K, dim, dim), np.nan), np.zeros(K, bool),
                       np.zeros(K, bool), np.full(K, np.nan), np.full(K, np.nan), ends - starts, np.zeros(K, int))
    for k, (a, b) in enumerate(zip(starts.tolist(), ends.tolist())):
        U = directions(polar[a:b], None if z is None else z[a:b])
        e = fit_ego_velocity(U, dop[a:b], rng, threshold_mps=f.doppler_threshold_mps, iterations=f.doppler_iterations,
                             sigma_floor_mps=f.doppler_std_floor_mps, zero_probability=f.zero_velocity_probability)
        out.n_inliers[k] = e.n_inliers
        if not e.valid:
            continue
        w = np.zeros(3)
        if gyro is not None:
            w = np.array([np.interp(st[k], gyro[0], gyro[1][:, i]) for i in range(3)])
        lever_term = np.cross(w, lever)[:dim] if three else w[2] * np.array([-lever[1], lever[0]])
        out.v[k] = R @ e.v - lever_term
        out.cov[k] = R @ e.cov @ R.T
        out.valid[k], out.at_rest[k] = True, e.at_rest
        out.zero_stat[k], out.sigma_mps[k] = e.zero_stat, e.sigma_mps
    return out


def write_ego_motion(out, run: EgoMotionRun) -> list[str]:
    """``ego_velocity.csv`` (per scan: time, flags, counts, velocity, covariance, speed and its
    std, at-rest statistic, residual std) and ``speed.png`` (when matplotlib is installed)."""
    from radarslam.io.results import atomic_write_text

    dim = run.v.shape[1]
    axes = "xyz"[:dim]
    cov_cols = [f"cov_{axes[i]}{axes[j]}_m2s2" for i in range(dim) for j in range(i, dim)]
    head = (["t_s", "valid", "at_rest", "n_detections", "n_inliers"] + [f"v{a}_mps" for a in axes] + cov_cols
            + ["speed_mps", "speed_std_mps", "zero_stat", "sigma_mps"])
    sp, ss = run.speed, run.speed_std
    lines = [",".join(head)]
    for k in range(run.t.size):
        c = [run.cov[k, i, j] for i in range(dim) for j in range(i, dim)]
        vals = [run.t[k], int(run.valid[k]), int(run.at_rest[k]), int(run.n_detections[k]), int(run.n_inliers[k]),
                *run.v[k], *c, sp[k], ss[k], run.zero_stat[k], run.sigma_mps[k]]
        lines.append(",".join(repr(float(v)) if isinstance(v, float) else str(v) for v in vals))
    atomic_write_text(out / "ego_velocity.csv", "\n".join(lines) + "\n")
    names = ["ego_velocity.csv"]
    from radarslam.viz import have_matplotlib

    if have_matplotlib():
        plot_speed(out / "speed.png", run)
        names.append("speed.png")
    return names


def plot_speed(path, run: EgoMotionRun) -> None:
    """Speed over time with its +-2 std band, scans flagged at rest shaded."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(9, 3.5))
    sp, ss = run.speed, run.speed_std
    ax.fill_between(run.t, sp - 2 * ss, sp + 2 * ss, color="tab:blue", alpha=0.25, label="+-2 std")
    ax.plot(run.t, sp, "-", color="tab:blue", lw=1.2, label="speed from Doppler")
    rest = run.at_rest.astype(float)
    ax.fill_between(run.t, 0, 1, where=rest > 0, transform=ax.get_xaxis_transform(), color="0.85",
                    label="at rest (chi-square test)")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("speed (m/s)")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary(run: EgoMotionRun) -> dict:
    """The run's numbers for ``metrics.json``."""
    moving = run.valid & ~run.at_rest
    return {"scans": int(run.t.size), "valid_scans": int(run.valid.sum()), "valid_fraction": float(run.valid.mean()),
            "at_rest_scans": int(run.at_rest.sum()),
            "moving_speed_median_mps": float(np.median(run.speed[moving])) if moving.any() else None,
            "mean_sigma_mps": float(np.nanmean(run.sigma_mps)) if run.valid.any() else None}
