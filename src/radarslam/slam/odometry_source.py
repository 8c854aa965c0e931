"""What drives the EKF prediction under ``filter.odometry`` "doppler" or "both" (docs/method.md c.10.5).

Event flow (what the fused engine's stream takes from :class:`DopplerOdometry`,
``slam/fused/stream.py: _stream_arrays``):

- an :class:`~radarslam.core.types.Odometry` event only accumulates: its ``dt``, its gyro reading
  ``gyro_rad_s`` weighted by ``dt`` and (under "both") the odometer's forward speed weighted by ``dt``;
- a :class:`~radarslam.core.types.Scan` first predicts over the accumulated interval with the
  body-velocity model (:mod:`radarslam.models.body_velocity`), input ``u = [v_x, v_y, omega]``:
  ``(v_x, v_y)`` the *previous* scan's Doppler ego-velocity fit (c.10.2) and ``omega`` the mean gyro
  rate, ``U = blockdiag(cov(v), sigma_gyro^2 dt_0 / dt)`` (the gyro a density, c.2.2), ``Q`` once per accumulated odometer interval (as
  the odometer's predictions add it); then the engine updates with the scan; then this scan's
  velocity is fitted, to drive the next interval.

Why the previous scan's velocity: the interval ``[t_k, t_{k+1}]`` starts at scan k, whose Doppler
measures the platform's velocity at ``t_k`` -- the causal, zero-order-hold choice, and in the
simulator exactly the velocity that moves pose k to pose k+1 (``platform_velocities``, b.4.3).
Before the first fit (odometry events ahead of the first scan) and after a scan whose fit is not
valid (c.10.3), the last valid fit is held with ``filter.doppler_hold_std_mps`` added to its std
(zero velocity before any fit).

The fit's directions are those from the radar (``[sensor]`` mounting, c.10.1), so the fit is the
sensor's velocity ``w`` in its own frame; it moves to the platform origin with the yaw rate
(:func:`platform_input`): with the gyro (``filter.yaw_rate = "gyro"``) ``v = R(yaw_m) w - omega x l``,
``(v_x, v_y, omega)`` free (the body-velocity model); from the Doppler alone (``"doppler"``, c.10.5.1)
the no-sideslip model ``v_y = 0`` gives ``omega = w_y' / l_x`` and ``v = w_x' + l_y omega``
(``w' = R(yaw_m) w``), observable only with the radar off the rear axle (``l_x != 0``). A 3-D
recording's scans carry their velocity at the platform origin already (``Scan.ego``, c.10.6). Under
"both" the odometer's forward speed (the unicycle's ``control[0]``, std ``filter.speed_std_mps``) is
fused with the input, information-weighted (a Kalman update of ``(v_x, v_y, omega)`` by the scalar
``v_x`` reading); the yaw rate stays the gyro's.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import ConfigError, InputError
from radarslam.core.mounting import ORIGIN, Mounting
from radarslam.core.types import Odometry, Scan
from radarslam.models.body_velocity import BodyVelocityModel

__all__ = ["DopplerOdometry", "fuse_forward_speed", "odometry_source", "platform_input"]


def odometry_source(slam) -> "DopplerOdometry | None":
    """The prediction driver of ``slam``'s ``filter.odometry``: None for "odometer" (the readings,
    :meth:`EkfSlam.predict`), else a :class:`DopplerOdometry`.

    Raises
    ------
    ConfigError
        For ``filter.yaw_rate = "doppler"`` without ``filter.odometry = "doppler"`` or with the radar on
        the rear axle (``sensor.mount_x_m = 0``), for "body-velocity" as ``filter.motion_model`` with
        the odometer (its readings are ``[v, psi]``), or for "doppler"/"both" with first-estimates
        Jacobians, or "both" with a motion model other than the unicycle (whose ``control[0]`` is
        the forward speed).
    """
    f = slam.config.filter
    if f.yaw_rate == "doppler":
        if f.odometry != "doppler":
            raise ConfigError(f"filter.yaw_rate: 'doppler' expected with filter.odometry 'doppler' (the radar alone, "
                              f"c.10.5.1), got filter.odometry {f.odometry!r}")
        why = radar_alone_unobservable(slam.config.rig, slam.config.sensor)
        if why is not None:
            raise ConfigError(why)
    if f.odometry == "odometer":
        if f.motion_model == "body-velocity":
            raise ConfigError("filter.motion_model: 'body-velocity' is driven by filter.odometry 'doppler' or "
                              "'both' (c.10.5), got filter.odometry 'odometer'")
        return None
    if f.jacobians != "standard":
        raise ConfigError(f"filter.jacobians: expected 'standard' with filter.odometry {f.odometry!r}, got "
                          f"{f.jacobians!r}")
    if f.odometry == "both" and f.motion_model != "unicycle":
        raise ConfigError(f"filter.motion_model: expected 'unicycle' with filter.odometry 'both' (its control[0] is "
                          f"the forward speed), got {f.motion_model!r}")
    return DopplerOdometry(f, slam.config.mounting,
                           rig_fit=f.yaw_rate == "doppler" and distinct_lever_arms(slam.config.rig))


def distinct_lever_arms(rig) -> bool:
    """Whether a rig (its :class:`Mounting` s, or their ``(x, y, yaw)`` rows) has two radars at
    different positions: then its joint Doppler fit observes ``(v_x, v_y, omega)`` (c.12.2: one radar's
    rows have the null direction ``(y_s, -x_s, 1)``; two radars share it only if ``l_s = l_r``)."""
    pos = {(float(m.x), float(m.y)) for m in map(Mounting.coerce, rig)}
    return len(pos) >= 2


def radar_alone_unobservable(rig, sensor) -> str | None:
    """Why the radar alone (``filter.yaw_rate = "doppler"``) cannot give the yaw rate, or None when it
    can: a rig (its :class:`Mounting` s, or their ``(x, y, yaw)`` rows) with two distinct lever arms
    fits ``(v_x, v_y, omega)`` (c.12.2), whatever the axle; a single radar (the rig's one, else
    ``sensor``, the ``[sensor]`` section) needs the no-sideslip model and ``l_x != 0``
    (``omega = w'_y / l_x``, c.10.5.1)."""
    if distinct_lever_arms(rig):
        return None
    if rig:
        first = Mounting.coerce(rig[0])
        x, y = float(first.x), float(first.y)
        if x != 0.0:
            return None
        return (f"filter.yaw_rate: 'doppler' needs two radars at different positions (the rig's joint fit, c.12.2) "
                f"or one off the rear axle (omega = w_y / l_x, c.10.5.1), got a rig of {len(rig)} radar(s), all at "
                f"x = {x}, y = {y}")
    if Mounting.from_config(sensor).x != 0.0:
        return None
    return ("filter.yaw_rate: 'doppler' needs the radar off the rear axle (omega = w_y / l_x is unobservable at "
            "l_x = 0, c.10.5.1) or a rig of two radars at different positions (c.12.2), got sensor.mount_x_m = 0.0 "
            "and no rig")


def platform_input(w: np.ndarray, C: np.ndarray, mount, yaw_rate: float | None,
                   yaw_var: float) -> tuple[np.ndarray, np.ndarray]:
    """The body-velocity model's input ``u = [v_x, v_y, omega]`` and its covariance ``U`` (3, 3) from a
    sensor velocity ``w`` (2,) (sensor frame, m/s) of covariance ``C`` (2, 2) of a radar mounted at
    ``mount`` (a :class:`Mounting`, or ``(l_x, l_y, yaw_m)`` (m, m, rad); c.10.1, c.10.5.1; both maps
    linear, so ``U`` is exact).

    With a gyro (``yaw_rate`` its reading, rad/s, variance ``yaw_var``): ``w' = R(yaw_m) w`` and
    ``u = J [w', omega]`` with ``J = [[1, 0, l_y], [0, 1, -l_x], [0, 0, 1]]``,
    ``U = J blockdiag(R C R^T, yaw_var) J^T``. From the Doppler alone (``yaw_rate`` None; needs
    ``l_x != 0``): no sideslip, ``u = [w'_x + (l_y / l_x) w'_y, 0, w'_y / l_x] = A w'`` on rows 0 and 2,
    ``U = A R C R^T A^T`` there with ``A = [[1, l_y / l_x], [0, 1 / l_x]]`` and zero on row 1.
    """
    m = Mounting.coerce(mount)
    lx, ly, yaw = float(m.x), float(m.y), float(m.yaw)
    if yaw != 0.0:
        c, s = math.cos(yaw), math.sin(yaw)
        R = np.array([[c, -s], [s, c]])
        w, C = R @ w, R @ C @ R.T
    if yaw_rate is None:
        A = np.array([[1.0, ly / lx], [0.0, 1.0 / lx]])
        vw, Cvw = A @ w, A @ C @ A.T
        u = np.array([vw[0], 0.0, vw[1]])
        U = np.zeros((3, 3))
        U[np.ix_([0, 2], [0, 2])] = Cvw
        return u, U
    u = np.array([w[0], w[1], yaw_rate])
    U = np.zeros((3, 3))
    U[:2, :2], U[2, 2] = C, yaw_var
    if lx != 0.0 or ly != 0.0:
        J = np.array([[1.0, 0.0, ly], [0.0, 1.0, -lx], [0.0, 0.0, 1.0]])
        u, U = J @ u, J @ U @ J.T
    return u, U


def fuse_forward_speed(v: np.ndarray, C: np.ndarray, speed: float, var: float) -> tuple[np.ndarray, np.ndarray]:
    """Information-weighted fusion of an input ``v`` (n,) whose first component is the forward speed
    (m/s), with covariance ``C`` (n, n), and a forward-speed reading ``speed`` (m/s) of variance
    ``var`` (m^2/s^2): the Kalman update with ``H = [1, 0, ...]`` (equal to
    ``(C^-1 + H^T H / var)^-1 (C^-1 v + H^T speed / var)``), ``(v', C')``."""
    s = float(C[0, 0]) + var
    if not s > 0:
        return v.copy(), C.copy()
    K = C[:, 0] / s
    return v + K * (speed - float(v[0])), C - np.outer(K, C[0, :])


class DopplerOdometry:
    """Prediction from the Doppler ego-velocity and a gyro (module docstring; c.10.5).

    Parameters
    ----------
    filter_config : FilterConfig
        ``odometry``, ``gyro_std_deg_s``, ``doppler_hold_std_mps``, ``speed_std_mps`` and the
        RANSAC settings of c.10.2 (``doppler_threshold_mps``, ``doppler_iterations``,
        ``doppler_std_floor_mps``, ``zero_velocity_probability``).
    """

    def __init__(self, filter_config, mount: Mounting = Mounting(), rig_fit: bool = False):
        self.f = filter_config
        #: The radar whose velocity is held: ``mount`` (``[sensor]``) for a scan in the platform frame,
        #: else the scan's own (``Scan.sensor``, c.13).
        self.mount = Mounting.coerce(mount)
        self.config_mount = self.mount
        #: Whether the held velocity is the sensor's (a fit of the scan) or the platform's (``Scan.ego``).
        self.sensor_frame = True
        #: The radar alone on a rig (c.10.5.1, c.12.2): the scans carry the rig's (v_x, v_y, omega) fit
        #: (``Scan.ego`` of three components), held as it is; never a radar's no-sideslip yaw rate.
        self.rig_fit = bool(rig_fit)
        self.model = BodyVelocityModel()
        self.gyro_var = math.radians(filter_config.gyro_std_deg_s) ** 2
        self.noise_ref = float(filter_config.noise_interval_s)   # Q is quoted per reading over it (c.2.2)
        #: RANSAC's minimal sets (c.10.2): a fixed seed of its own, so a run is reproducible.
        self.rng = np.random.default_rng(0)
        n = 3 if self.rig_fit else 2
        self.v = np.zeros(n)                                  # the velocity driving the next interval
        self.C = np.eye(n) * filter_config.doppler_hold_std_mps ** 2
        if self.rig_fit:
            self.sensor_frame = False
        self.fits = 0                                         # valid fits so far
        self.clear_interval()

    def clear_interval(self) -> None:
        """Start a new interval (after a prediction)."""
        self.dt, self.n, self.gyro_dt, self.speed_dt = 0.0, 0, 0.0, 0.0

    def accumulate(self, odo: Odometry) -> None:
        """Add an odometry event to the interval before the next scan (module docstring)."""
        dt = float(odo.dt)
        if not (math.isfinite(dt) and dt > 0):
            raise InputError(f"odometry.dt: expected a finite value > 0, got {odo.dt!r}")
        g = odo.gyro_rad_s
        if self.f.yaw_rate == "doppler":
            g = 0.0                           # c.10.5.1: the radar alone, the gyro is not read
        elif g is None or not math.isfinite(float(g)):
            raise InputError(f"odometry.gyro_rad_s: filter.odometry {self.f.odometry!r} expected a finite gyro "
                             f"reading (t={odo.t!r}), got {g!r}")
        if self.f.odometry == "both":
            v = float(np.asarray(odo.control, dtype=float).reshape(-1)[0])
            if not math.isfinite(v):
                raise InputError(f"odometry.control: expected a finite speed, got {odo.control!r}")
            self.speed_dt += v * dt
        self.dt += dt
        self.n += 1
        self.gyro_dt += float(g) * dt

    def prediction_input(self, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, float, np.ndarray]:
        """The body-velocity prediction over the accumulated interval (c.10.5) as ``(u (3,), U (3, 3),
        dt, Q_n)``, ``Q_n`` the process noise over dt (c.2.2); it depends on the
        scans and readings only, not on the filter's state (the fused engine's stream takes it)."""
        if self.v.size == 3:          # the rig's (v_x, v_y, omega) at the rear axle (c.12.2), the radar alone
            u, U = self.v.copy(), self.C.copy()
            steady = abs(self.dt - self.n * self.noise_ref) <= 1e-9
            return u, U, self.dt, self.n * Q if steady else Q * (self.dt / self.noise_ref)
        omega = None if self.f.yaw_rate == "doppler" else self.gyro_dt / self.dt
        # c.2.2: the gyro's mean over the interval; filter.gyro_std_deg_s is quoted for a reading over
        # noise_interval_s (a density sigma^2 dt_0), so its mean over dt has variance sigma^2 dt_0 / dt and the
        # heading variance it adds, sigma^2 dt_0 dt, grows with time, not with the number of scans (radars)
        gyro_var = self.gyro_var * (self.noise_ref / self.dt)
        u, U = platform_input(self.v, self.C, self.mount if self.sensor_frame else ORIGIN, omega, gyro_var)
        if self.f.odometry == "both":
            u, U = fuse_forward_speed(u, U, self.speed_dt / self.dt, self.f.speed_std_mps ** 2)
        # Q a density (c.2.2): n readings of the reference interval take n Q, as before, bit for bit
        steady = abs(self.dt - self.n * self.noise_ref) <= 1e-9
        return u, U, self.dt, self.n * Q if steady else Q * (self.dt / self.noise_ref)

    def fit(self, scan: Scan, gate_ego=None) -> None:
        """This scan's ego velocity, held for the next interval: the one the scan carries (a 3-D
        recording's levelled fit, c.10.6), else the Doppler gate's fit ``gate_ego`` when it ran, else
        a fit of the scan's platform-frame azimuths (c.10.2)."""
        if self.rig_fit:
            self._hold_rig(scan)
            return
        ego = scan.ego if scan.ego is not None else gate_ego       # c.10.6: a recording's 3-D fit first
        if scan.ego is not None and self.f.yaw_rate == "doppler":
            raise InputError(f"scan {scan.index}: filter.yaw_rate 'doppler' expected the radar's own fit, got a scan "
                             f"carrying its velocity at the platform origin (Scan.ego, c.10.6)")
        self.sensor_frame = scan.ego is None
        sen = scan.sensor              # c.13: a scan in its own radar's frame, the held velocity that radar's
        self.mount = self.config_mount if sen is None else sen
        if ego is None:
            from radarslam.models.doppler import fit_ego_velocity, mounted_directions

            polar = np.asarray(scan.polar, dtype=float).reshape(-1, 2)
            d = np.asarray((scan.channels or {}).get("doppler_mps", np.empty(0)), dtype=float)
            if d.shape != (polar.shape[0],):
                raise InputError(f"scan {scan.index}: channels['doppler_mps']: filter.odometry {self.f.odometry!r} "
                                 f"expected shape ({polar.shape[0]},), got {d.shape}")
            f = self.f
            m = self.mount if sen is None else ORIGIN
            ego = fit_ego_velocity(mounted_directions(polar, m.x, m.y, m.yaw), d, self.rng,
                                   threshold_mps=f.doppler_threshold_mps, iterations=f.doppler_iterations,
                                   sigma_floor_mps=f.doppler_std_floor_mps,
                                   zero_probability=f.zero_velocity_probability)
        if ego.valid and np.all(np.isfinite(ego.v)) and np.all(np.isfinite(ego.cov)):
            self.v, self.C = np.asarray(ego.v, dtype=float)[:2].copy(), np.asarray(ego.cov, dtype=float)[:2, :2].copy()
            self.fits += 1
        else:
            self.C = self.C + np.eye(2) * self.f.doppler_hold_std_mps ** 2

    def _hold_rig(self, scan: Scan) -> None:
        """The radar alone on a rig: hold the scan's ``Scan.ego``, the rig's joint ``(v_x, v_y, omega)``
        fit at the rear axle (c.12.2; egomotion/rig_odometry.py); a scan without a valid one keeps
        the last with ``filter.doppler_hold_std_mps``^2 added to every component (m/s, and rad/s)."""
        ego = scan.ego
        if ego is not None and np.asarray(ego.v).shape != (3,):
            raise InputError(f"scan {scan.index}: filter.yaw_rate 'doppler' on a rig expected the rig's (v_x, v_y, "
                             f"omega) fit as Scan.ego, got shape {np.asarray(ego.v).shape}")
        if ego is not None and ego.valid and np.all(np.isfinite(ego.v)) and np.all(np.isfinite(ego.cov)):
            self.v, self.C = np.asarray(ego.v, dtype=float).copy(), np.asarray(ego.cov, dtype=float).copy()
            self.fits += 1
        else:
            self.C = self.C + np.eye(3) * self.f.doppler_hold_std_mps ** 2
