"""The platform trajectory (docs/method.md b.2) and the odometer (b.3)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.config import OdometerConfig, TrajectoryConfig
from radarslam.core.angles import wrap_2pi_scalar
from radarslam.models.motion import UnicycleModel


def commanded_controls(traj: TrajectoryConfig) -> np.ndarray:
    """True controls ``u_k = [v, psi]`` for k = 1..K as rows ``(K, 2)``.

    [PROP] convention of b.2: pose k comes from pose k-1 with u_k, psi != 0 for
    ``turn_start <= k <= turn_end``. Row 0 (u_1) is never applied: pose 1 is the initial pose.
    """
    k = np.arange(1, traj.n_steps + 1)
    u = np.zeros((traj.n_steps, 2))
    u[:, 0] = traj.speed_mps
    u[(k >= traj.turn_start) & (k <= traj.turn_end), 1] = traj.turn_rate_rad_s
    return u


def noise_free_path(traj: TrajectoryConfig) -> np.ndarray:
    """Poses ``(K, 3)`` of the commanded controls without process noise."""
    return true_path(traj, np.zeros((traj.n_steps, 3)))


def true_path(traj: TrajectoryConfig, process_noise: np.ndarray) -> np.ndarray:
    """Poses ``(K, 3)``: APSIPA eq. (5) with the process noise ``omega_k`` (row k-1) added."""
    model = UnicycleModel()
    u = commanded_controls(traj)
    poses = np.empty((traj.n_steps, 3))
    poses[0] = traj.initial_pose
    poses[0, 2] = wrap_2pi_scalar(poses[0, 2])
    for k in range(1, traj.n_steps):
        p = model.step(poses[k - 1], u[k], traj.dt_s) + process_noise[k]
        p[2] = wrap_2pi_scalar(p[2])
        poses[k] = p
    return poses


def process_noise(traj: TrajectoryConfig, rng: np.random.Generator) -> np.ndarray:
    """``omega_k ~ N(0, Q)`` for k = 1..K, ``(K, 3)``; row 0 is zero (no motion into pose 1)."""
    std = np.sqrt([traj.process_var_xy_m2, traj.process_var_xy_m2, traj.process_var_heading_rad2])
    w = rng.standard_normal((traj.n_steps, 3)) * std
    w[0] = 0.0
    return w


def odometer_readings(controls: np.ndarray, odo: OdometerConfig, rng: np.random.Generator) -> np.ndarray:
    """``u_bar_k = u_k + eta_k + bias`` with ``eta ~ N(0, U)`` (APSIPA eq. 6), ``(K, 2)``."""
    std = np.array([odo.speed_std_mps, math.radians(odo.turn_rate_std_deg_s)])
    bias = np.array([odo.speed_bias_mps, math.radians(odo.turn_rate_bias_deg_s)])
    return controls + rng.standard_normal(controls.shape) * std + bias
