"""Ackermann (car-like) kinematics of the Victoria Park utility vehicle, with analytic Jacobians.

The model of Guivant & Nebot (IEEE T-RA 17(3), 2001) as documented with the dataset (ACFR
``info.txt`` and the drawing ``car.bmp``):

- the encoder measures the speed ``v_e`` of the rear-LEFT wheel and a potentiometer the steering
  angle ``alpha`` of the front wheels; control ``u = [v_e (m/s), alpha (rad)]``;
- the state pose ``[x, y, phi]`` is the position of the LASER (the GPS antenna sits there too)
  and the vehicle heading, ``phi`` in [0, 2 pi);
- geometry: wheelbase ``L``, lateral offset ``H`` of the encoder wheel from the centre line,
  laser ``a`` ahead of the FRONT axle (``L + a`` ahead of the rear axle) and ``b`` to the side.

Importing this module registers the model as ``"ackermann"`` in :data:`radarslam.core.registry.MOTION_MODELS`.

Derivation (rigid-body kinematics)
----------------------------------
Vehicle frame: origin at the centre of the rear axle ``C``, ``x`` forward, ``y`` to the LEFT.
The rear wheels do not slip sideways, so ``C`` moves with speed ``v_c`` along the heading; the
front axle centre, ``L`` ahead, is steered by ``alpha``, so the instantaneous centre of rotation
lies on the rear-axle line at ``R = L / tan(alpha)`` to the left and the yaw rate is::

    omega = phi' = v_c tan(alpha) / L.

A body point at ``p = (l, s)`` in the vehicle frame has world position ``P = C + R(phi) p`` and
velocity ``P' = v_c [cos phi, sin phi] + omega J R(phi) p`` with ``J = [[0, -1], [1, 0]]``::

    x' = v_c cos(phi) - omega (l sin(phi) + s cos(phi))
    y' = v_c sin(phi) + omega (l cos(phi) - s sin(phi))

- Encoder: the rear-left wheel is at ``p = (0, H)``; its speed along the heading is
  ``v_e = v_c - omega H = v_c (1 - tan(alpha) H / L)``, hence
  ``v_c = v_e / (1 - tan(alpha) H / L)`` (:func:`centre_speed`). Turning left (``alpha > 0``)
  the left wheel is on the inside of the turn and slower than ``C``, as it must be.
- Laser: ``p = (L + a, b)``. The equations above with ``l = L + a = 3.78 m`` and ``s = b`` are the
  literature's model, whose ``a`` is the lever arm from the REAR axle (ACFR's example code uses
  ``a = 3.78``). Here ``a`` is the distance from the front axle, as drawn in ``car.bmp``, and the
  lever arm ``l = L + a`` is formed inside; pass ``a = 0.95`` (the default), not 3.78.
- Side of ``b``: ``b > 0`` is to the LEFT. In ``car.bmp`` the laser is drawn on the same side of
  the centre line as the encoder wheel, and the documentation says the encoder is on the
  rear-left wheel; so the laser is on the left, and ``s = +b``. This is also the sign with which
  ``b`` enters the published equations.

Discretisation: one explicit Euler step of ``dt`` (odometry arrives every 25 ms)::

    x_k   = x + dt (v_c cos(phi) - omega (l sin(phi) + b cos(phi)))
    y_k   = y + dt (v_c sin(phi) + omega (l cos(phi) - b sin(phi)))
    phi_k = phi + dt omega            (wrapped to [0, 2 pi))

The single-track (bicycle) geometry is singular at ``tan(alpha) = L / H`` (75 deg here), far
outside the car's steering range of about +-0.6 rad.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_2pi_scalar
from radarslam.core.validation import as_scalar
from radarslam.models.input_bias import STEERING_KEYS, InputBias


def centre_speed(v_e: float, alpha: float, L: float, H: float) -> float:
    """Speed of the rear-axle centre from the rear-left encoder speed: ``v_e / (1 - tan(alpha) H / L)``."""
    return v_e / (1.0 - math.tan(alpha) * H / L)


def ackermann_step(x: float, y: float, phi: float, v_e: float, alpha: float, dt: float, L: float, H: float,
                   l: float, b: float) -> np.ndarray:
    """:meth:`AckermannModel.step` of the pose ``(x, y, phi)`` with control ``(v_e, alpha)``, lever
    arm ``l = L + a``. A kernel: numba compiles it as it is (the fused engine's prediction)."""
    t = math.tan(alpha)
    v_c = centre_speed(v_e, alpha, L, H)
    w = v_c * t / L
    c, s = math.cos(phi), math.sin(phi)
    return np.array([x + dt * (v_c * c - w * (l * s + b * c)),
                     y + dt * (v_c * s + w * (l * c - b * s)),
                     wrap_2pi_scalar(phi + dt * w)])


def ackermann_jacobians(phi: float, v_e: float, alpha: float, dt: float, L: float, H: float, l: float,
                        b: float) -> tuple[np.ndarray, np.ndarray]:
    """``(F_x (3, 3), F_u (3, 2))`` of :func:`ackermann_step` at heading ``phi`` and control
    ``(v_e, alpha)``. A kernel: numba compiles it as it is."""
    t = math.tan(alpha)
    sec2 = 1.0 + t * t
    g = 1.0 / (1.0 - t * H / L)          # v_c = g v_e
    v_c = g * v_e
    w = v_c * t / L
    c, s = math.cos(phi), math.sin(phi)
    A = l * s + b * c                     # x' = v_c c - w A
    B = l * c - b * s                     # y' = v_c s + w B;  dA/dphi = B, dB/dphi = -A
    Fx = np.array([[1.0, 0.0, -dt * (v_c * s + w * B)],
                   [0.0, 1.0, dt * (v_c * c - w * A)],
                   [0.0, 0.0, 1.0]])
    # d/dv_e: dv_c = g, dw = g t / L.  d/dalpha: dv_c = v_e g^2 (H / L) sec^2, dw = (dv_c t + v_c sec^2) / L.
    dvc_de, dw_de = g, g * t / L
    dvc_da = v_e * g * g * (H / L) * sec2
    dw_da = (dvc_da * t + v_c * sec2) / L
    Fu = np.array([[dt * (dvc_de * c - dw_de * A), dt * (dvc_da * c - dw_da * A)],
                   [dt * (dvc_de * s + dw_de * B), dt * (dvc_da * s + dw_da * B)],
                   [dt * dw_de, dt * dw_da]])
    return Fx, Fu


class AckermannModel:
    """Victoria Park car: control ``u = [v_e, alpha]`` (rear-left wheel speed m/s, steering rad).

    Parameters
    ----------
    L : float
        Wheelbase (m), > 0.
    H : float
        Lateral offset of the rear-left encoder wheel from the centre line (m), >= 0.
    a : float
        Laser position ahead of the FRONT axle (m); the lever arm from the rear axle is ``L + a``.
    b : float
        Laser position to the LEFT of the centre line (m); negative for the right side.

    See the module docstring for the derivation of the equations.
    """

    name = "ackermann"
    #: c.11: a wheel-speed scale on v_e and a steering offset (rad) on alpha.
    input_bias = InputBias((0,), 1, ("speed_scale", "steering_offset"), ("1", "rad"), STEERING_KEYS)
    #: c.2.1: the step adds a position increment that does not depend on the position, so F_x's
    #: heading column is (-dy, dx): first-estimates Jacobians apply (tests/test_fej.py checks it).
    se2_increment = True

    def __init__(self, L: float = 2.83, H: float = 0.76, a: float = 0.95, b: float = 0.5):
        self.L = as_scalar("ackermann.L", L, low=0.0, low_open=True)
        self.H = as_scalar("ackermann.H", H, low=0.0)
        self.a = as_scalar("ackermann.a", a)
        self.b = as_scalar("ackermann.b", b)
        self.lever = self.L + self.a  # l: laser ahead of the rear axle (m)

    def __repr__(self) -> str:
        return f"AckermannModel(L={self.L}, H={self.H}, a={self.a}, b={self.b})"

    def step(self, pose: np.ndarray, u: np.ndarray, dt: float) -> np.ndarray:
        """Next laser pose ``(3,)`` after an Euler step of ``dt``; heading wrapped to [0, 2 pi)."""
        return ackermann_step(float(pose[0]), float(pose[1]), float(pose[2]), float(u[0]), float(u[1]), dt,
                              self.L, self.H, self.lever, self.b)

    def jacobians(self, pose: np.ndarray, u: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
        """``(F_x (3, 3), F_u (3, 2))`` of :meth:`step` at ``(pose, u)``."""
        return ackermann_jacobians(float(pose[2]), float(u[0]), float(u[1]), dt, self.L, self.H, self.lever, self.b)

    def control_cov(self, filter_config) -> np.ndarray:
        """diag(sigma_v^2, sigma_alpha^2): wheel-speed and steering-angle noise."""
        return np.diag([filter_config.speed_std_mps ** 2, math.radians(filter_config.steering_std_deg) ** 2])


def make_ackermann(f) -> AckermannModel:
    """From the ``filter`` section: ``vehicle_L_m``, ``vehicle_H_m``, ``sensor_a_m``, ``sensor_b_m``."""
    return AckermannModel(L=f.vehicle_L_m, H=f.vehicle_H_m, a=f.sensor_a_m, b=f.sensor_b_m)


