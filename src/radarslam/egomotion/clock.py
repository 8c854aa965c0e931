"""The radars' clock against the wheels, online from the first sweep (docs/method.md c.12.8).

A recording's radar stamps and its odometry's come from different clocks, or from one clock at
different points of the processing: nuScenes' radars read 30-45 ms early against the wheels on the
Boston car, RadarScenes' about 0.1 s late (c.12.8's table). The rig's Doppler fit (c.12.3) measures
the car's forward speed at each sweep from the radars alone, so a sweep stamped ``t`` that was
measured at ``t + tau`` reads

    v_x(t) = (1 + s) v_o(t + tau) + e  ~  v_o(t) + tau a_o(t) + s v_o(t) + e,

with ``v_o`` the wheel speed, ``a_o`` its rate of change (a central difference over
``2 ACCEL_HALF_S``: the estimate looks that far ahead of the sweep), ``s`` the wheels' scale against
the Doppler's and ``e`` the fit's error. ``(tau, s)`` is a static state: a Kalman filter (recursive
least squares with a prior) takes the valid sweeps in time order, each with the variance of the
fit's ``v_x`` as an independent reading (``white_cov``, c.12.7) plus the wheels' speed noise at
the profile's density (c.2.2); a sweep whose residual lies beyond ``GATE_SIGMA`` standard deviations
is not taken. Only sweeps at ``MIN_SPEED_MPS`` or more count (at a standstill there is nothing to
time). The estimate after sweep ``k`` uses sweeps ``1 .. k`` only: applied to the detections up to
the next sweep, it is what a car running the filter live would know. ``tau`` is seen through the
accelerations (a steady speed tells nothing of the clock), ``s`` through the speed itself.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import ConfigError

__all__ = ["ACCEL_HALF_S", "ClockTrack", "GATE_SIGMA", "MIN_SPEED_MPS", "SCALE_PRIOR_STD", "online_clock",
           "resolved_clock", "restamped", "shift_stamps"]

#: Half the span of the wheel speed's central difference (s).
ACCEL_HALF_S = 0.1
#: Sweeps slower than this (m/s) are not taken.
MIN_SPEED_MPS = 1.0
#: A sweep whose residual is beyond this many standard deviations is not taken.
GATE_SIGMA = 5.0
#: The prior std of the wheels' scale against the Doppler's (2%, as c.16's).
SCALE_PRIOR_STD = 0.02


@dataclass(frozen=True)
class ClockTrack:
    """The online estimate after each sweep: ``t`` (K,) the sweeps' stamps, ``offset_s`` (K,) the
    clock offset (the radar's stamps early by this much: a detection's time is its stamp plus it),
    ``std_s`` (K,) its std, ``scale`` (K,) the wheels' scale against the Doppler's minus one, and
    ``used`` (K,) whether the sweep was taken."""

    t: np.ndarray
    offset_s: np.ndarray
    std_s: np.ndarray
    scale: np.ndarray
    used: np.ndarray

    def at(self, t: np.ndarray) -> np.ndarray:
        """The offset known at times ``t``: the estimate after the last sweep stamped at or before
        each (0 before the first)."""
        k = np.searchsorted(self.t, t, side="right") - 1
        return np.where(k >= 0, self.offset_s[np.maximum(k, 0)], 0.0)

    def summary(self) -> dict:
        return {"offset_s": float(self.offset_s[-1]), "std_s": float(self.std_s[-1]),
                "wheel_scale_minus_one": float(self.scale[-1]), "sweeps_used": int(self.used.sum()),
                "sweeps": int(self.t.size), "from": "online (docs/method.md c.12.8)"}


def online_clock(series, odometry: np.ndarray, prior_std_s: float, speed_std_mps: float,
                 noise_interval_s: float) -> ClockTrack:
    """The online clock offset (module docstring) of the rig's fits ``series`` (a
    :class:`~radarslam.models.rig_velocity.RigVelocitySeries`) against ``odometry`` ``(n, 3)``
    ``[t, speed, yaw rate]``; ``prior_std_s`` the offset's prior std, ``speed_std_mps`` the wheel
    speed's std quoted over ``noise_interval_s`` (c.2.2)."""
    t = np.asarray(series.t, dtype=float)
    ot, ov = odometry[:, 0], odometry[:, 1]
    v_o = np.interp(t, ot, ov)
    a_o = (np.interp(t + ACCEL_HALF_S, ot, ov) - np.interp(t - ACCEL_HALF_S, ot, ov)) / (2 * ACCEL_HALF_S)
    var_fit = series.white_cov()[:, 0, 0]
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 0.1))
    var_odo = speed_std_mps ** 2 * noise_interval_s / np.maximum(dt, 1e-3)
    inside = (t >= ot[0] + ACCEL_HALF_S) & (t <= ot[-1] - ACCEL_HALF_S)
    ok = series.valid & np.isfinite(series.theta[:, 0]) & np.isfinite(var_fit) & inside & (v_o >= MIN_SPEED_MPS)
    x = np.zeros(2)                                    # (tau, s)
    P = np.diag([prior_std_s ** 2, SCALE_PRIOR_STD ** 2])
    K = t.size
    off, std, scale, used = np.zeros(K), np.zeros(K), np.zeros(K), np.zeros(K, dtype=bool)
    for k in range(K):
        if ok[k]:
            h = np.array([a_o[k], v_o[k]])
            r = series.theta[k, 0] - v_o[k] - h @ x
            S = h @ P @ h + var_fit[k] + var_odo[k]
            if r * r <= GATE_SIGMA ** 2 * S:
                g = P @ h / S
                x = x + g * r
                P = P - np.outer(g, h @ P)
                used[k] = True
        off[k], std[k], scale[k] = x[0], math.sqrt(max(P[0, 0], 0.0)), x[1]
    return ClockTrack(t, off, std, scale, used)


