"""Mounting calibration of a rig of radars from the static world's Doppler (docs/method.md c.12.5):
each radar's yaw offset against the reference motion of the odometry, the table ``calibration.csv``
and a ``sensors_calibrated.csv`` in the sensors.csv format that a later run can take.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError
from radarslam.egomotion.rig import Rig
from radarslam.models.rig_velocity import (
    DEFAULTS,
    fit_rig_windows,
    static_doppler,
    tukey_location,
    yaw_offset_of_sweep,
)

__all__ = ["Calibration", "calibrate_yaw", "write_calibration"]

#: Sweeps whose sensor moves slower than this (m/s) are left out (c.12.5): the reference's own error
#: (wheel-speed quantisation, unmodelled sideslip, ~0.05 m/s) is then more than 1.4 deg of direction.
MIN_SPEED_MPS = 2.0


@dataclass(frozen=True)
class Calibration:
    """Each sensor's yaw offset (rows in ``Rig.sensor_ids`` order; c.12.5).

    Attributes
    ----------
    sensor_ids : ndarray of int, shape (S,)
    names : list of str
    yaw_nominal, offset, std : ndarray, shape (S,)
        The mounting's yaw, the estimated offset and its std (rad); the calibrated yaw is their sum.
        NaN where no sweep qualified.
    n_sweeps, n_used : ndarray of int, shape (S,)
        Sweeps with a valid fit and a moving sensor; those with a non-zero weight in the estimate.
    rms_before, rms_after : ndarray, shape (S,)
        RMS of the static detections' Doppler residual against the reference motion (m/s) with the
        nominal and the calibrated yaw.
    """

    sensor_ids: np.ndarray
    names: list
    yaw_nominal: np.ndarray
    offset: np.ndarray
    std: np.ndarray
    n_sweeps: np.ndarray
    n_used: np.ndarray
    rms_before: np.ndarray
    rms_after: np.ndarray

    def mount(self, rig: Rig) -> np.ndarray:
        """The rig's mounting ``(S, 3)`` with the calibrated yaws (nominal where not estimated)."""
        m = rig.mount.copy()
        m[:, 2] += np.nan_to_num(self.offset)
        return m


def check_calibration_drive(rig: Rig, min_speed_mps: float) -> None:
    """Refuse in one line a calibration drive without odometry (the reference motion) or a
    non-positive speed threshold."""
    if rig.odometry is None or rig.odometry.shape[0] < 2:
        raise InputError("--recording: expected odometry.csv (t_s, speed_mps, yaw_rate_rad_s) as the reference "
                         "motion of the calibration, got none")
    if not min_speed_mps > 0:
        raise InputError(f"min_speed_mps: expected > 0 m/s, got {min_speed_mps}")


