"""Is a recording's Doppler column the raw radial velocity? (docs/recordings.md "Doppler")

The static world's Doppler is ``d = -u . w`` (c.10.1): ``w`` the radar's own velocity in its frame,
``u`` the detection's direction, positive receding. A column stored with the other sign
(approaching positive) gives ``w`` reversed; an ego-compensated column (nuScenes ``vx_comp`` /
``vy_comp``, RadarScenes ``vr_compensated``, View-of-Delft ``v_r_compensated``) has the radar's own
motion removed, so the static world reads about 0 and ``w`` about 0. Neither is visible to the
filter (the consensus of c.10.2 is found either way), so the column is checked against the
odometry: each sweep's static consensus (the RANSAC fit of ``w``, c.10.2-c.10.3) is moved to the
rear axle with the odometry's yaw rate, ``v = (R(yaw_m) w)_x + omega l_y`` (c.10.5), and compared
with the odometry's speed over the sweeps in which the car moves. The median ratio ``v / v_odo`` is
about +1 for a raw column, -1 for a negated one and 0 for a compensated one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError

__all__ = ["DopplerConsensus", "MIN_MOVING_SWEEPS", "MOVING_MPS", "check_doppler_column", "doppler_consensus",
           "with_doppler_scale", "with_doppler_sign"]

#: A sweep counts as moving when the odometry's speed there is above this (m/s): at 2 m/s a raw
#: column's consensus is 2 m/s, 20 times the nuScenes fit's 0.1 m/s scatter (c.12.6).
MOVING_MPS = 2.0
#: The check needs this many moving sweeps with a consensus; fewer (a car at rest) and it says nothing.
MIN_MOVING_SWEEPS = 10
#: A sweep needs this many detections for its fit (RANSAC's minimal set is 2; c.10.3 wants 4 in 2-D).
MIN_DETECTIONS = 6
#: A detection this far (m/s) from its sweep's first fit is a road user's, left out of the second.
OUTLIER_MPS = 1.0


@dataclass(frozen=True)
class DopplerConsensus:
    """The static Doppler consensus against the odometry over the moving sweeps.

    Attributes
    ----------
    sweeps : int
        Moving sweeps with a valid consensus.
    doppler_mps, odometry_mps : float
        Median forward speed at the rear axle from the consensus and from the odometry (m/s).
    ratio : float
        Median over those sweeps of the two speeds' ratio (+1 raw, -1 negated, 0 compensated).
    """

    sweeps: int
    doppler_mps: float
    odometry_mps: float
    ratio: float

    @property
    def verdict(self) -> str:
        """"raw", "negated" or "compensated" (the nearest of +1, -1, 0), or "unknown" (too few sweeps)."""
        if self.sweeps < MIN_MOVING_SWEEPS:
            return "unknown"
        return "negated" if self.ratio <= -0.5 else "compensated" if self.ratio < 0.5 else "raw"


def with_doppler_sign(rec, sign: int):
    """``rec`` with ``channels['doppler_mps']`` multiplied by ``sign`` (``[sensor] doppler_sign``:
    -1 for a column stored approaching-positive); ``rec`` itself for +1 or without the column."""
    import dataclasses

    if sign not in (1, -1):
        raise InputError(f"sensor.doppler_sign: expected 1 or -1, got {sign!r}")
    d = rec.channels.get("doppler_mps")
    if sign == 1 or d is None:
        return rec
    return dataclasses.replace(rec, channels={**rec.channels, "doppler_mps": -np.asarray(d, dtype=float)})


def with_doppler_scale(rec, scale: float):
    """``rec`` with ``channels['doppler_mps']`` divided by ``scale`` (``[sensor] doppler_scale``, what the
    column reads of the radial speed, docs/method.md c.16.5); ``rec`` itself for 1 or without the column."""
    import dataclasses

    if not (math.isfinite(scale) and scale > 0):
        raise InputError(f"sensor.doppler_scale: expected a finite number > 0, got {scale!r}")
    d = rec.channels.get("doppler_mps")
    if scale == 1.0 or d is None:
        return rec
    return dataclasses.replace(rec, channels={**rec.channels, "doppler_mps": np.asarray(d, dtype=float) / scale})


def doppler_consensus(rec, mounting, rng: np.random.Generator | None = None) -> DopplerConsensus:
    """The sweeps' static consensus against the odometry (module docstring). A sweep is the rows of
    one ``(t_s, sensor_id)``; its mounting is its sensor's (``rec.sensors``), else ``mounting``
    (the single radar's: a :class:`~radarslam.core.mounting.Mounting`). Needs a unicycle
    odometry (``speed_mps, yaw_rate_rad_s``).

    Each sweep's sensor velocity is the least-squares fit of ``d = -u . w`` to its detections, once
    more without the detections farther than :data:`OUTLIER_MPS` from the first fit (the road users:
    a check of the column's sign and scale needs no RANSAC, and plain numpy compiles nothing, so a
    first run on a machine does not wait for it); the consensus is the median over the sweeps.
    ``rng`` is not used (kept for callers of the RANSAC version)."""
    d = np.asarray(rec.channels["doppler_mps"], dtype=float)
    sid = rec.channels.get("sensor_id")
    sid = np.zeros(d.size, dtype=np.int64) if sid is None else np.asarray(sid).astype(np.int64)
    t = np.asarray(rec.det_t, dtype=float)
    ok = (rec.det_polar[:, 0] > 0) & np.isfinite(d)                  # zero ranges: invalid returns
    rows = np.flatnonzero(ok)
    _, first, sweep = np.unique(np.column_stack([t, sid])[ok], axis=0, return_index=True, return_inverse=True)
    sweep = sweep.reshape(-1)
    S = first.size
    az = rec.det_polar[rows, 1]
    ax, ay, dd = -np.cos(az), -np.sin(az), d[rows]
    keep = np.ones(rows.size, dtype=bool)
    for _ in range(2):                                              # the fit, then again without the outliers
        k = keep.astype(float)
        s = lambda v: np.bincount(sweep, weights=v * k, minlength=S)
        sxx, sxy, syy, sxd, syd, n = s(ax * ax), s(ax * ay), s(ay * ay), s(ax * dd), s(ay * dd), s(np.ones_like(dd))
        det = sxx * syy - sxy * sxy
        good = (n >= MIN_DETECTIONS) & (det > 1e-9 * np.maximum(n * n, 1.0))
        with np.errstate(invalid="ignore", divide="ignore"):
            wx = np.where(good, (syy * sxd - sxy * syd) / det, np.nan)
            wy = np.where(good, (sxx * syd - sxy * sxd) / det, np.nan)
        r = dd - (ax * wx[sweep] + ay * wy[sweep])
        keep = np.abs(np.nan_to_num(r, nan=np.inf)) <= OUTLIER_MPS
    t0 = t[rows[first]]
    speed = np.interp(t0, rec.odo_t, rec.odo[:, 0])
    omega = np.interp(t0, rec.odo_t, rec.odo[:, 1])
    inside = (t0 >= rec.odo_t[0]) & (t0 <= rec.odo_t[-1]) & good & (np.abs(speed) > MOVING_MPS)
    v_fit, v_odo = [], []
    for j in np.flatnonzero(inside):
        m = rec.sensors.get(int(sid[rows[first[j]]])) if rec.sensors else mounting
        if m is None:
            continue
        c, sn = math.cos(m.yaw), math.sin(m.yaw)
        v_fit.append(c * wx[j] - sn * wy[j] + omega[j] * m.y)                  # c.10.5: w' = R w, v = w'_x + omega l_y
        v_odo.append(speed[j])
    if not v_fit:
        return DopplerConsensus(0, math.nan, math.nan, math.nan)
    v_fit, v_odo = np.array(v_fit), np.array(v_odo)
    return DopplerConsensus(int(v_fit.size), float(np.median(v_fit)), float(np.median(v_odo)),
                            float(np.median(v_fit / v_odo)))


def check_doppler_column(rec, mounting, where: str = "detections.csv") -> DopplerConsensus:
    """Refuse (:class:`InputError`, one line) a Doppler column that looks negated or ego-compensated
    against the odometry (module docstring); the consensus otherwise (also when it cannot tell:
    no odometry speed, or the car moving in fewer than :data:`MIN_MOVING_SWEEPS` sweeps)."""
    if rec.channels.get("doppler_mps") is None or rec.odo_kind != "unicycle" or rec.odo_t.size < 2:
        return DopplerConsensus(0, math.nan, math.nan, math.nan)
    cons = doppler_consensus(rec, mounting)
    found = (f"the static Doppler consensus gives {cons.doppler_mps:+.1f} m/s where the odometry says "
             f"{cons.odometry_mps:+.1f} m/s ({cons.sweeps} moving scans)")
    if cons.verdict == "negated":
        raise InputError(f"{where}: doppler_mps looks negated: {found}; set [sensor] doppler_sign = -1 or pass "
                         f"--doppler-sign -1")
    if cons.verdict == "compensated":
        raise InputError(f"{where}: doppler_mps looks ego-compensated (the radar's own motion removed, as "
                         f"nuScenes vx_comp/vy_comp, RadarScenes vr_compensated, View-of-Delft v_r_compensated): "
                         f"{found}; expected the raw radial velocity (nuScenes vx/vy projected on the line of "
                         f"sight, RadarScenes vr, View-of-Delft v_r)")
    return cons
