"""EKF-SLAM on a 3-D radar recording without odometry: the Doppler ego-velocity and a gyro drive the
prediction, the detections are levelled and projected to the horizontal plane (docs/method.md
c.10.6, docs/recordings.md "A radar alone").

:func:`level_recording` turns a :class:`~radarslam.io.recording.stream.Recording` with ``z_m`` and
``doppler_mps`` and the IMU's samples into the filter's event stream:

1. every scan's sensor velocity is fitted in 3-D (c.10.2-c.10.3) and the detections failing the
   static-world test are dropped as moving (c.10.4, in 3-D);
2. the attitude of the platform (the IMU's body frame) is integrated from the gyro, levelled by the
   accelerometer (:mod:`radarslam.models.attitude`), after subtracting the gyro's mean over the
   scans at rest before the first motion (its bias);
3. the velocity moves to the platform origin (the lever arm, c.10.1) and into the levelled platform
   frame (origin the IMU's, x axis the radar's boresight projected on the horizontal plane, z up);
   its forward and lateral components and their covariance ride on the scan (``Scan.ego``);
4. the detections move into the levelled platform frame; those outside the elevation gate or the
   height band of ``[sensor]`` are dropped; the rest become range and azimuth about the platform
   origin in the horizontal plane;
5. between two scans an odometry event carries the mean yaw rate of the levelled heading.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from radarslam.config import Config, validate
from radarslam.core.errors import ConfigError, InputError
from radarslam.core.types import Odometry, Scan
from radarslam.egomotion.single_radar import mounting_3d
from radarslam.models.attitude import headings, integrate_attitude, levelling
from radarslam.models.doppler import EgoVelocity, directions, fit_ego_velocity, moving_mask

#: Rest before the first motion shorter than this (s) gives no gyro bias (too few samples to average).
MIN_REST_FOR_BIAS_S = 1.0


@dataclass
class Imu:
    """IMU samples on the radar's clock: ``t`` (n,) s, ``gyro`` (n, 3) rad/s, ``accel`` (n, 3) m/s^2."""

    t: np.ndarray
    gyro: np.ndarray
    accel: np.ndarray


@dataclass
class LevelledRecording:
    """A 3-D recording made ready for the 2-D filter (``K`` scans).

    Attributes
    ----------
    t : ndarray, shape (K,)
        Scan times (s).
    events : list of Event
        The stream: an odometry event (yaw rate) before every scan but the first, and the scans
        (levelled, gated detections; ``Scan.ego`` the levelled velocity).
    v, cov : ndarray, shapes (K, 3) and (K, 3, 3)
        Platform velocity at the platform origin in the levelled frame (m/s; NaN where no valid
        fit) and its covariance.
    valid, at_rest : ndarray of bool, shape (K,)
    yaw_rate : ndarray, shape (K,)
        Mean yaw rate of the levelled heading over the interval ending at each scan (rad/s; 0 at the first).
    heading : ndarray, shape (K,)
        The gyro's levelled heading at each scan (rad, unwrapped, 0 at the first scan: the filter's
        map frame when its initial heading is 0).
    n_detections, n_inliers, n_moving, n_kept : ndarray of int, shape (K,)
    gyro_bias : ndarray, shape (3,)
        The bias subtracted (rad/s).
    attitude : ndarray, shape (n, 3, 3)
        The attitude at every IMU sample (body to the gyro's levelled world frame, heading 0 at the
        first sample).
    frame_yaw : float
        Heading (rad) of the map frame in that world frame: the gyro's heading at the first scan
        plus the boresight's azimuth on the body (the 2-D platform frame's x axis is the radar's
        boresight on the horizontal plane, so that ``filter.field_of_view_deg`` is centred on it).
    boresight_yaw : float
        That boresight's azimuth in the body's x-y plane (rad): ``Rz(boresight_yaw) v`` is the
        velocity in the levelled body frame.
    imu : Imu
    notes : list of str
    """

    t: np.ndarray
    events: list
    v: np.ndarray
    cov: np.ndarray
    valid: np.ndarray
    at_rest: np.ndarray
    yaw_rate: np.ndarray
    heading: np.ndarray
    n_detections: np.ndarray
    n_inliers: np.ndarray
    n_moving: np.ndarray
    n_kept: np.ndarray
    gyro_bias: np.ndarray
    attitude: np.ndarray
    frame_yaw: float
    boresight_yaw: float
    imu: Imu
    notes: list


