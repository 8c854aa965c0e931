"""Each radar's yaw offset as a state (docs/method.md c.13.1): a mounting's boresight that is off by
``psi_j`` from the rig's stated yaw, learnt through the landmarks.

Under ``filter.radar_yaw_states`` the platform block ends with one state ``psi_j`` per radar of the
rig (``EstimatorConfig.rig``'s ``sensor_id``, the config's ``sensors``, in sensor-id order), after the odometry-bias states (c.11). A scan from
radar ``j`` is measured from the sensor pose (c.13)

    s = (t + R(theta) [m_x, m_y],  theta + m_yaw + psi_j),

so the offset turns the radar about its own position: the sensor's position does not depend on it.
For the span of the scan the pose block becomes ``s``: after c.13's lever-arm shear the heading row
gains the offset's, ``theta_s = theta + m_yaw + psi_j``, ``P <- G_psi P G_psi^T`` with ``G_psi`` the
identity plus a 1 at (heading, psi_j): the heading's row and column gain psi_j's. The scan's steps
then run unchanged about the sensor; the update's gain reaches ``psi_j`` through its covariance with
the sensor's heading, as with ``H_psi = dh/dtheta_s`` in the measurement model. After the scan
the heading row loses it again (``theta_s - psi_j``), before c.13's inverse. ``G_psi`` is linear and
exact: no linearisation is added. The prediction carries each ``psi_j`` as a random walk of drift
``filter.radar_yaw_drift_deg_per_rt_s`` (0: a constant of the car) beside the odometry biases
(``slam/bias.py``, their ``C_b`` column 0: the odometry does not see them).

What is observable: one common offset of every radar together with the heading and the thrust
angle (c.11.12) is not (a rotation of the whole rig); with ``filter.radar_yaw_reference = "rig"``
the offsets are held to a zero mean (a pseudo-measurement ``sum_j psi_j = 0`` of std
``ZERO_MEAN_STD`` on the initial state), so the rig as a whole defines the car's axis as in the
calibration (c.16); each radar's offset against the others is then observable as soon as two
radars see landmarks in common (or landmarks mapped by one are seen by another).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.slam.rig_states import PerRadarStates, rig_ids

__all__ = ["ZERO_MEAN_STD", "RadarYawStates", "enter_yaw", "leave_yaw", "radar_yaw_states", "zero_mean_update"]


#: The std (rad) of the pseudo-measurement that holds the rig's mean yaw offset at zero.
ZERO_MEAN_STD = 1e-6


def enter_yaw(x: np.ndarray, P: np.ndarray, heading: int, i: int) -> None:
    """``theta_s += psi`` (in place): the heading (index ``heading``) of a state ``(x, P)`` gains the
    offset at index ``i``, ``P <- G P G^T`` with ``G = I + e_heading e_i^T``. A kernel."""
    x[heading] += x[i]
    P[heading, :] += P[i, :]
    P[:, heading] += P[:, i]


def leave_yaw(x: np.ndarray, P: np.ndarray, heading: int, i: int) -> None:
    """The inverse of :func:`enter_yaw` (in place): ``G^{-1} = I - e_heading e_i^T``. A kernel."""
    x[heading] -= x[i]
    P[heading, :] -= P[i, :]
    P[:, heading] -= P[:, i]


def zero_mean_update(x: np.ndarray, P: np.ndarray, idx: np.ndarray, std: float) -> None:
    """The pseudo-measurement ``sum_j x[idx_j] = 0`` with std ``std`` (in place, Joseph form): the rig's
    mean yaw offset held at zero (module docstring)."""
    n = x.shape[0]
    H = np.zeros(n)
    H[idx] = 1.0
    PH = P @ H
    S = float(H @ PH) + std * std
    K = PH / S
    x -= K * float(H @ x)
    A = np.eye(n) - np.outer(K, H)
    P[:] = A @ P @ A.T + (std * std) * np.outer(K, K)
    P[:] = 0.5 * (P + P.T)


class RadarYawStates(PerRadarStates):
    """The rig's yaw-offset states: their sensor ids (in state order), prior std and drift (rad,
    rad/sqrt(s)) and whether the rig's mean is held at zero."""

    prefix = "yaw_offset"

    def __init__(self, sensor_ids, prior_std: float, drift: float, zero_mean: bool):
        super().__init__(sensor_ids, prior_std, drift)
        self.zero_mean = bool(zero_mean)


def radar_yaw_states(config) -> RadarYawStates | None:
    """The yaw-offset states of ``config`` (``filter.radar_yaw_states``), or None; one-line
    :class:`ConfigError` without the odometry-bias states' block or without a rig."""
    f = config.filter
    if not f.radar_yaw_states:
        return None
    ids = rig_ids(config, "radar_yaw_states", "c.13.1")
    return RadarYawStates(ids, math.radians(f.radar_yaw_std_deg), math.radians(f.radar_yaw_drift_deg_per_rt_s),
                          f.radar_yaw_reference == "rig")
