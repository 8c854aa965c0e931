"""Doppler odometry from the whole rig (docs/method.md c.12, c.10.5): each scan carries the joint fit
of every radar's static detections about its time as its ``Scan.ego``, so that ``filter.odometry =
"doppler"`` with ``filter.yaw_rate = "gyro"`` predicts with the rig's velocity at the rear axle and
the gyro's yaw rate, instead of the velocity of the one radar that made the scan. The velocity is the
fit's given the gyro's yaw rate (the Gaussian conditional, c.12.7), not its marginal, and a fit the
consistency gates flag (c.12.7) is no reading: the scan carries an invalid ``ego`` and the last valid
velocity is held.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from radarslam.core.mounting import Mounting
from radarslam.core.types import Scan
from radarslam.egomotion.rig import Rig, checked_rig_velocity, filter_series
from radarslam.models.doppler import EgoVelocity
from radarslam.models.rig_gates import velocity_given_yaw_rate

#: A fit held as valid (models.rig_velocity status 0).
OK = 0


def rig_of(rec, mounting: Mounting | None = None) -> Rig | None:
    """The recording as a :class:`Rig` (time order; zero-range detections, a driver's invalid
    returns, left out as the stream leaves them), or None without ``doppler_mps`` or detections: its
    sensors (``rec.sensors``), else ``mounting`` as sensor 0, else None (no rig). The one
    conversion, for the Doppler odometry, the online clock and the run's ``ego_velocity.csv``."""
    d = rec.channels.get("doppler_mps")
    sensors = rec.sensors or ({0: mounting} if mounting is not None else None)
    if d is None or not sensors or rec.det_t.size == 0:
        return None
    ids = np.array(sorted(sensors), dtype=np.int64)
    sid = rec.channels.get("sensor_id")
    sid = np.full(rec.det_t.size, ids[0]) if sid is None else sid.astype(np.int64)
    keep = rec.det_polar[:, 0] > 0.0
    order = np.flatnonzero(keep)[np.argsort(rec.det_t[keep], kind="stable")]
    mount = Mounting.stack(sensors[k] for k in ids.tolist())
    odo = np.column_stack([rec.odo_t, rec.odo]) if rec.odo_kind == "unicycle" and rec.odo_t.size >= 2 else None
    return Rig(rec.det_t[order], rec.det_polar[order, 0], rec.det_polar[order, 1], d[order],
               np.searchsorted(ids, sid[order]), ids, [sensors[k].name or str(k) for k in ids.tolist()], mount, odo,
               None if rec.labels is None else rec.labels[order])


def with_rig_velocity(events: list, rec, config, fit=None) -> list:
    """``events`` with every scan's ``ego`` the rig's fit at its time (module docstring) under
    ``filter.odometry`` "doppler" or "both" (the wheel speed fused with it, c.10.5) and
    ``filter.yaw_rate`` "gyro" on a rig with Doppler: ``(v_x, v_y)``; under the radar alone
    (``yaw_rate`` "doppler") on a rig with two distinct lever arms, the whole ``(v_x, v_y, omega)``
    (c.12.2); else ``events``. ``fit`` ``(rig, series)``: the recording's rig and its
    :func:`~radarslam.egomotion.rig.checked_rig_velocity` when the caller has them already (the run's
    ``ego_velocity.csv`` is the same fit: one fit of 1 M detections, not two)."""
    f = config.filter
    alone = f.odometry == "doppler" and f.yaw_rate == "doppler"     # c.10.5.1: the rig's omega, not the gyro's
    wanted = f.odometry in ("doppler", "both") and f.yaw_rate == "gyro" or alone
    rig = None if not wanted else fit[0] if fit is not None else rig_of(rec)
    if rig is None:
        return events
    from radarslam.slam.odometry_source import distinct_lever_arms

    if alone and not distinct_lever_arms(rec.sensors.values()):
        return events                         # one lever arm: each scan's own no-sideslip fit (c.10.5.1)
    n = 3 if alone else 2
    # the full model's fits (c.12.7: given the gyro, the lateral velocities measure the sideslip themselves)
    series = filter_series(fit[1] if fit is not None else checked_rig_velocity(rig, f))
    gyro_var = math.radians(f.gyro_std_deg_s) ** 2
    cov = series.white_cov()               # c.12.7: neighbouring fits share detections, the filter's readings not
    out = []
    for e in events:
        if isinstance(e, Scan):
            k = min(int(np.searchsorted(series.t, e.t)), series.t.size - 1)
            if abs(series.t[k] - e.t) > 1e-6 and k > 0 and abs(series.t[k - 1] - e.t) < abs(series.t[k] - e.t):
                k -= 1
            ok = series.status[k] == OK and np.all(np.isfinite(series.theta[k]))
            v, C = np.zeros(n), np.eye(n)
            if ok and alone:                  # the radar alone: the rig's whole (v_x, v_y, omega) (c.12.2)
                v, C = series.theta[k, :3].copy(), cov[k, :3, :3].copy()
            elif ok and rig.odometry is not None:
                # c.12.7: the prediction turns at the gyro's rate, so the velocity is the fit's given it
                g = float(np.interp(series.t[k], rig.odometry[:, 0], rig.odometry[:, 2]))
                v, C = velocity_given_yaw_rate(series.theta[k], cov[k], g, gyro_var)
            elif ok:
                v, C = series.theta[k, :2].copy(), cov[k, :2, :2].copy()
            ego = EgoVelocity(v, C, np.zeros(0, dtype=bool), float(series.sigma_mps[k]) if ok else float("nan"), 0.0,
                              False, bool(ok))
            e = dataclasses.replace(e, ego=ego)
        out.append(e)
    return out
