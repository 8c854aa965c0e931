"""The car's fixed errors from one drive, by batch least squares on the rig's Doppler (docs/method.md
c.16): the thrust angle, the wheel-speed scale, the gyro's bias, each radar's yaw offset and each
radar's time offset against the odometry; written as one calibration file that a run of another
drive of the same car applies (:func:`apply_calibration`).

The model (c.16.1). At a sweep of radar ``j`` stamped ``t``, the radar measured the car's motion
at ``t + tau_j`` (its stamps early by ``tau_j``). The rear axle moves at
``v = k s(t + tau_j) (1, tan delta)`` (``s`` the wheel speed, ``k`` its scale, ``delta`` the thrust
angle) and the car turns at ``omega = g(t + tau_j) - b`` (``g`` the gyro, ``b`` its bias); radar ``j``
at ``(x_j, y_j)`` moves at ``u_j = v + omega (-y_j, x_j)`` and, its boresight at
``psi_j + eps_j``, sees ``w_j = R(-(psi_j + eps_j)) u_j``. Each sweep's ``w`` is fitted to its static
detections' Doppler (c.12.3); the parameters minimise the sweeps' residuals, each weighted by its
fit's covariance, under a robust loss.

What the Doppler cannot tell apart is one common rotation of every radar from the thrust angle: a
car crabbing at ``delta`` with its radars turned by ``eps`` reads as one straight with its radars
turned by ``eps - delta``. The reference is the rig (``sum_j eps_j = 0``: the radars' mean boresight
error is taken as zero, the mountings as a whole define the car's axis) and the thrust angle is
estimated with it; referenced to the wheels' direction instead (no thrust angle, c.12.5 before),
every radar absorbs ``-delta`` and the calibrated rig can no longer see the car's sideways drift.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from radarslam.egomotion.clock import restamped
from radarslam.core.errors import InputError
from radarslam.egomotion.calibrate import check_calibration_drive
from radarslam.egomotion.calibration_truth import truth_doppler_scale, truth_motion
from radarslam.egomotion.fit_uncertainty import block_jackknife, honest_covariance
from radarslam.egomotion.rig import Rig
from radarslam.egomotion.same_rig import check_same_rig
from radarslam.models.rig_velocity import DEFAULTS, fit_rig_windows

__all__ = ["CarCalibration", "ESTIMATES", "calibrate_car", "read_car_calibration", "write_car_calibration",
           "sweep_velocities"]

#: The quantities :func:`calibrate_car` can estimate; each can be left out (then fixed at its prior).
ESTIMATES = ("thrust_angle", "wheel_scale", "gyro_bias", "yaw_offsets", "time_offsets")
#: The calibration file's format version.
FORMAT = 1
#: Sweeps whose sensor moves slower than this (m/s) carry no direction (c.12.5).
MIN_SPEED_MPS = 2.0
#: A sweep's residual beyond this many of its standard deviations is down-weighted (soft-L1 loss).
ROBUST_SCALE = 3.0


@dataclass(frozen=True)
class CarCalibration:
    """The car's fixed errors (rad, 1, rad/s, s) with their standard deviations; per radar in the
    order of ``sensor_ids``. A default instance is the identity (nothing to correct)."""

    thrust_angle_rad: float = 0.0
    thrust_angle_std: float = 0.0
    wheel_scale: float = 1.0
    wheel_scale_std: float = 0.0
    gyro_bias_rad_s: float = 0.0
    gyro_bias_std: float = 0.0
    sensor_ids: tuple[int, ...] = ()
    yaw_offset_rad: tuple[float, ...] = ()
    yaw_offset_std: tuple[float, ...] = ()
    time_offset_s: tuple[float, ...] = ()
    time_offset_std: tuple[float, ...] = ()
    n_sweeps: int = 0
    residual_rms_before: float = math.nan
    residual_rms_after: float = math.nan
    source: str = ""
    estimated: tuple[str, ...] = field(default_factory=tuple)
    #: What fixes the car's axis: "rig" (the radars' yaw offsets sum to zero) or "truth" (the
    #: calibration drive's reference trajectory, :func:`truth_motion`).
    reference: str = "rig"
    #: Under the truth's reference: the radars' own Doppler scale against the truth's speed; a run with
    #: the calibration divides the Doppler column by it (c.16.3).
    doppler_scale: float = 1.0
    #: The free parameters' names and their covariance (the last radar's yaw offset is minus the sum
    #: of the others'; the wheel scale enters as ``k - 1``).
    parameters: tuple[str, ...] = ()
    covariance: tuple[tuple[float, ...], ...] = ()
    #: Per radar: its moving sweeps used, and the RMS of their velocity residual (m/s) before (the
    #: nominal car) and after the calibration.
    sensor_sweeps: tuple[int, ...] = ()
    sensor_rms_before: tuple[float, ...] = ()
    sensor_rms_after: tuple[float, ...] = ()
    #: The free parameters' values at the solution, in the order of ``parameters`` (the nuisance
    #: ``rotation_scale_minus_1`` of the truth's reference among them: not carried, c.16.2).
    parameter_values: tuple[float, ...] = ()
    #: The rig the calibration was computed on: each radar's nominal ``(x m, y m, yaw rad)`` in the
    #: order of ``sensor_ids``; a recording of another rig is refused (:func:`check_same_rig`).
    mountings: tuple[tuple[float, float, float], ...] = ()

    def per_sensor(self, sensor_id: int) -> tuple[float, float]:
        """``(yaw offset rad, time offset s)`` of ``sensor_id`` (zeros for a radar not calibrated)."""
        if sensor_id in self.sensor_ids:
            j = self.sensor_ids.index(sensor_id)
            return self.yaw_offset_rad[j], self.time_offset_s[j]
        return 0.0, 0.0


@dataclass(frozen=True)
class SweepVelocities:
    """Each sweep's sensor velocity fitted in its nominal frame (c.12.3)."""

    t: np.ndarray          # (K,) stamp (s)
    sensor: np.ndarray     # (K,) row of the rig's mounting
    w: np.ndarray          # (K, 2) the sensor's velocity in its nominal frame (m/s)
    cov: np.ndarray        # (K, 2, 2)
    valid: np.ndarray      # (K,) bool


