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
from radarslam.core.registry import MOTION_MODELS
from radarslam.models.input_bias import TURN_RATE_KEYS, InputBias

__all__ = ["BodyVelocityModel"]


class BodyVelocityModel:
    """Pose ``[x m, y m, theta rad]`` driven by ``u = [v_x m/s, v_y m/s, omega rad/s]`` (c.10.5)."""

    name = "body-velocity"
    #: c.11: a speed scale on (v_x, v_y) and a yaw-rate (gyro) offset (rad/s) on omega.
    input_bias = InputBias((0, 1), 2, ("speed_scale", "yaw_rate_offset"), ("1", "rad/s"), TURN_RATE_KEYS)
    #: c.2.1: F_x's heading column is (-dy, dx) of the increment: first-estimates Jacobians apply.
    se2_increment = True

    @staticmethod
    def _increment(pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[float, float]:
        """The position increment ``(dx, dy)`` (m) in the world frame."""
        vx, vy, w = float(u[0]), float(u[1]), float(u[2])
        a = float(pose[2]) + 0.5 * dt * w
        c, s = math.cos(a), math.sin(a)
        return dt * (vx * c - vy * s), dt * (vx * s + vy * c)

    def step(self, pose: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """Next pose ``(3,)``, heading wrapped to [0, 2 pi)."""
        dx, dy = self._increment(pose, u, dt)
        return np.array([pose[0] + dx, pose[1] + dy, wrap_2pi_scalar(float(pose[2]) + float(u[2]) * dt)])

    def jacobians(self, pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F_x (3, 3), F_u (3, 3))`` at ``(pose, u)`` (docs/method.md c.10.5):

        F_x = [[1, 0, -dy], [0, 1, dx], [0, 0, 1]],
        F_u = [[dt c, -dt s, -dt dy / 2], [dt s, dt c, dt dx / 2], [0, 0, dt]]

        with ``c, s = cos a, sin a`` and ``(dx, dy)`` the position increment."""
        a = float(pose[2]) + 0.5 * dt * float(u[2])
        c, s = math.cos(a), math.sin(a)
        dx, dy = self._increment(pose, u, dt)
        Fx = np.array([[1.0, 0.0, -dy], [0.0, 1.0, dx], [0.0, 0.0, 1.0]])
        Fu = np.array([[dt * c, -dt * s, -0.5 * dt * dy], [dt * s, dt * c, 0.5 * dt * dx], [0.0, 0.0, dt]])
        return Fx, Fu

    def control_cov(self, filter_config) -> np.ndarray:
        """A nominal U ``(3, 3)``: diag(sigma_v^2, sigma_v^2, sigma_gyro^2) from ``filter.speed_std_mps``
        and ``filter.gyro_std_deg_s``. Under Doppler odometry each prediction uses the fit's own
        covariance instead (c.10.5)."""
        s = filter_config.speed_std_mps ** 2
        return np.diag([s, s, math.radians(filter_config.gyro_std_deg_s) ** 2])


def _make_body_velocity(filter_config) -> BodyVelocityModel:
    return BodyVelocityModel()


MOTION_MODELS.register("body-velocity", _make_body_velocity)