def restamped(rec, det_t: np.ndarray):
    """``rec`` with its detections stamped ``det_t`` (one per detection), every per-detection array
    re-sorted stably by the new stamps and the scans' own times dropped (they are the stamps'). The
    one re-stamping of a recording: the online clock's (:func:`shift_stamps`) and a calibration's
    per-radar offsets (``car_calibration.apply_calibration``)."""
    import dataclasses

    order = np.argsort(det_t, kind="stable")
    pick = lambda a: None if a is None else a[order]
    return dataclasses.replace(rec, det_t=det_t[order], det_polar=rec.det_polar[order],
                               channels={k: v[order] for k, v in rec.channels.items()},
                               labels=pick(rec.labels), det_scan=pick(rec.det_scan), scan_t=None)


def shift_stamps(rec, track: ClockTrack):
    """``rec`` with every detection's stamp moved to its time by the offset known then
    (:meth:`ClockTrack.at`), re-sorted (stably) when that changes their order."""
    return restamped(rec, rec.det_t + track.at(rec.det_t))


def resolved_clock(rec, config):
    """``config`` with ``filter.radar_clock`` "auto" replaced by what ``rec`` supports: "online" where it
    has a rig of radars with Doppler and wheel speeds (what the online clock reads, c.12.8), else
    "as-stamped"; any other value is returned as it is. The written ``config.toml`` then holds the
    value chosen, and ``metrics.json["radar_clock"]`` says it (present only when online)."""
    import dataclasses

    from radarslam.egomotion.rig_odometry import rig_of

    f = config.filter
    if f.radar_clock != "auto":
        return config
    rig = rig_of(rec)
    chosen = "online" if rig is not None and rig.odometry is not None else "as-stamped"
    return dataclasses.replace(config, filter=dataclasses.replace(f, radar_clock=chosen))


def clock_of(rec, config):
    """The online clock of recording ``rec`` under ``config`` (``filter.radar_clock = "online"``),
    or None ("as-stamped"; "auto" as :func:`resolved_clock` decides); one-line :class:`ConfigError` without a rig with Doppler or without wheel
    speeds."""
    from radarslam.egomotion.rig import checked_rig_velocity, filter_series
    from radarslam.egomotion.rig_odometry import rig_of

    f = resolved_clock(rec, config).filter
    if f.radar_clock == "as-stamped":
        return None
    rig = rig_of(rec)
    if rig is None or rig.odometry is None:
        raise ConfigError("filter.radar_clock: 'online' needs a rig of radars with Doppler (sensors.csv, doppler_mps) "
                          f"and wheel speeds (unicycle odometry), got {'no rig with Doppler' if rig is None else 'no wheel speeds'}")
    series = filter_series(checked_rig_velocity(rig, f))
    return online_clock(series, rig.odometry, f.radar_clock_std_s, f.speed_std_mps, f.noise_interval_s)