def sweep_velocities(rig: Rig, rng: np.random.Generator) -> SweepVelocities:
    """The robust fit of every sweep's static Doppler to its sensor's own velocity (c.12.3), one
    window per sweep."""
    order = np.lexsort((rig.t, rig.sensor))                 # sweeps contiguous: by sensor, then time
    t, sen, az, d = rig.t[order], rig.sensor[order], rig.azimuth[order], rig.doppler[order]
    key = np.flatnonzero(np.r_[True, (np.diff(t) != 0) | (np.diff(sen) != 0)])
    hi = np.r_[key[1:], t.size]
    A = np.ascontiguousarray(np.column_stack([-np.cos(az), -np.sin(az)]))
    sweep = np.repeat(np.arange(key.size), hi - key).astype(float)
    fit = fit_rig_windows(sweep, A, d, np.arange(key.size, dtype=float), rng, half_window_s=0.25, **DEFAULTS)
    w = fit.theta[:, [0, 2]]                                # a 2-column fit reads (w_x, 0, w_y)
    cov = fit.cov[:, ::2, ::2]
    ok = fit.valid & np.all(np.isfinite(w), axis=1) & np.all(np.isfinite(cov.reshape(-1, 4)), axis=1)
    return SweepVelocities(t[key], sen[key].astype(np.int64), w, cov, ok)


def predicted(params: np.ndarray, sv: SweepVelocities, mount: np.ndarray, odo: np.ndarray,
              layout: dict) -> np.ndarray:
    """The velocity ``(K, 2)`` each sweep's radar sees under the model of the module docstring."""
    delta, k, b, eps, tau = unpack(params, layout, mount.shape[0])
    ts = sv.t + tau[sv.sensor]
    s = np.interp(ts, odo[:, 0], odo[:, 1])
    g = np.interp(ts, odo[:, 0], odo[:, 2])
    om = (g - b) * ((1.0 + params[-2]) if layout.get("anchored") else 1.0)   # the turn's own scale, a nuisance
    x, y, yaw = mount[sv.sensor, 0], mount[sv.sensor, 1], mount[sv.sensor, 2] + eps[sv.sensor]
    ux = k * s - om * y
    uy = k * s * math.tan(delta) + om * x
    c, si = np.cos(yaw), np.sin(yaw)
    g = 1.0 + params[-1] if layout.get("anchored") else 1.0   # the radars' own Doppler scale, against the truth's
    return g * np.column_stack([c * ux + si * uy, -si * ux + c * uy])