def calibrate_yaw(rig: Rig, rng: np.random.Generator, *, min_speed_mps: float = MIN_SPEED_MPS) -> Calibration:
    """Each radar's yaw offset from its sweeps against the odometry's motion (c.12.5).

    Per sweep, the sensor's own velocity ``w`` is fitted in its nominal frame (the robust fit of
    c.12.3 on the design rows ``-(cos phi, sin phi)``); the odometry (``speed_mps`` forward, no
    sideslip at the rear axle, ``yaw_rate_rad_s``) interpolated at the sweep's time predicts
    ``w_ref``; the offset is ``angle(w_ref) - angle(w)`` with its first-order variance
    (:func:`~radarslam.models.rig_velocity.yaw_offset_of_sweep`), and the sweeps' offsets are pooled
    by Tukey's biweight (:func:`~radarslam.models.rig_velocity.tukey_location`).
    """
    check_calibration_drive(rig, min_speed_mps)
    S = rig.sensor_ids.size
    order = np.lexsort((rig.t, rig.sensor))                 # sweeps contiguous: by sensor, then time
    t, sen, az, d = rig.t[order], rig.sensor[order], rig.azimuth[order], rig.doppler[order]
    key = np.flatnonzero(np.r_[True, (np.diff(t) != 0) | (np.diff(sen) != 0)])
    lo = key
    hi = np.r_[key[1:], t.size]
    A = np.ascontiguousarray(np.column_stack([-np.cos(az), -np.sin(az)]))
    # one window per sweep: fit_rig_windows over a strictly increasing pseudo-time (sweep index)
    sweep = np.repeat(np.arange(lo.size), hi - lo).astype(float)
    opts = {k: v for k, v in DEFAULTS.items()}
    fit = fit_rig_windows(sweep, A, d, np.arange(lo.size, dtype=float), rng, half_window_s=0.25, **opts)
    w = fit.theta[:, [0, 2]] if fit.theta.shape[1] == 3 else fit.theta
    cov = fit.cov[:, ::2, ::2]
    # fit_rig_windows reports a 2-column fit as (v_x, 0, omega): here that is (w_x, 0, w_y)
    ts, ss = t[lo], sen[lo]
    odo = rig.odometry
    vx = np.interp(ts, odo[:, 0], odo[:, 1])
    om = np.interp(ts, odo[:, 0], odo[:, 2])
    mx, my, myaw = rig.mount[ss, 0], rig.mount[ss, 1], rig.mount[ss, 2]
    ux, uy = vx - om * my, om * mx                            # sensor velocity, vehicle frame (c.12.1)
    c, s = np.cos(myaw), np.sin(myaw)
    w_ref = np.column_stack([c * ux + s * uy, -s * ux + c * uy])
    delta, var, _ = yaw_offset_of_sweep(np.nan_to_num(w), np.nan_to_num(cov), w_ref)
    inside = (ts >= odo[0, 0]) & (ts <= odo[-1, 0])
    use = fit.valid & inside & (np.hypot(w_ref[:, 0], w_ref[:, 1]) >= min_speed_mps) & (var > 0)
    off = np.full(S, np.nan)
    std = np.full(S, np.nan)
    n_sw = np.zeros(S, dtype=np.int64)
    n_used = np.zeros(S, dtype=np.int64)
    before = np.full(S, np.nan)
    after = np.full(S, np.nan)
    for j in range(S):
        k = np.flatnonzero(use & (ss == j))
        n_sw[j] = k.size
        if k.size < 3:
            continue
        off[j], std[j], wt = tukey_location(delta[k], np.sqrt(var[k]))
        n_used[j] = int(np.count_nonzero(wt))
        # static detections of the used sweeps: those within RANSAC's threshold of their sweep's fit
        rows = np.concatenate([np.arange(lo[i], hi[i]) for i in k])
        kk = np.repeat(k, hi[k] - lo[k])
        pred_fit = np.einsum("ij,ij->i", A[rows], w[kk])
        static = np.abs(d[rows] - pred_fit) <= DEFAULTS["threshold_mps"]
        r, kk = rows[static], kk[static]
        for name, yaw in (("before", myaw[kk]), ("after", myaw[kk] + off[j])):
            e = d[r] - static_doppler(az[r], mx[kk], my[kk], yaw, vx[kk], 0.0, om[kk])
            (before if name == "before" else after)[j] = math.sqrt(float(np.mean(e * e))) if e.size else math.nan
    return Calibration(rig.sensor_ids.copy(), list(rig.names), rig.mount[:, 2].copy(), off, std, n_sw, n_used,
                       before, after)


def write_calibration(out: str | Path, rig: Rig, cal: Calibration) -> list[str]:
    """``calibration.csv`` (one row per sensor: ``sensor_id, name, yaw_nominal_deg, yaw_offset_deg,
    std_deg, yaw_calibrated_deg, n_sweeps, n_used, residual_rms_before_mps, residual_rms_after_mps``)
    and ``sensors_calibrated.csv`` (the sensors.csv columns ``sensor_id, x_m, y_m, yaw_rad, name``
    with the calibrated yaw). Returns the names written."""
    from radarslam.io.results import atomic_write_text

    out = Path(out)
    f = lambda v, fmt: "" if not np.isfinite(v) else format(float(v), fmt)
    lines = [("sensor_id,name,yaw_nominal_deg,yaw_offset_deg,std_deg,yaw_calibrated_deg,n_sweeps,n_used,"
              "residual_rms_before_mps,residual_rms_after_mps")]
    m = cal.mount(rig)
    for j, sid in enumerate(cal.sensor_ids):
        lines.append(",".join([str(int(sid)), cal.names[j], f(math.degrees(cal.yaw_nominal[j]), ".4f"),
                               f(math.degrees(cal.offset[j]), ".4f"), f(math.degrees(cal.std[j]), ".4f"),
                               f(math.degrees(m[j, 2]), ".4f"), str(int(cal.n_sweeps[j])), str(int(cal.n_used[j])),
                               f(cal.rms_before[j], ".4f"), f(cal.rms_after[j], ".4f")]))
    atomic_write_text(out / "calibration.csv", "\n".join(lines) + "\n")
    sl = ["sensor_id,x_m,y_m,yaw_rad,name"]
    for j, sid in enumerate(cal.sensor_ids):
        sl.append(f"{int(sid)},{m[j, 0]:.4f},{m[j, 1]:.4f},{m[j, 2]:.6f},{cal.names[j]}")
    atomic_write_text(out / "sensors_calibrated.csv", "\n".join(sl) + "\n")
    return ["calibration.csv", "sensors_calibrated.csv"]
