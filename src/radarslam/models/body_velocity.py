"""The body-velocity motion model: input ``u = [v_x, v_y, omega]`` (docs/method.md c.10.5).

``v_x`` and ``v_y`` (m/s) are the platform's forward and lateral velocity in its own frame and
``omega`` (rad/s) its yaw rate, as a Doppler ego-velocity fit (c.10) and a gyro give them. Over
``dt`` the pose moves along the midpoint heading ``a = theta + dt omega / 2`` (the unicycle's
APSIPA eq. (5) with a lateral term; with ``v_y = 0`` the two models are the same):

    x_k = x + dt (v_x cos a - v_y sin a),  y_k = y + dt (v_x sin a + v_y cos a),
    theta_k = theta + dt omega.

Importing this module registers the model as ``"body-velocity"`` in
:data:`radarslam.core.registry.MOTION_MODELS`. The filter drives it from
:mod:`radarslam.slam.odometry_source` under ``filter.odometry = "doppler"`` or ``"both"``.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_2pi_scalar
from radarslam.models.input_bias import TURN_RATE_KEYS, InputBias

__all__ = ["BodyVelocityModel", "body_velocity_increment", "body_velocity_jacobians", "body_velocity_step"]


def body_velocity_increment(theta: float, vx: float, vy: float, w: float, dt: float) -> tuple[float, float]:
    """The position increment ``(dx, dy)`` (m) in the world frame over ``dt`` from heading ``theta``
    with input ``(v_x, v_y, omega)`` (module docstring). A kernel: numba compiles it as it is."""
    a = theta + 0.5 * dt * w
    c, s = math.cos(a), math.sin(a)
    return dt * (vx * c - vy * s), dt * (vx * s + vy * c)


def body_velocity_step(x: float, y: float, theta: float, vx: float, vy: float, w: float, dt: float) -> np.ndarray:
    """:meth:`BodyVelocityModel.step` of the pose ``(x, y, theta)``: the next pose ``(3,)``, heading
    wrapped to [0, 2 pi). A kernel (the fused engine's prediction under Doppler odometry)."""
    dx, dy = body_velocity_increment(theta, vx, vy, w, dt)
    return np.array([x + dx, y + dy, wrap_2pi_scalar(theta + w * dt)])


def body_velocity_jacobians(theta: float, vx: float, vy: float, w: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(F_x (3, 3), F_u (3, 3))`` of :func:`body_velocity_step` (docs/method.md c.10.5):

    F_x = [[1, 0, -dy], [0, 1, dx], [0, 0, 1]],
    F_u = [[dt c, -dt s, -dt dy / 2], [dt s, dt c, dt dx / 2], [0, 0, dt]]

    with ``c, s = cos a, sin a`` and ``(dx, dy)`` the position increment. A kernel."""
    a = theta + 0.5 * dt * w
    c, s = math.cos(a), math.sin(a)
    dx, dy = body_velocity_increment(theta, vx, vy, w, dt)
    Fx = np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx], [0.0, 0.0, 1.0]])
    Fu = np.array([[dt * c, -dt * s, -0.5 * dt * dy], [dt * s, dt * c, 0.5 * dt * dx], [0.0, 0.0, dt]])
    return Fx, Fu


class BodyVelocityModel:
    """Pose ``[x m, y m, theta rad]`` driven by ``u = [v_x m/s, v_y m/s, omega rad/s]`` (c.10.5)."""

    name = "body-velocity"
    #: c.11: a speed scale on (v_x, v_y) and a yaw-rate (gyro) offset (rad/s) on omega.
    input_bias = InputBias((0, 1), 2, ("speed_scale", "yaw_rate_offset"), ("1", "rad/s"), TURN_RATE_KEYS)
    #: c.2.1: F_x's heading column is (-dy, dx) of the increment: first-estimates Jacobians apply.
    se2_increment = True

    def step(self, pose: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """Next pose ``(3,)``, heading wrapped to [0, 2 pi) (:func:`body_velocity_step`)."""
        return body_velocity_step(float(pose[0]), float(pose[1]), float(pose[2]), float(u[0]), float(u[1]),
                                  float(u[2]), dt)

    def jacobians(self, pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F_x (3, 3), F_u (3, 3))`` at ``(pose, u)`` (:func:`body_velocity_jacobians`)."""
        return body_velocity_jacobians(float(pose[2]), float(u[0]), float(u[1]), float(u[2]), dt)

    def control_cov(self, filter_config) -> np.ndarray:
        """A nominal U ``(3, 3)``: diag(sigma_v^2, sigma_v^2, sigma_gyro^2) from ``filter.speed_std_mps``
        and ``filter.gyro_std_deg_s``. Under Doppler odometry each prediction uses the fit's own
        covariance instead (c.10.5)."""
        s = filter_config.speed_std_mps ** 2
        return np.diag([s, s, math.radians(filter_config.gyro_std_deg_s) ** 2])


def make_body_velocity(filter_config) -> BodyVelocityModel:
    return BodyVelocityModel()