def unpack(params: np.ndarray, layout: dict, S: int):
    """``(delta, k, b, eps (S,), tau (S,))`` from the free parameters; ``eps`` summing to zero (the rig's reference)."""
    p = iter(params.tolist())
    delta = next(p) if layout["thrust_angle"] else 0.0
    k = 1.0 + next(p) if layout["wheel_scale"] else 1.0
    b = next(p) if layout["gyro_bias"] else 0.0
    eps = np.zeros(S)
    if layout["yaw_offsets"] and layout.get("anchored"):        # the truth fixes the car's axis: every yaw free
        eps[:] = [next(p) for _ in range(S)]
    elif layout["yaw_offsets"] and S > 1:
        eps[:-1] = [next(p) for _ in range(S - 1)]
        eps[-1] = -eps[:-1].sum()
    tau = np.array([next(p) for _ in range(S)]) if layout["time_offsets"] else np.zeros(S)
    return delta, k, b, eps, tau


#: The priors' standard deviations (c.16.2): what a car's build and a rig's mounting allow before
#: any drive (a thrust angle within a degree or so, a wheel scale within 2%, a MEMS gyro's bias, a
#: radar's yaw within 2 deg of its drawing, its clock within 50 ms).
PRIOR_STD = {"thrust_angle": math.radians(1.0), "wheel_scale": 0.02, "gyro_bias": math.radians(0.5),
             "yaw_offsets": math.radians(2.0), "time_offsets": 0.05, "doppler_scale": 0.01,
             "rotation_scale": 0.05}


def prior_stds(layout: dict, S: int) -> np.ndarray:
    """The free parameters' prior standard deviations, in :func:`unpack`'s order (all centred on zero)."""
    out = [PRIOR_STD[n] for n in ("thrust_angle", "wheel_scale", "gyro_bias") if layout[n]]
    if layout["yaw_offsets"] and layout.get("anchored"):
        out += [PRIOR_STD["yaw_offsets"]] * S
    elif layout["yaw_offsets"] and S > 1:
        out += [PRIOR_STD["yaw_offsets"]] * (S - 1)
    if layout["time_offsets"]:
        out += [PRIOR_STD["time_offsets"]] * S
    if layout.get("anchored"):
        out += [PRIOR_STD["rotation_scale"], PRIOR_STD["doppler_scale"]]
    return np.array(out)


