"""Platform motion models.

A motion model maps ``(pose, control, dt)`` to the next pose and provides the Jacobians with
respect to the pose and the control, and the covariance U of its control from the ``filter``
section. A model that declares an ``input_bias`` (:class:`~radarslam.models.input_bias.InputBias`)
supports the odometry-bias states of ``filter.odometry_bias = "states"`` (docs/method.md c.11).
The filter picks one by ``filter.motion_model`` through the registry
:data:`radarslam.core.registry.MOTION_MODELS`; a model registered there from any code is selectable.
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from radarslam.core.angles import wrap_2pi_scalar
from radarslam.core.registry import MOTION_MODELS
from radarslam.models.input_bias import TURN_RATE_KEYS, InputBias


def unicycle_step(x: float, y: float, theta: float, v: float, psi: float, dt: float) -> np.ndarray:
    """:meth:`UnicycleModel.step` of the pose ``(x, y, theta)`` with control ``(v, psi)`` (APSIPA
    eq. 5). A kernel: numba compiles it as it is (the fused engine's prediction)."""
    a = theta + 0.5 * dt * psi
    return np.array([x + v * dt * math.cos(a), y + v * dt * math.sin(a), wrap_2pi_scalar(theta + psi * dt)])


def unicycle_jacobians(theta: float, v: float, psi: float, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """``(F_x (3, 3), F_u (3, 2))`` of :func:`unicycle_step` (APSIPA App. A with
    A = sin(theta + dt psi/2), B = cos(theta + dt psi/2)). A kernel: numba compiles it as it is."""
    a = theta + 0.5 * dt * psi
    A, B = math.sin(a), math.cos(a)
    Fx = np.array([[1.0, 0.0, -dt * v * A], [0.0, 1.0, dt * v * B], [0.0, 0.0, 1.0]])
    # The reference code has Fu[2, 1] = 1 (h.14); the derivative is dt.
    Fu = np.array([[dt * B, -0.5 * dt * dt * v * A], [dt * A, 0.5 * dt * dt * v * B], [0.0, dt]])
    return Fx, Fu


class MotionModel(Protocol):
    """What the EKF prediction needs from a motion model."""

    name: str

    def step(self, pose: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """Next pose (3,), heading wrapped to [0, 2 pi)."""

    def jacobians(self, pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F_x (3, 3), F_u (3, 2))`` evaluated at ``(pose, u)``."""

    def control_cov(self, filter_config) -> np.ndarray:
        """U: covariance (2, 2) of the control noise, from the ``filter`` config section."""


class UnicycleModel:
    """The car park's model, APSIPA eq. (5): control ``u = [v, psi]`` (m/s, rad/s).

    x_k = x + v dt cos(theta + dt psi / 2),  y_k = y + v dt sin(theta + dt psi / 2),
    theta_k = theta + psi dt.
    """

    name = "unicycle"
    #: c.11: a speed scale on v and a turn-rate offset (rad/s) on psi.
    input_bias = InputBias((0,), 1, ("speed_scale", "turn_rate_offset"), ("1", "rad/s"), TURN_RATE_KEYS)
    #: c.2.1: F_x's heading column is (-dy, dx) of the increment: first-estimates Jacobians apply.
    se2_increment = True

    def step(self, pose: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        return unicycle_step(float(pose[0]), float(pose[1]), float(pose[2]), float(u[0]), float(u[1]), dt)

    def jacobians(self, pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        return unicycle_jacobians(float(pose[2]), float(u[0]), float(u[1]), dt)

    def control_cov(self, filter_config) -> np.ndarray:
        """diag(sigma_v^2, sigma_psi^2): speed and turn-rate noise (APSIPA Table I)."""
        return np.diag([filter_config.speed_std_mps ** 2, math.radians(filter_config.turn_rate_std_deg_s) ** 2])


def make_unicycle(filter_config) -> UnicycleModel:
    return UnicycleModel()




def motion_model_from_config(filter_config) -> MotionModel:
    """The model named by ``filter.motion_model``, built by its registered factory from the
    ``filter`` section (:data:`radarslam.core.registry.MOTION_MODELS`)."""
    return MOTION_MODELS.create(filter_config.motion_model, filter_config)
