"""Platform motion models.

A motion model maps ``(pose, control, dt)`` to the next pose and provides the Jacobians with
respect to the pose and the control. The filter picks one by name (:func:`get_motion_model`).
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from radarslam.core.angles import wrap_2pi_scalar
from radarslam.core.errors import InputError


class MotionModel(Protocol):
    """What the EKF prediction needs from a motion model."""

    name: str

    def step(self, pose: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """Next pose (3,), heading wrapped to [0, 2 pi)."""

    def jacobians(self, pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F_x (3, 3), F_u (3, 2))`` evaluated at ``(pose, u)``."""


class UnicycleModel:
    """The car park's model, APSIPA eq. (5): control ``u = [v, psi]`` (m/s, rad/s).

    x_k = x + v dt cos(theta + dt psi / 2),  y_k = y + v dt sin(theta + dt psi / 2),
    theta_k = theta + psi dt.
    """

    name = "unicycle"

    def step(self, pose: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        v, psi = float(u[0]), float(u[1])
        a = float(pose[2]) + 0.5 * dt * psi
        return np.array([pose[0] + v * dt * math.cos(a), pose[1] + v * dt * math.sin(a),
                         wrap_2pi_scalar(float(pose[2]) + psi * dt)])

    def jacobians(self, pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        # APSIPA App. A with A = sin(theta + dt psi/2), B = cos(theta + dt psi/2).
        v, psi = float(u[0]), float(u[1])
        a = float(pose[2]) + 0.5 * dt * psi
        A, B = math.sin(a), math.cos(a)
        Fx = np.array([[1.0, 0.0, -dt * v * A], [0.0, 1.0, dt * v * B], [0.0, 0.0, 1.0]])
        # The reference code has Fu[2, 1] = 1 (h.14); the derivative is dt.
        Fu = np.array([[dt * B, -0.5 * dt * dt * v * A], [dt * A, 0.5 * dt * dt * v * B], [0.0, dt]])
        return Fx, Fu


_MODELS: dict[str, type] = {"unicycle": UnicycleModel}
#: Models living in their own module, imported on first use (they register themselves).
_LAZY_MODELS = {"ackermann": "radarslam.models.ackermann"}


def register_motion_model(name: str, cls: type) -> None:
    """Make a motion model selectable by ``filter.motion_model = name``."""
    _MODELS[name] = cls


def get_motion_model(name: str, **kwargs) -> MotionModel:
    """The motion model registered under ``name``."""
    if name not in _MODELS and name in _LAZY_MODELS:
        import importlib

        importlib.import_module(_LAZY_MODELS[name])
    try:
        return _MODELS[name](**kwargs)
    except KeyError:
        raise InputError(f"motion_model: expected one of {sorted(_MODELS)}, got {name!r}") from None