def check_radar_alone_config(config: Config) -> Config:
    """The configuration of a radar-alone SLAM run: ``filter.odometry = "doppler"`` with the
    body-velocity model (the lateral speed is not forced to 0)."""
    config = validate(config)
    f = config.filter
    if f.odometry != "doppler":
        raise ConfigError(f"filter.odometry: a recording without odometry runs SLAM with 'doppler' (c.10.6), got "
                          f"{f.odometry!r}")
    if f.motion_model != "body-velocity":
        raise ConfigError(f"filter.motion_model: expected 'body-velocity' with filter.odometry 'doppler' on a "
                          f"recording (the lateral speed is measured, c.10.5), got {f.motion_model!r}")
    if f.initial_error != "fixed":
        raise ConfigError(f"filter.initial_error: expected 'fixed' for real data, got {f.initial_error!r}")
    return config


def _fits(rec, config: Config, rng: np.random.Generator):
    """Per scan (sorted detections): ``(slices, sensor-frame points (n, 3), fits, moving masks)``."""
    f = config.filter
    if "doppler_mps" not in rec.channels or "z_m" not in rec.channels:
        raise InputError(f"{rec.source}: SLAM from a radar alone expected 3-D detections with Doppler (fields z and "
                         f"a Doppler field), got channels {sorted(rec.channels)}")
    st = rec.scan_times()
    order = np.argsort(rec.det_t, kind="stable")
    t = rec.det_t[order]
    a, b = np.searchsorted(t, st, side="left"), np.searchsorted(t, st, side="right")
    polar, dop, z = rec.det_polar[order], rec.channels["doppler_mps"][order], rec.channels["z_m"][order]
    ps = np.column_stack([polar[:, 0] * np.cos(polar[:, 1]), polar[:, 0] * np.sin(polar[:, 1]), z])
    fits, moving = [], []
    for i, j in zip(a.tolist(), b.tolist()):
        U = directions(polar[i:j], z[i:j])
        e = fit_ego_velocity(U, dop[i:j], rng, threshold_mps=f.doppler_threshold_mps, iterations=f.doppler_iterations,
                             sigma_floor_mps=f.doppler_std_floor_mps, zero_probability=f.zero_velocity_probability)
        fits.append(e)
        moving.append(moving_mask(U, dop[i:j], e, f.doppler_gate_probability) if e.valid else np.zeros(j - i, bool))
    ch = {k: v[order] for k, v in rec.channels.items()}
    return st, list(zip(a.tolist(), b.tolist())), ps, fits, moving, ch


def rest_bias(imu: Imu, st: np.ndarray, fits: list[EgoVelocity]) -> tuple[np.ndarray, str]:
    """The gyro's mean (rad/s) over the scans at rest before the first valid moving scan, and a note."""
    moving = [k for k, e in enumerate(fits) if e.valid and not e.at_rest]
    end = st[moving[0]] if moving else st[-1]
    rest = [k for k, e in enumerate(fits) if e.valid and e.at_rest and st[k] < end]
    if not rest or end - st[rest[0]] < MIN_REST_FOR_BIAS_S:
        return np.zeros(3), "gyro bias: no rest of at least 1 s before the first motion; none subtracted"
    sel = (imu.t >= st[rest[0]]) & (imu.t < end)
    b = imu.gyro[sel].mean(axis=0)
    return b, (f"gyro bias from the rest over {st[rest[0]]:.2f}-{end:.2f} s ({int(sel.sum())} samples): "
               f"[{b[0]:.5f}, {b[1]:.5f}, {b[2]:.5f}] rad/s")


