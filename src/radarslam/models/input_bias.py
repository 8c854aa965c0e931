"""Systematic odometry errors of a motion model, as the model declares them (docs/method.md c.11).

A motion model that supports ``filter.odometry_bias = "states"`` carries an ``input_bias``
attribute, an :class:`InputBias`: two slowly varying bias states ``b = [eps, delta]`` that act on
its measured input ``u`` before the model sees it,

    u_c = c(u, b):   u_c[i] = (1 + eps) u[i]  for i in ``scaled``,   u_c[k] = u[k] + delta  for k = ``offset``,

every other entry unchanged. ``eps`` is a dimensionless speed-scale error (0 nominal: a wheel
radius or encoder resolution that is off by ``100 eps`` percent) and ``delta`` an additive offset
of the turning input (a steering-potentiometer offset in rad for the Ackermann model, a turn-rate
or gyro offset in rad/s for the unicycle and the body-velocity model). The model's own ``step``
and ``jacobians`` are evaluated at ``u_c``; :mod:`radarslam.slam.bias` chains them with
:meth:`InputBias.jacobians` into the Jacobians of the augmented prediction (c.11.2).

Why ``1 + eps`` and not ``exp(eps)`` (a log scale): the models' position increments are linear in
the speed, so the prediction is bilinear in ``(eps, u)`` and the linearisation in ``eps`` is exact
for the mean; a log scale would add the curvature of ``exp`` for nothing, since a scale near 0 (the
one thing a log keeps away) never occurs for a wheel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["InputBias"]


@dataclass(frozen=True)
class InputBias:
    """A speed scale ``eps`` on the inputs ``scaled`` and an offset ``delta`` on the input ``offset``.

    ``names`` and ``units`` label the two states in outputs; ``offset_keys`` names the ``filter``
    config fields (in degrees, converted to rad here) of the offset's prior std and drift; the
    scale's are ``bias_scale_std`` and ``bias_scale_drift_per_rt_s`` for every model.
    """

    scaled: tuple[int, ...]
    offset: int
    names: tuple[str, str]
    units: tuple[str, str]
    offset_keys: tuple[str, str]

    #: Number of bias states.
    dim = 2

    def correct(self, u: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``u_c = c(u, b)`` (m,): the input with the bias states ``b = [eps, delta]`` applied."""
        uc = np.array(u, dtype=float)
        for i in self.scaled:
            uc[i] = (1.0 + b[0]) * uc[i]
        uc[self.offset] = uc[self.offset] + b[1]
        return uc

    def jacobians(self, u: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(C_u (m, m), C_b (m, 2))``: ``d u_c / d u`` (diagonal: ``1 + eps`` on the scaled inputs,
        1 elsewhere) and ``d u_c / d b`` (``u[i]`` in column 0 for the scaled inputs, 1 in column 1
        at the offset)."""
        m = len(u)
        Cu = np.eye(m)
        Cb = np.zeros((m, 2))
        for i in self.scaled:
            Cu[i, i] = 1.0 + b[0]
            Cb[i, 0] = u[i]
        Cb[self.offset, 1] = 1.0
        return Cu, Cb

    def prior_std(self, f) -> np.ndarray:
        """The prior std ``(2,)`` of ``[eps, delta]`` from the ``filter`` config section ``f``."""
        return np.array([f.bias_scale_std, math.radians(getattr(f, self.offset_keys[0]))])

    def drift(self, f) -> np.ndarray:
        """The random-walk intensity ``(2,)`` of ``[eps, delta]`` (per sqrt(s)) from ``f``."""
        return np.array([f.bias_scale_drift_per_rt_s, math.radians(getattr(f, self.offset_keys[1]))])


#: The unicycle's ``[v, psi]`` and the body-velocity model's ``[v_x, v_y, omega]``: a speed scale and
#: a turn-rate (gyro) offset in rad/s.
TURN_RATE_KEYS = ("bias_turn_rate_std_deg_s", "bias_turn_rate_drift_deg_s_per_rt_s")
#: The Ackermann model's ``[v_e, alpha]``: a wheel-speed scale and a steering offset in rad.
STEERING_KEYS = ("bias_steering_std_deg", "bias_steering_drift_deg_per_rt_s")
