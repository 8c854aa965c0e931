"""Range-azimuth radar: the measurement function, its Jacobians, and the polar <-> xy conversions.

Notation (APSIPA eq. 8, App. B-C; seed eq. 3): pose ``[x, y, theta]``, landmark ``p = [px, py]``,
``dx = px - x``, ``dy = py - y``, ``r = hypot(dx, dy)``; azimuth relative to the heading.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_pi, wrap_pi_scalar


def range_azimuth(pose: np.ndarray, p: np.ndarray) -> np.ndarray:
    """h(x, p) = [r, atan2(dy, dx) - theta] with the azimuth wrapped to (-pi, pi]; shape (2,)."""
    dx, dy = float(p[0] - pose[0]), float(p[1] - pose[1])
    return np.array([math.hypot(dx, dy), wrap_pi_scalar(math.atan2(dy, dx) - float(pose[2]))])


def range_azimuth_jacobians(pose: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(H_pose (2, 3), H_p (2, 2))`` of :func:`range_azimuth` (APSIPA App. B)."""
    dx, dy = float(p[0] - pose[0]), float(p[1] - pose[1])
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    Hx = np.array([[-dx / r, -dy / r, 0.0], [dy / q, -dx / q, -1.0]])
    Hp = np.array([[dx / r, dy / r], [-dy / q, dx / q]])
    return Hx, Hp


def polar_to_xy(pose: np.ndarray, polar: np.ndarray) -> np.ndarray:
    """Seed eq. (3): world-frame points ``(m, 2)`` of detections ``polar (m, 2)`` seen from ``pose``."""
    psi = pose[2] + polar[:, 1]
    out = np.empty((polar.shape[0], 2))
    out[:, 0] = pose[0] + polar[:, 0] * np.cos(psi)
    out[:, 1] = pose[1] + polar[:, 0] * np.sin(psi)
    return out


def xy_to_polar(pose: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Inverse of :func:`polar_to_xy`: ``(m, 2)`` of ``[range, azimuth]``."""
    d = xy - pose[:2]
    return np.column_stack([np.hypot(d[:, 0], d[:, 1]), wrap_pi(np.arctan2(d[:, 1], d[:, 0]) - pose[2])])


def inverse_jacobians(pose: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of seed eq. (3) / APSIPA App. C: ``(G_x (2, 3), G_s (2, 2))`` at detection ``s = [r, phi]``.

    These are the seed's eqs. (6)-(7); the same matrices initialise a new landmark (APSIPA eq. 10-11).
    """
    r = float(s[0])
    a = float(pose[2]) + float(s[1])
    c, sn = math.cos(a), math.sin(a)
    Gx = np.array([[1.0, 0.0, -r * sn], [0.0, 1.0, r * c]])
    Gs = np.array([[c, -r * sn], [sn, r * c]])
    return Gx, Gs


class RangeAzimuthModel:
    """The range-azimuth sensor, the one measurement model built in (``filter.measurement_model =
    "range-azimuth"``; no registry: the EKF kernels of :mod:`radarslam.slam.ekf`, the associators and
    the fused engine are written for it): the measurement function, its Jacobians and the polar <->
    world conversions of this module, bound to one object the filter holds.

    The EKF kernels of :mod:`radarslam.slam.ekf` (sparse Jacobian, log distance) are written for
    this model; an associator for another sensor model brings its own.
    """

    name = "range-azimuth"

    measure = staticmethod(range_azimuth)
    jacobians = staticmethod(range_azimuth_jacobians)
    to_world = staticmethod(polar_to_xy)
    to_sensor = staticmethod(xy_to_polar)
    inverse_jacobians = staticmethod(inverse_jacobians)

    def noise(self, filter_config) -> np.ndarray:
        """R = diag(sigma_r^2, sigma_phi^2) of the ``filter`` section (APSIPA Table I)."""
        return filter_config.R