def level_recording(rec, imu: Imu, config: Config, rng: np.random.Generator) -> LevelledRecording:
    """The recording as the levelled, gated event stream of the 2-D filter (module docstring)."""
    s = config.sensor
    st, spans, ps, fits, moving, ch = _fits(rec, config, rng)
    if imu.t[0] > st[0] + 0.5 or imu.t[-1] < st[-1] - 0.5:
        raise InputError(f"{rec.source}: expected IMU samples over the radar's {st[0]:.2f}-{st[-1]:.2f} s, got "
                         f"{imu.t[0]:.2f}-{imu.t[-1]:.2f} s (clocks not aligned?)")
    notes = []
    bias = np.zeros(3)
    if s.gyro_bias_from_rest:
        bias, note = rest_bias(imu, st, fits)
        notes.append(note)
    R = integrate_attitude(imu.t, imu.gyro, imu.accel, tau_s=s.attitude_time_constant_s, bias=bias)
    Rm, lever = mounting_3d(s)
    yb = math.atan2(Rm[1, 0], Rm[0, 0])          # the boresight's azimuth in the body's x-y plane
    cb, sb = math.cos(yb), math.sin(yb)
    L = np.array([[cb, sb, 0.0], [-sb, cb, 0.0], [0.0, 0.0, 1.0]]) @ levelling(R)
    psi = headings(R)
    idx = np.clip(np.searchsorted(imu.t, st), 0, imu.t.size - 1)
    heading = np.interp(st, imu.t, psi)
    frame_yaw = float(heading[0]) + yb
    heading = heading - heading[0]
    K = st.size
    out = LevelledRecording(st, [], np.full((K, 3), np.nan), np.full((K, 3, 3), np.nan), np.zeros(K, bool),
                            np.zeros(K, bool), np.zeros(K), heading, np.zeros(K, int), np.zeros(K, int),
                            np.zeros(K, int), np.zeros(K, int), bias, R, frame_yaw, yb, imu, notes)
    gate = math.radians(s.elevation_gate_deg)
    for k, ((a, b), e, mv) in enumerate(zip(spans, fits, moving)):
        Lk = L[idx[k]]
        w = np.array([np.interp(st[k], imu.t, imu.gyro[:, i]) for i in range(3)]) - bias
        ego = None
        if e.valid:
            vb = Rm @ e.v - np.cross(w, lever)                      # c.10.1, at the platform origin
            Cb = Rm @ e.cov @ Rm.T
            out.v[k], out.cov[k] = Lk @ vb, Lk @ Cb @ Lk.T
            out.valid[k], out.at_rest[k] = True, e.at_rest
            ego = EgoVelocity(out.v[k, :2].copy(), out.cov[k, :2, :2].copy(), e.inliers, e.sigma_mps, e.zero_stat,
                              e.at_rest, True)
        pl = (ps[a:b] @ Rm.T + lever) @ Lk.T                        # levelled platform frame
        horiz = np.hypot(pl[:, 0], pl[:, 1])
        keep = (~mv & (np.abs(np.arctan2(pl[:, 2], horiz)) <= gate) & (pl[:, 2] >= s.height_min_m)
                & (pl[:, 2] <= s.height_max_m))
        out.n_detections[k], out.n_inliers[k] = b - a, e.n_inliers
        out.n_moving[k], out.n_kept[k] = int(mv.sum()), int(keep.sum())
        polar = np.column_stack([horiz[keep], np.arctan2(pl[keep, 1], pl[keep, 0])])
        channels = {n: v[a:b][keep] for n, v in ch.items() if n != "z_m"}
        channels["z_m"] = pl[keep, 2]
        if k:
            dt = st[k] - st[k - 1]
            out.yaw_rate[k] = (heading[k] - heading[k - 1]) / dt
            out.events.append(Odometry(float(st[k]), float(dt), np.array([0.0, out.yaw_rate[k]]),
                                       gyro_rad_s=float(out.yaw_rate[k])))
        out.events.append(Scan(float(st[k]), k + 1, polar, channels, ego))
    return out


def run_radar_alone(rec, imu: Imu, config: Config, *, on_scan=None, first_run=None):
    """Level ``rec`` and run :class:`~radarslam.slam.EkfSlam` over it by ``first_run``'s engine (a
    :class:`~radarslam.compiling.policy.Plan`, as a recording's run): ``(RecordingRun, LevelledRecording)``."""
    from radarslam.runs.recording import RecordingRun, _run_filter
    from radarslam.core.mounting import Mounting

    config = check_radar_alone_config(config)
    lev = level_recording(rec, imu, config, np.random.default_rng(0))
    record, _ = _run_filter(config, lev.events, on_scan, first_run)
    metrics = {"scans": int(lev.t.size), "detections": int(lev.n_detections.sum()),
               "detections_moving": int(lev.n_moving.sum()), "detections_kept": int(lev.n_kept.sum()),
               "associated": int(record.n_associated.sum()), "landmarks_final": int(record.n_landmarks[-1]),
               "filter_seconds": record.seconds}
    run = RecordingRun(dataclasses.replace(config), rec, Mounting(source="config [sensor], 3-D"), lev.events, lev.t,
                       record, None, metrics)
    return run, lev
