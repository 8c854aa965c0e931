"""A small recording generator: a car at constant speed and turn rate past point reflectors, seen by
one or several mounted radars, with exact odometry and a truth (docs/recordings.md
"Checking a recording's handling").

It writes what a real recording holds -- detections in each SENSOR's frame at each radar's own scan
times, odometry rows at their own stamps, the truth at its own rate -- so that timing, mounting and
frame handling can be checked against a known answer. The motion is exact (circular arcs), the
odometry exact, the radar noise (when asked for) drawn about the sensor.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.mounting import Mounting, detections_to_sensor
from radarslam.io.recording.stream import Recording


def arc_poses(t: np.ndarray, speed: float, turn_rate: float, start=(0.0, 0.0, 0.0)) -> np.ndarray:
    """Poses ``(K, 3)`` at times ``t`` of a platform moving at ``speed`` (m/s) and ``turn_rate`` (rad/s)
    from ``start`` at ``t = 0`` (exact: a circular arc, a straight line at zero turn rate)."""
    x0, y0, th0 = start
    th = th0 + turn_rate * t
    if turn_rate == 0.0:
        return np.column_stack([x0 + speed * t * math.cos(th0), y0 + speed * t * math.sin(th0), th])
    r = speed / turn_rate
    return np.column_stack([x0 + r * (np.sin(th) - math.sin(th0)), y0 - r * (np.cos(th) - math.cos(th0)), th])


def reflectors_along(poses: np.ndarray, spacing_m: float, lateral_m: float) -> np.ndarray:
    """Point reflectors ``(n, 2)`` every ``spacing_m`` of path, at ``lateral_m`` on either side of it."""
    d = np.r_[0.0, np.cumsum(np.hypot(*np.diff(poses[:, :2], axis=0).T))]
    at = np.arange(0.0, d[-1], spacing_m)
    x, y = np.interp(at, d, poses[:, 0]), np.interp(at, d, poses[:, 1])
    th = np.interp(at, d, poses[:, 2])
    nx, ny = -np.sin(th), np.cos(th)
    return np.concatenate([np.column_stack([x + side * lateral_m * nx, y + side * lateral_m * ny])
                           for side in (1.0, -1.0)])


def synthetic_recording(*, duration_s: float = 10.0, speed_mps: float = 10.0, turn_rate_rad_s: float = 0.0,
                        scan_hz: float = 10.0, odo_hz: float = 10.0, odo_delay_s: float = 0.0,
                        sensors: dict[int, Mounting] | None = None, sensor_delays_s: dict[int, float] | None = None,
                        spacing_m: float = 8.0, lateral_m: float = 7.0, returns: int = 3,
                        max_range_m: float = 25.0, fov_rad: float = 2 * math.pi, range_std_m: float = 0.0,
                        azimuth_std_rad: float = 0.0, truth_hz: float = 50.0,
                        ackermann: tuple[float, float] | None = None,
                        rng: np.random.Generator | None = None) -> Recording:
    """A recording of ``duration_s`` seconds (see the module's docstring).

    Parameters
    ----------
    scan_hz, odo_hz, truth_hz : float
        Each radar's scan rate, the odometry's and the truth's rates (Hz).
    odo_delay_s : float
        The odometry's stamps lie this much after a multiple of its period (scans at multiples of
        theirs); its rows start one period before the first scan, so they cover every scan.
    sensors : dict of int to Mounting, or None
        The rig (None: one radar at the platform origin, no ``sensors`` in the recording).
    sensor_delays_s : dict of int to float, or None
        Each sensor's scan times lie this much after the multiples of ``1 / scan_hz`` (default 0).
    returns : int
        Detections of each reflector in view per scan (the filter's clustering needs two to make a
        landmark), each with its own noise.
    range_std_m, azimuth_std_rad : float
        Radar noise drawn about the sensor (``rng`` required when non-zero).
    ackermann : (L, H) or None
        Odometry of the ``ackermann`` model instead (models/ackermann.py: the rear-left wheel's speed
        ``v - omega H`` and the steering ``atan(omega L / v)`` of wheelbase ``L``); the truth stays the
        rear axle's.
    """
    rig = sensors or {0: Mounting()}
    delays = sensor_delays_s or {}
    t_truth = np.arange(math.ceil(duration_s * truth_hz) + 2) / truth_hz
    truth = arc_poses(t_truth, speed_mps, turn_rate_rad_s)
    dense = arc_poses(np.linspace(-2.0, duration_s + 2.0, 2000), speed_mps, turn_rate_rad_s)
    refl = np.repeat(reflectors_along(dense, spacing_m, lateral_m), returns, axis=0)
    det_t, det_polar, det_sid, scan_t = [], [], [], []
    for sid, m in sorted(rig.items()):
        for ts in np.arange(math.ceil((duration_s - delays.get(sid, 0.0)) * scan_hz)) / scan_hz + delays.get(sid, 0.0):
            pose = arc_poses(np.array([ts]), speed_mps, turn_rate_rad_s)[0]
            c, s = math.cos(pose[2]), math.sin(pose[2])
            dx, dy = refl[:, 0] - pose[0], refl[:, 1] - pose[1]
            local = np.column_stack([c * dx + s * dy, -s * dx + c * dy])          # platform frame
            polar = detections_to_sensor(np.column_stack([np.hypot(*local.T), np.arctan2(local[:, 1], local[:, 0])]), m)
            keep = (polar[:, 0] <= max_range_m) & (np.abs(polar[:, 1]) <= fov_rad / 2)
            polar = polar[keep]
            if range_std_m or azimuth_std_rad:
                polar = polar + rng.normal(size=polar.shape) * [range_std_m, azimuth_std_rad]
            det_t.append(np.full(polar.shape[0], ts))
            det_polar.append(polar)
            det_sid.append(np.full(polar.shape[0], float(sid)))
            scan_t.append(ts)
    t = np.concatenate(det_t)
    order = np.argsort(t, kind="stable")
    odo_t = (np.arange(math.ceil(duration_s * odo_hz) + 2) - 1) / odo_hz + odo_delay_s   # k / rate: exact multiples
    row = [speed_mps, turn_rate_rad_s]
    if ackermann is not None:
        L, H = ackermann
        row = [speed_mps - turn_rate_rad_s * H, math.atan2(turn_rate_rad_s * L, speed_mps)]
    odo = np.tile(row, (odo_t.size, 1))
    return Recording(t[order], np.concatenate(det_polar)[order],
                     {"sensor_id": np.concatenate(det_sid)[order]} if sensors else {}, odo_t, odo,
                     "unicycle" if ackermann is None else "ackermann",
                     t_truth, truth, source="synthetic", scan_t=np.unique(scan_t),
                     sensors=dict(sensors) if sensors else None)