def calibrate_car(rig: Rig, rng: np.random.Generator, *, estimate: tuple[str, ...] = ESTIMATES,
                  min_speed_mps: float = MIN_SPEED_MPS, source: str = "", truth=None) -> CarCalibration:
    """The car's fixed errors from ``rig``'s drive (module docstring): the robust weighted least
    squares of every moving sweep's velocity, the standard deviations from the Gauss-Newton
    covariance scaled by the residuals' robust spread.

    ``truth`` ``(t (q,), poses (q, 3))``, a reference trajectory of the calibration drive (a survey, a
    lidar localisation), fixes the car's axis: its direction of motion against its heading measures
    the thrust angle, its speed the wheel scale and its turn the gyro's bias (:func:`truth_motion`), so every radar's yaw is
    estimated against the car's axis instead of the rig's mean (c.16.2)."""
    from scipy.optimize import least_squares

    bad = sorted(set(estimate) - set(ESTIMATES))
    if bad:
        raise InputError(f"estimate: expected some of {', '.join(ESTIMATES)}, got {', '.join(bad)}")
    check_calibration_drive(rig, min_speed_mps)
    S = rig.sensor_ids.size
    layout = {name: name in estimate for name in ESTIMATES}
    if layout["yaw_offsets"] and S < 2:
        layout["yaw_offsets"] = False        # one radar: its yaw is the reference itself
    sv = sweep_velocities(rig, rng)
    odo = rig.odometry
    inside = (sv.t >= odo[0, 0] + 0.2) & (sv.t <= odo[-1, 0] - 0.2)
    speed = np.interp(sv.t, odo[:, 0], odo[:, 1])
    use = sv.valid & inside & (np.abs(speed) >= min_speed_mps)
    if np.count_nonzero(use) < 10 * S:
        raise InputError(f"--recording: expected at least {10 * S} sweeps of a moving car (>= {min_speed_mps} m/s) to "
                         f"calibrate from, got {int(np.count_nonzero(use))}")
    sv = SweepVelocities(sv.t[use], sv.sensor[use], sv.w[use], sv.cov[use], sv.valid[use])
    anchor = None
    if truth is not None:
        anchor = truth_motion(*truth, odo, min_speed_mps)
        layout["anchored"] = layout["yaw_offsets"] and layout["thrust_angle"] and layout["wheel_scale"]
        if layout["anchored"]:
            anchor = anchor + truth_doppler_scale(rig, rng, *truth, min_speed_mps)
    n_yaw = (S if layout.get("anchored") else S - 1) * layout["yaw_offsets"]
    n_free = (layout["thrust_angle"] + layout["wheel_scale"] + layout["gyro_bias"] + n_yaw + S * layout["time_offsets"]
              + 2 * bool(layout.get("anchored")))
    prior = prior_stds(layout, S)
    # Each radar's sweeps weighted by that radar's own robust spread, found in two passes: a sweep
    # fit's claimed covariance is not honest (overlapping windows, unmodelled multipath), a radar's
    # scatter about the model is measured. The priors (c.16.2) keep a quantity the drive hardly
    # excites (a time offset on a steady drive) near its prior.
    sigma = np.full(S, 0.1)

    def residuals(p, keep=None):
        r = (sv.w - predicted(p, sv, rig.mount, odo, layout)) / sigma[sv.sensor][:, None]
        out = [(r if keep is None else r[keep]).ravel(), p / prior]
        if layout.get("anchored"):      # the truth's direction of motion and speed (c.16.2)
            out.append(np.array([(p[0] - anchor[0]) / anchor[1], (p[1] - (anchor[2] - 1.0)) / anchor[3]]))
            if layout["gyro_bias"]:     # and the truth's turn against the gyro's (p[2], the gyro's bias)
                out.append(np.array([(p[2] - anchor[4]) / anchor[5]]))
            # and the rig's Doppler speed against the truth's (p[-1], the Doppler scale less 1)
            out.append(np.array([(p[-1] - (anchor[6] - 1.0)) / anchor[7]]))
        return np.concatenate(out)

    x0 = np.zeros(n_free)
    raw0 = np.linalg.norm(sv.w - predicted(x0, sv, rig.mount, odo, layout), axis=1)
    loss = robust_sweeps_loss(2 * sv.t.size)
    sol = None
    for _ in range(2):
        sol = least_squares(residuals, x0 if sol is None else sol.x, loss=loss, x_scale="jac", method="trf")
        e = sv.w - predicted(sol.x, sv, rig.mount, odo, layout)
        for j in range(S):
            m = sv.sensor == j
            if m.any():
                sigma[j] = max(1.4826 * float(np.median(np.abs(e[m]))), 0.01)
    r = sol.fun[:2 * sv.t.size]
    J = sol.jac
    # the robust spread of the whitened residuals (1 when each radar's spread is right)
    mad = 1.4826 * float(np.median(np.abs(r - np.median(r))))
    scale = max(mad, 1e-12) ** 2
    jk = block_jackknife(sv.t, sol.x, residuals, lambda keep: robust_sweeps_loss(2 * int(keep.sum())))
    cov = honest_covariance(np.linalg.pinv(J.T @ J) * scale, jk)
    std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    delta, k, b, eps, tau = unpack(sol.x, layout, S)
    sd_delta, sd_k, sd_b, sd_eps, sd_tau = _stds(std, cov, layout, S)
    rms = lambda e: float(np.sqrt(np.mean(e ** 2))) if e.size else math.nan
    raw1 = np.linalg.norm(sv.w - predicted(sol.x, sv, rig.mount, odo, layout), axis=1)
    per = [sv.sensor == j for j in range(S)]
    return CarCalibration(float(delta), sd_delta, float(k), sd_k, float(b), sd_b,
                          tuple(int(s) for s in rig.sensor_ids), tuple(float(e) for e in eps),
                          tuple(float(e) for e in sd_eps), tuple(float(t) for t in tau), tuple(float(t) for t in sd_tau),
                          int(sv.t.size), rms(raw0), rms(raw1), source, tuple(n for n in ESTIMATES if layout[n]),
                          "truth" if layout.get("anchored") else "rig",
                          1.0 + float(sol.x[-1]) if layout.get("anchored") else 1.0,
                          parameter_names(layout, rig.sensor_ids), tuple(tuple(float(v) for v in row) for row in cov),
                          tuple(int(m.sum()) for m in per), tuple(rms(raw0[m]) for m in per),
                          tuple(rms(raw1[m]) for m in per), parameter_values=tuple(float(v) for v in sol.x),
                          mountings=tuple(tuple(float(v) for v in row) for row in rig.mount))


