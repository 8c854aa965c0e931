"""Ego-motion of a multi-radar recording from its Doppler (docs/method.md c.12.4): read a plain
recording with ``sensors.csv``, fit ``(v_x, v_y, omega)`` in a window about every sweep, compare it
with the recording's odometry, write ``ego_velocity.csv``.
"""

from __future__ import annotations

import csv
import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting
from radarslam.models.rig_gates import gate_rig_velocity
from radarslam.models.rig_velocity import (
    DEFAULTS,
    STATUS_WORDS,
    RigVelocitySeries,
    fit_rig_windows,
    rig_design,
    rig_design_yaw,
)

__all__ = [
    "EGO_VELOCITY_COLUMNS",
    "Rig",
    "RigEgoMotion",
    "checked_rig_velocity",
    "compare_with_odometry",
    "filter_series",
    "read_rig",
    "rig_ego_motion",
    "rig_ego_velocity",
    "write_ego_velocity_csv",
]


@dataclass(frozen=True)
class Rig:
    """A multi-radar recording as arrays (detections in time order).

    Attributes
    ----------
    t, range_m, azimuth, doppler : ndarray, shape (n,)
        Each detection's time (s), range (m), azimuth in its sensor's frame (rad), radial velocity (m/s).
    sensor : ndarray of int, shape (n,)
        Row of ``mount`` (not the ``sensor_id``) of each detection's sensor.
    sensor_ids : ndarray of int, shape (S,)
    names : list of str
    mount : ndarray, shape (S, 3)
        ``(x m, y m, yaw rad)`` of each sensor in the vehicle frame: the rows
        :meth:`~radarslam.core.mounting.Mounting.stack` of its mountings.
    odometry : ndarray, shape (T, 3) or None
        ``t_s, speed_mps, yaw_rate_rad_s``.
    label : ndarray of int, shape (n,) or None
    """

    t: np.ndarray
    range_m: np.ndarray
    azimuth: np.ndarray
    doppler: np.ndarray
    sensor: np.ndarray
    sensor_ids: np.ndarray
    names: list
    mount: np.ndarray
    odometry: np.ndarray | None = None
    label: np.ndarray | None = None

    def design(self, lateral: bool = True, mount: np.ndarray | None = None) -> np.ndarray:
        """Design rows (:func:`~radarslam.models.rig_velocity.rig_design`) with ``mount`` (default the rig's)."""
        m = self.mount if mount is None else mount
        return rig_design(self.azimuth, m[self.sensor, 0], m[self.sensor, 1], m[self.sensor, 2], lateral)


def _table(path: Path, need: tuple[str, ...]) -> dict[str, np.ndarray]:
    """A numeric CSV table by column (numpy's reader: a million rows in about a second)."""
    try:
        with path.open(encoding="utf-8") as fh:
            head = [h.strip() for h in fh.readline().split(",")]
    except OSError as exc:
        raise InputError(f"{path}: cannot read ({exc.strerror})") from None
    missing = [c for c in need if c not in head]
    if missing:
        raise InputError(f"{path}: missing column(s) {', '.join(missing)}, got {', '.join(head)}")
    try:
        a = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise InputError(f"{path}: expected numbers in every column, got {exc}") from None
    if a.shape[1] != len(head) or not np.all(np.isfinite(a)):
        raise InputError(f"{path}: expected {len(head)} finite numbers a line, got a malformed or non-finite value")
    return {h: a[:, j] for j, h in enumerate(head)}


