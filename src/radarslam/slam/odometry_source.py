"""What drives the EKF prediction under ``filter.odometry`` "doppler" or "both" (docs/method.md c.10.5).

Event flow (:meth:`DopplerOdometry.process`, called by :meth:`EkfSlam.process
<radarslam.slam.filter.EkfSlam.process>`):

- an :class:`~radarslam.core.types.Odometry` event only accumulates: its ``dt``, its gyro reading
  ``gyro_rad_s`` weighted by ``dt`` and (under "both") the odometer's forward speed weighted by ``dt``;
- a :class:`~radarslam.core.types.Scan` first predicts over the accumulated interval with the
  body-velocity model (:mod:`radarslam.models.body_velocity`), input ``u = [v_x, v_y, omega]``:
  ``(v_x, v_y)`` the *previous* scan's Doppler ego-velocity fit (c.10.2) and ``omega`` the mean gyro
  rate, ``U = blockdiag(cov(v), sigma_gyro^2)``, ``Q`` once per accumulated odometer interval (as
  the odometer's predictions add it); then updates with the scan (:meth:`EkfSlam.update`); then fits
  this scan's velocity, to drive the next interval.

Why the previous scan's velocity: the interval ``[t_k, t_{k+1}]`` starts at scan k, whose Doppler
measures the platform's velocity at ``t_k`` -- the causal, zero-order-hold choice, and in the
simulator exactly the velocity that moves pose k to pose k+1 (``platform_velocities``, b.4.3).
Before the first fit (odometry events ahead of the first scan) and after a scan whose fit is not
valid (c.10.3), the last valid fit is held with ``filter.doppler_hold_std_mps`` added to its std
(zero velocity before any fit).

The fit's directions are the platform-frame azimuths: the sensor is taken at the platform origin
with zero boresight (the car park's radar). Under "both" the odometer's forward speed (the unicycle's
``control[0]``, std ``filter.speed_std_mps``) is fused with the fit, information-weighted (a
Kalman update of ``(v_x, v_y)`` by the scalar ``v_x`` reading); the yaw rate stays the gyro's.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import ConfigError, InputError
from radarslam.core.types import Odometry, Scan
from radarslam.models.body_velocity import BodyVelocityModel
from radarslam.slam import ekf
from radarslam.slam.bias import predict_terms

__all__ = ["DopplerOdometry", "fuse_forward_speed", "odometry_source"]


def odometry_source(slam) -> "DopplerOdometry | None":
    """The prediction driver of ``slam``'s ``filter.odometry``: None for "odometer" (the readings,
    :meth:`EkfSlam.predict`), else a :class:`DopplerOdometry`.

    Raises
    ------
    ConfigError
        For "body-velocity" as ``filter.motion_model`` with the odometer (its readings are
        ``[v, psi]``), or for "doppler"/"both" with first-estimates Jacobians, or "both" with a
        motion model other than the unicycle (whose ``control[0]`` is the forward speed).
    """
    f = slam.config.filter
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
    return DopplerOdometry(f)


def fuse_forward_speed(v: np.ndarray, C: np.ndarray, speed: float, var: float) -> tuple[np.ndarray, np.ndarray]:
    """Information-weighted fusion of a velocity ``v`` (2,) m/s with covariance ``C`` (2, 2) and a
    forward-speed reading ``speed`` (m/s) of variance ``var`` (m^2/s^2): the Kalman update with
    ``H = [1, 0]`` (equal to ``(C^-1 + H^T H / var)^-1 (C^-1 v + H^T speed / var)``), ``(v', C')``."""
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

    def __init__(self, filter_config):
        self.f = filter_config
        self.model = BodyVelocityModel()
        self.gyro_var = math.radians(filter_config.gyro_std_deg_s) ** 2
        #: RANSAC's minimal sets (c.10.2): a fixed seed of its own, so a run is reproducible.
        self.rng = np.random.default_rng(0)
        self.v = np.zeros(2)                                  # the velocity driving the next interval
        self.C = np.eye(2) * filter_config.doppler_hold_std_mps ** 2
        self.fits = 0                                         # valid fits so far
        self._reset()

    def _reset(self) -> None:
        self.dt, self.n, self.gyro_dt, self.speed_dt = 0.0, 0, 0.0, 0.0

    def process(self, slam, event):
        """One event of the stream (module docstring): None for odometry, the scan's ScanReport."""
        if isinstance(event, Odometry):
            self._accumulate(event)
            return None
        if isinstance(event, Scan):
            if self.n:
                self._predict(slam, event.t)
            report = slam.update(event)
            self._fit(slam, event, report)
            return report
        raise InputError(f"event: expected Odometry or Scan, got {type(event).__name__}")

    def _accumulate(self, odo: Odometry) -> None:
        dt = float(odo.dt)
        if not (math.isfinite(dt) and dt > 0):
            raise InputError(f"odometry.dt: expected a finite value > 0, got {odo.dt!r}")
        g = odo.gyro_rad_s
        if g is None or not math.isfinite(float(g)):
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

    def _predict(self, slam, t) -> None:
        """Predict over the accumulated interval (c.10.5), then clear it."""
        v, C = self.v, self.C
        if self.f.odometry == "both":
            v, C = fuse_forward_speed(v, C, self.speed_dt / self.dt, self.f.speed_std_mps ** 2)
        u = np.array([v[0], v[1], self.gyro_dt / self.dt])
        U = np.zeros((3, 3))
        U[:2, :2], U[2, 2] = C, self.gyro_var
        st, dt = slam.state, self.dt
        with np.errstate(over="ignore", invalid="ignore"):
            pose, Ppp, Ppl = predict_terms(slam.bias_model, st.x, st.P, u, dt, self.model, U, self.n * slam.Q)
        if not (np.isfinite(pose).all() and np.isfinite(Ppp).all() and np.isfinite(Ppl).all()):
            raise InputError(f"odometry before the scan at t={t!r}: expected an input that keeps the state finite "
                             f"(u {u.tolist()}, dt {dt!r}), got one that makes it non-finite")
        ekf.apply_prediction(st.x, st.P, pose, Ppp, Ppl)
        slam._dt_since_scan += dt
        self._reset()

    def _fit(self, slam, scan: Scan, report) -> None:
        """This scan's ego velocity, held for the next interval: the one the scan carries (a 3-D
        recording's levelled fit, c.10.6), else the Doppler gate's fit when it ran, else a fit of the
        scan's platform-frame azimuths (c.10.2)."""
        ego = scan.ego if scan.ego is not None else report.ego     # c.10.6: a recording's 3-D fit first
        if ego is None:
            from radarslam.models.doppler import directions, fit_ego_velocity

            polar = np.asarray(scan.polar, dtype=float).reshape(-1, 2)
            d = np.asarray((scan.channels or {}).get("doppler_mps", np.empty(0)), dtype=float)
            if d.shape != (polar.shape[0],):
                raise InputError(f"scan {scan.index}: channels['doppler_mps']: filter.odometry {self.f.odometry!r} "
                                 f"expected shape ({polar.shape[0]},), got {d.shape}")
            f = self.f
            ego = fit_ego_velocity(directions(polar), d, self.rng, threshold_mps=f.doppler_threshold_mps,
                                   iterations=f.doppler_iterations, sigma_floor_mps=f.doppler_std_floor_mps,
                                   zero_probability=f.zero_velocity_probability)
        if ego.valid and np.all(np.isfinite(ego.v)) and np.all(np.isfinite(ego.cov)):
            self.v, self.C = np.asarray(ego.v, dtype=float)[:2].copy(), np.asarray(ego.cov, dtype=float)[:2, :2].copy()
            self.fits += 1
        else:
            self.C = self.C + np.eye(2) * self.f.doppler_hold_std_mps ** 2