def robust_sweeps_loss(n_sweep_residuals: int):
    """The loss of :func:`calibrate_car` for scipy's ``least_squares``: soft-L1 at
    :data:`ROBUST_SCALE` standard deviations on the first ``n_sweep_residuals`` residuals (the sweeps,
    where a rival consensus or multipath may win a fit), plain squares on the rest, the priors and the
    truth's anchor (c.16.2): a Gaussian prior under a robust loss loses its weight exactly where the
    sweeps pull hardest against it (scene-0916: the truth's wheel scale 1.0088 +- 0.0022 outvoted to
    1.0346, 11.7 of its standard deviations, by a Doppler scale it is 0.99 correlated with)."""
    c2 = ROBUST_SCALE ** 2

    def loss(z: np.ndarray) -> np.ndarray:
        rho = np.empty((3, z.size))
        rho[0], rho[1], rho[2] = z, 1.0, 0.0
        zs = z[:n_sweep_residuals] / c2
        t = np.sqrt(1.0 + zs)
        rho[0, :n_sweep_residuals] = c2 * 2.0 * (t - 1.0)
        rho[1, :n_sweep_residuals] = 1.0 / t
        rho[2, :n_sweep_residuals] = -0.5 / (c2 * t ** 3)
        return rho

    return loss


def parameter_names(layout: dict, sensor_ids) -> tuple[str, ...]:
    """The free parameters of :func:`unpack`, by name."""
    out = [n for n, key in (("thrust_angle_rad", "thrust_angle"), ("wheel_scale_minus_1", "wheel_scale"),
                            ("gyro_bias_rad_s", "gyro_bias")) if layout[key]]
    S = len(sensor_ids)
    if layout["yaw_offsets"] and layout.get("anchored"):
        out += [f"yaw_offset_rad[{int(s)}]" for s in sensor_ids]
    elif layout["yaw_offsets"] and S > 1:
        out += [f"yaw_offset_rad[{int(s)}]" for s in list(sensor_ids)[:-1]]
    if layout["time_offsets"]:
        out += [f"time_offset_s[{int(s)}]" for s in sensor_ids]
    if layout.get("anchored"):
        out += ["rotation_scale_minus_1", "doppler_scale_minus_1"]
    return tuple(out)


def _stds(std: np.ndarray, cov: np.ndarray, layout: dict, S: int):
    """The standard deviations of :func:`unpack`'s quantities from the free parameters' covariance;
    the last radar's yaw offset (minus the sum of the others) by propagation."""
    i = 0
    out = []
    for name in ("thrust_angle", "wheel_scale", "gyro_bias"):
        if layout[name]:
            out.append(float(std[i]))
            i += 1
        else:
            out.append(0.0)
    sd_eps = np.zeros(S)
    if layout["yaw_offsets"] and layout.get("anchored"):
        sd_eps[:] = std[i:i + S]
        i += S
    elif layout["yaw_offsets"] and S > 1:
        block = cov[i:i + S - 1, i:i + S - 1]
        sd_eps[:-1] = std[i:i + S - 1]
        sd_eps[-1] = math.sqrt(max(float(block.sum()), 0.0))
        i += S - 1
    sd_tau = std[i:i + S].copy() if layout["time_offsets"] else np.zeros(S)
    return out[0], out[1], out[2], sd_eps, sd_tau