def read_rig(path: str | Path, sensors: dict | None = None, origin: str = "sensors.csv") -> Rig:
    """Read a plain recording directory with ``sensors.csv`` (docs/recordings.md) as a :class:`Rig`;
    ``sensors`` (``dict[int, Mounting]``, e.g. ``--sensors FILE`` or the config's ``[[sensors]]``, named
    by ``origin``) takes the place of that file."""
    path = Path(path)
    if not (path / "detections.csv").is_file() or (sensors is None and not (path / "sensors.csv").is_file()):
        raise InputError(f"--recording {path}: expected a directory with detections.csv and sensors.csv")
    det = _table(path / "detections.csv", ("t_s", "range_m", "azimuth_rad", "doppler_mps", "sensor_id"))
    if sensors is not None:
        rows = [{"name": sensors[k].name} for k in sorted(sensors)]
        ids = np.array(sorted(sensors), dtype=np.int64)
        mount = Mounting.stack(sensors[k] for k in sorted(sensors))
    else:
        with (path / "sensors.csv").open(newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
        try:
            ids = np.array([int(r["sensor_id"]) for r in rows])
            mount = Mounting.stack(Mounting(float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"])) for r in rows)
        except (KeyError, ValueError, TypeError) as exc:
            raise InputError(f"{path / 'sensors.csv'}: expected sensor_id, x_m, y_m, yaw_rad numbers, "
                             f"got {exc}") from None
    if ids.size == 0 or np.unique(ids).size != ids.size or not np.all(np.isfinite(mount)):
        raise InputError(f"{path / 'sensors.csv'}: expected one finite row per sensor, got ids {ids.tolist()}")
    names = [r.get("name") or str(i) for r, i in zip(rows, ids)]
    sid = det["sensor_id"].astype(np.int64)
    lookup = {int(k): j for j, k in enumerate(ids)}
    unknown = np.setdiff1d(np.unique(sid), ids)
    if unknown.size:
        raise InputError(f"{path / 'detections.csv'}: sensor_id {int(unknown[0])} not in {origin} "
                         f"({', '.join(map(str, ids))})")
    sensor = np.vectorize(lookup.get, otypes=[np.int64])(sid) if sid.size else sid
    order = np.argsort(det["t_s"], kind="stable")
    odo = None
    if (path / "odometry.csv").is_file():
        o = _table(path / "odometry.csv", ("t_s", "speed_mps", "yaw_rate_rad_s"))
        odo = np.column_stack([o["t_s"], o["speed_mps"], o["yaw_rate_rad_s"]])
    lab = det.get("label")
    return Rig(det["t_s"][order], det["range_m"][order], det["azimuth_rad"][order], det["doppler_mps"][order],
               sensor[order], ids, names, mount, odo, None if lab is None else lab[order].astype(np.int64))


#: The systematic terms' priors (docs/method.md c.12.3 step 5b), stated before any measurement on the
#: recordings they are used on: each radar's mounting yaw as a dataset gives it is off by up to about
#: 0.5 deg (the smallest offset an independent review found on nuScenes' given mountings, 0.5-1.3 deg; one
#: sigma), and the radars' clock against the vehicle's by up to 50 ms (the review's nuScenes offsets,
#: 0-45 ms, rounded up; one sigma).
MOUNT_YAW_STD_DEG = 0.5
TIME_OFFSET_STD_S = 0.05
#: The consistency gates (c.12.7): each gate's chi-square probability, and how fast a car's motion can
#: change between two fits (1 sigma: 3 m/s^2 along, 1 m/s^2 across, 1 rad/s^2 of yaw; a car brakes at up
#: to ~9 m/s^2 and a lane change reaches ~0.5 rad/s^2).
GATE_PROBABILITY = 0.999
ACCEL_STD = (3.0, 1.0, 1.0)
#: How fast the fit's disagreement with the gyro may wander (rad/s^2, 1 sigma): a clock offset of 50 ms
#: (TIME_OFFSET_STD_S) against a yaw acceleration of 1 rad/s^2 (ACCEL_STD) is 0.05 rad/s of it.
OFFSET_RATE_STD = 0.05


def rig_ego_velocity(rig: Rig, rng: np.random.Generator, *, lateral: bool = True, half_window_s: float = 0.04,
                     mount: np.ndarray | None = None, systematic: bool = True, **options) -> RigVelocitySeries:
    """``(v_x, v_y, omega)`` at every sweep's time from every radar's detections within
    ``+-half_window_s`` (c.12.4); ``lateral`` False: the no-sideslip model (``v_y = 0``). With
    ``systematic`` the covariance carries the mounting-yaw and timing terms of c.12.3 step 5b at
    :data:`MOUNT_YAW_STD_DEG` and :data:`TIME_OFFSET_STD_S` (``options`` may state others)."""
    opts = {k: v for k, v in DEFAULTS.items() if k not in options} | options
    m = rig.mount if mount is None else mount
    if systematic:
        opts.setdefault("mount_yaw_std_rad", math.radians(MOUNT_YAW_STD_DEG))
        opts.setdefault("time_offset_std_s", TIME_OFFSET_STD_S)
        opts["sensor"] = rig.sensor
        opts["dA_dyaw"] = rig_design_yaw(rig.azimuth, m[rig.sensor, 0], m[rig.sensor, 1], m[rig.sensor, 2], lateral)
    return fit_rig_windows(rig.t, rig.design(lateral, mount), rig.doppler, np.unique(rig.t), rng,
                           half_window_s=half_window_s, **opts)


@dataclass(frozen=True)
class RigEgoMotion(RigVelocitySeries):
    """The rig's ego-motion as a run writes it (``ego_velocity.csv``): the fits of the model the rig's
    geometry observes (:func:`rig_ego_motion`), with the full-model fits the filter takes beside them.

    Attributes
    ----------
    full : RigVelocitySeries or None
        The full model's ``(v_x, v_y, omega)`` fits with the same statuses: what the Doppler odometry
        takes (given the gyro, c.12.7, the lateral velocities measure the sideslip themselves).
    model : str
        ``"v_x, v_y, omega"`` or ``"single-track"`` (``v_y = -D v_x^2 omega``,
        :mod:`radarslam.egomotion.single_track`).
    compliance : (float, float) or None
        The single-track model's ``(D, std)`` (rad of rear-axle sideslip per m/s^2 of lateral
        acceleration), None under the full model.
    yaw_rate_vif : float
        The full model's median variance inflation factor of ``omega`` (:func:`~radarslam.egomotion.
        single_track.yaw_rate_vif`), which chose the model.
    """

    full: RigVelocitySeries | None = None
    model: str = "v_x, v_y, omega"
    compliance: tuple[float, float] | None = None
    yaw_rate_vif: float = math.nan


def _fields(series: RigVelocitySeries) -> dict:
    return {f.name: getattr(series, f.name) for f in dataclasses.fields(RigVelocitySeries)}


def rig_ego_motion(series: RigVelocitySeries) -> RigEgoMotion:
    """The model a rig's geometry observes, from its full-model fits ``series`` (docs/method.md c.12.2):
    where freeing ``v_y`` inflates the variance of ``omega`` by more than
    :data:`~radarslam.egomotion.single_track.VIF_LIMIT` (the radars share one ``x``: ``omega`` would
    rest on the difference of their forward velocities over a lateral lever arm of 1.4-1.75 m, where a
    0.1% disagreement between two radars' Doppler is 0.6 deg/s at 18 m/s), the single-track model with
    the rear axle's cornering compliance fitted to the same Doppler (:func:`~radarslam.egomotion.
    single_track.cornering_compliance`, :func:`~radarslam.egomotion.single_track.single_track_velocity`);
    otherwise the full model as it is. Either way ``full`` keeps ``series``."""
    from radarslam.egomotion.single_track import (
        VIF_LIMIT,
        cornering_compliance,
        single_track_velocity,
        yaw_rate_vif,
    )

    vif = yaw_rate_vif(series)
    if not vif > VIF_LIMIT:
        return RigEgoMotion(**_fields(series), full=series, yaw_rate_vif=vif)
    D, D_std = cornering_compliance(series)
    st = single_track_velocity(series, D, D_std)
    return RigEgoMotion(**_fields(st), full=series, model="single-track", compliance=(D, D_std), yaw_rate_vif=vif)


def filter_series(series: RigVelocitySeries) -> RigVelocitySeries:
    """The fits the filter and the online clock take from :func:`checked_rig_velocity`'s ``series``:
    its ``full`` model's when it has one (:class:`RigEgoMotion`), else ``series`` itself."""
    full = getattr(series, "full", None)
    return series if full is None else full


def checked_rig_velocity(rig: Rig, filter_config, rng: np.random.Generator | None = None, *,
                         lateral: bool = True) -> RigVelocitySeries:
    """The rig's fit as a recording run takes it (c.12.4, c.12.7): the Doppler's floor from the
    configuration (``filter.doppler_std_floor_mps``; 0, "none stated", keeps the fit's quantisation
    floor of c.12.3), the systematic terms, and the fits that disagree with the odometry's yaw rate
    (the gyro, ``filter.gyro_std_deg_s``) or with the previous sweeps flagged (:func:`~radarslam.models.
    rig_gates.gate_rig_velocity` at :data:`GATE_PROBABILITY`). With ``lateral`` the result is a
    :class:`RigEgoMotion` (:func:`rig_ego_motion`: the model the rig's geometry observes, the full fits
    beside it for the filter, :func:`filter_series`). Seed 0 unless ``rng``."""
    floor = float(filter_config.doppler_std_floor_mps)
    opts = {"sigma_floor_mps": floor} if floor > 0 else {}
    series = rig_ego_velocity(rig, np.random.default_rng(0) if rng is None else rng, lateral=lateral, **opts)
    odo = rig.odometry
    gt, g = (odo[:, 0], odo[:, 2]) if odo is not None and odo.shape[0] >= 2 else (None, None)
    gated = gate_rig_velocity(series, gt, g, math.radians(filter_config.gyro_std_deg_s),
                              probability=GATE_PROBABILITY, accel_std=ACCEL_STD, offset_rate_std=OFFSET_RATE_STD)
    return rig_ego_motion(gated) if lateral else gated


def compare_with_odometry(series: RigVelocitySeries, odometry: np.ndarray) -> dict:
    """Speed (``v_x`` against ``speed_mps``) and yaw rate against the odometry interpolated at the
    valid fits' times: RMSE, mean and std of the difference (Doppler minus odometry), in m/s and deg/s."""
    ok = series.valid & (series.t >= odometry[0, 0]) & (series.t <= odometry[-1, 0])
    t = series.t[ok]
    dv = series.theta[ok, 0] - np.interp(t, odometry[:, 0], odometry[:, 1])
    dw = np.degrees(series.theta[ok, 2] - np.interp(t, odometry[:, 0], odometry[:, 2]))
    f = lambda e: {"rmse": float(np.sqrt(np.mean(e * e))), "mean": float(np.mean(e)),
                   "std": float(np.std(e))} if e.size else {"rmse": math.nan, "mean": math.nan, "std": math.nan}
    return {"windows": int(series.t.size), "valid": int(ok.sum()), "speed_mps": f(dv), "yaw_rate_deg_s": f(dw)}


#: Columns of ``ego_velocity.csv`` (c.12.4).
EGO_VELOCITY_COLUMNS = ("t_s", "vx_mps", "vy_mps", "yaw_rate_rad_s", "cov_vx_vx", "cov_vx_vy", "cov_vx_wz",
                        "cov_vy_vy", "cov_vy_wz", "cov_wz_wz", "sigma_mps", "n_inliers", "n_used", "status")


def write_ego_velocity_csv(path: str | Path, series: RigVelocitySeries) -> None:
    """``ego_velocity.csv``: one row per window (c.12.4): its centre ``t_s``; the vehicle's velocity at
    the rear axle ``vx_mps`` (forward), ``vy_mps`` (left), ``yaw_rate_rad_s``; the upper triangle of
    its covariance (m^2/s^2, m^2/s^2 ... rad^2/s^2: ``wz`` is the yaw rate); the robust scale of the
    Doppler residuals ``sigma_mps``; ``n_inliers`` detections with a non-zero weight of ``n_used`` in
    the window; ``status`` a word: ok, too-few, no-consensus, rank-deficient (velocity and covariance
    empty), flagged-gyro or flagged-jump (c.12.7: the fit is written but drives nothing)."""
    from radarslam.io.results import atomic_write_text

    iu = np.triu_indices(3)
    lines = [",".join(EGO_VELOCITY_COLUMNS)]
    fmt = lambda v: repr(v) if math.isfinite(v) else ""
    K = series.t.size
    vals = np.column_stack([np.asarray(series.theta, dtype=float).reshape(K, 3),
                            np.asarray(series.cov, dtype=float).reshape(K, 3, 3)[:, iu[0], iu[1]],
                            np.asarray(series.sigma_mps, dtype=float).reshape(K)]).tolist()
    ints = np.column_stack([np.asarray(series.n_inliers).reshape(K),
                            np.asarray(series.n_used).reshape(K)]).astype(np.int64).tolist()
    words = [STATUS_WORDS[int(c)] for c in np.asarray(series.status).reshape(K)]
    for tk, row, last, word in zip(np.asarray(series.t, dtype=float).tolist(), vals, ints, words):
        lines.append(",".join([repr(tk)] + [fmt(v) for v in row] + [str(i) for i in last] + [word]))
    atomic_write_text(path, "\n".join(lines) + "\n")