def write_car_calibration(path: str | Path, cal: CarCalibration) -> None:
    """The calibration file (JSON, docs/recordings.md "Calibration"): every quantity, its standard
    deviation and unit, the sensors, the drive it came from."""
    from radarslam.io.results import atomic_write_text

    d = asdict(cal)
    d = {"format": FORMAT, **d,
         "units": {"thrust_angle_rad": "rad", "wheel_scale": "1", "gyro_bias_rad_s": "rad/s",
                   "yaw_offset_rad": "rad", "time_offset_s": "s (a radar's stamps early by this much)"}}
    atomic_write_text(path, json.dumps(d, indent=2, allow_nan=True) + "\n")


def read_car_calibration(path: str | Path, key: str = "--calibration") -> CarCalibration:
    """A calibration file written by :func:`write_car_calibration`, checked in one line per fault
    (naming ``key``, where the path came from)."""
    path = Path(path)
    try:
        d = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{key}: {path}: no such file") from None
    except (OSError, ValueError) as exc:
        raise InputError(f"{key}: {path}: expected a calibration JSON file, got {exc}") from None
    if not isinstance(d, dict) or d.get("format") != FORMAT:
        raise InputError(f"{key}: {path}: expected 'format': {FORMAT}, got {d.get('format') if isinstance(d, dict) else d!r}")
    names = {f for f in CarCalibration.__dataclass_fields__}
    kw = {k: (tuple(tuple(r) if isinstance(r, list) else r for r in v) if isinstance(v, list) else v)
          for k, v in d.items() if k in names}
    cal = CarCalibration(**kw)
    S = len(cal.sensor_ids)
    for name in ("yaw_offset_rad", "yaw_offset_std", "time_offset_s", "time_offset_std") + (
            ("mountings",) if cal.mountings else ()):
        if len(getattr(cal, name)) != S:
            raise InputError(f"{key}: {path}: {name}: expected {S} values (one per sensor_id), got "
                             f"{len(getattr(cal, name))}")
    for name in ("thrust_angle_rad", "wheel_scale", "gyro_bias_rad_s", "yaw_offset_rad", "time_offset_s",
                 "doppler_scale"):
        v = np.atleast_1d(np.asarray(getattr(cal, name), dtype=float))
        if not np.all(np.isfinite(v)):
            raise InputError(f"{key}: {path}: {name}: expected finite values, got {v.tolist()}")
    if not 0.5 < cal.wheel_scale < 1.5:
        raise InputError(f"{key}: {path}: wheel_scale: expected a scale near 1, got {cal.wheel_scale}")
    if not 0.9 < cal.doppler_scale < 1.1:
        raise InputError(f"{key}: {path}: doppler_scale: expected a scale near 1, got {cal.doppler_scale}")
    return cal


#: What :func:`apply_calibration` carries to another drive: the car's build (thrust angle, wheel scale)
#: and its radars' mountings and clocks. A gyro's bias is the power-up's, not the car's (it moves
#: between drives: -0.10 / -0.04 deg/s against the truth on the Singapore car's two scenes, -0.02 /
#: -0.004 on the Boston car's), so it is estimated with the others (it would bias them otherwise)
#: and applied only with ``gyro_bias=True`` (the same drive).
CARRIED = ("thrust_angle", "wheel_scale", "yaw_offsets", "time_offsets", "doppler_scale")


def apply_calibration(rec, cal: CarCalibration, *, gyro_bias: bool = False):
    """``rec`` (a :class:`~radarslam.io.recording.stream.Recording` of this car, ``unicycle``
    odometry) corrected by ``cal`` (c.16.3): the wheel speed scaled (the gyro's bias removed with
    ``gyro_bias``: the same drive only, :data:`CARRIED`), each
    radar's stamps moved by its time offset and its yaw by its offset, all in the *track frame*:
    the car's frame turned by the thrust angle, whose x axis is the rear axle's direction of motion.
    In that frame the car moves without sideslip at ``k s / cos(delta)`` and the unicycle model
    holds exactly; the mountings turn by ``-delta`` about the rear axle and the truth's heading by
    ``+delta``. A pose estimated in the track frame is the car's with its heading minus ``delta``
    (:func:`car_heading`). Refuses a recording whose sensors the file does not name, or whose rig
    is not the calibration's (:func:`check_same_rig`)."""
    import dataclasses

    if rec.odo_kind != "unicycle":
        raise InputError(f"--calibration: expected a recording with unicycle odometry (speed_mps, yaw_rate_rad_s), "
                         f"got {rec.odo_kind!r}")
    d = cal.thrust_angle_rad
    odo = rec.odo.copy()
    odo[:, 0] = odo[:, 0] * cal.wheel_scale / math.cos(d)
    if gyro_bias:
        odo[:, 1] = odo[:, 1] - cal.gyro_bias_rad_s
    c, s = math.cos(-d), math.sin(-d)
    sensors = rec.sensors
    if sensors:
        missing = sorted(set(sensors) - set(cal.sensor_ids))
        if missing and cal.sensor_ids:
            raise InputError(f"--calibration: expected an entry for every sensor_id of the recording, got none for "
                             f"{missing} (the file has {list(cal.sensor_ids)})")
        check_same_rig(sensors, cal)
        new = {}
        for sid, m in sensors.items():
            eps, _ = cal.per_sensor(sid)
            new[sid] = dataclasses.replace(m, x=c * m.x - s * m.y, y=s * m.x + c * m.y, yaw=m.yaw + eps - d)
        sensors = new
    mounting = rec.mounting
    if mounting is not None:
        mounting = dataclasses.replace(mounting, x=c * mounting.x - s * mounting.y, y=s * mounting.x + c * mounting.y,
                                       yaw=mounting.yaw - d)
    truth = rec.truth
    if truth is not None:
        truth = truth.copy()
        truth[:, 2] = truth[:, 2] + d
    channels = rec.channels
    if cal.doppler_scale != 1.0 and "doppler_mps" in channels:      # the radars' own scale (c.16.2), a 2-D radar's cos(el)
        channels = {**channels, "doppler_mps": channels["doppler_mps"] / cal.doppler_scale}
    out = dataclasses.replace(rec, odo=odo, sensors=sensors, mounting=mounting, truth=truth, channels=channels)
    if any(cal.time_offset_s) and "sensor_id" in rec.channels:      # each radar's stamps by its offset
        sid = rec.channels["sensor_id"].astype(np.int64)
        shift = np.zeros(rec.det_t.size)
        for j, s_id in enumerate(cal.sensor_ids):
            shift[sid == s_id] = cal.time_offset_s[j]
        out = restamped(out, rec.det_t + shift)
    return out


def car_heading(poses: np.ndarray, cal: CarCalibration) -> np.ndarray:
    """Poses ``(K, 3)`` of the track frame (:func:`apply_calibration`) as the car's: heading minus the thrust angle."""
    from radarslam.core.angles import wrap_pi

    out = np.array(poses, dtype=float, copy=True)
    out[:, 2] = wrap_pi(out[:, 2] - cal.thrust_angle_rad)
    return out


def yaw_table(cal: CarCalibration, rig: Rig):
    """The per-radar yaw table (:class:`~radarslam.egomotion.calibrate.Calibration`, ``calibration.csv``)
    of ``cal``: the rig-referenced yaw offsets, their sweeps and velocity residuals."""
    from radarslam.egomotion.calibrate import Calibration

    ids = list(cal.sensor_ids)
    j = [ids.index(int(s)) for s in rig.sensor_ids]
    pick = lambda v, dtype=float: np.array([v[i] for i in j], dtype=dtype)
    return Calibration(rig.sensor_ids.copy(), list(rig.names), rig.mount[:, 2].copy(), pick(cal.yaw_offset_rad),
                       pick(cal.yaw_offset_std), pick(cal.sensor_sweeps, np.int64), pick(cal.sensor_sweeps, np.int64),
                       pick(cal.sensor_rms_before), pick(cal.sensor_rms_after))
