"""Systematic odometry errors of a motion model, as the model declares them (docs/method.md c.11).

A motion model that supports ``filter.odometry_bias = "states"`` carries an ``input_bias``
attribute, an :class:`InputBias`: two slowly varying bias states ``b = [eps, delta]`` that act on
its measured input ``u`` before the model sees it,

    u_c = c(u, b):   u_c[i] = (1 + eps) u[i]  for i in ``scaled``,   u_c[k] = u[k] + delta  for k = ``offset``,

every other entry unchanged. The turning input's error may instead be a *scale* (``turn = "scale"``,
``b = [eps, kappa]``: ``u_c[k] = (1 + kappa) u[k]``, an error proportional to the turn, c.11.8) or both
(``turn = "both"``, ``b = [eps, delta, kappa]``: ``u_c[k] = (1 + kappa) u[k] + delta``). ``eps`` is a dimensionless speed-scale error (0 nominal: a wheel
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
from dataclasses import dataclass, replace

import numpy as np

__all__ = ["InputBias", "TURN_BOTH", "TURN_CODES", "TURN_OFFSET", "TURN_SCALE", "correct_input",
           "input_jacobians", "turn_terms"]


#: The turning input's error (``InputBias.turn``) as the kernels take it: an offset, a scale or both.
TURN_OFFSET, TURN_SCALE, TURN_BOTH = 0, 1, 2
TURN_CODES = {"offset": TURN_OFFSET, "scale": TURN_SCALE, "both": TURN_BOTH}


def turn_terms(b, turn):
    """``(delta, kappa)``: the turning input's offset and scale among the bias states ``b`` of the
    turn form ``turn`` (TURN_OFFSET ``b = [eps, delta]``, TURN_SCALE ``[eps, kappa]``, TURN_BOTH
    ``[eps, delta, kappa]``). A kernel (the fused engine compiles it as it is)."""
    if turn == TURN_OFFSET:
        return b[1], 0.0
    if turn == TURN_SCALE:
        return 0.0, b[1]
    return b[1], b[2]


def correct_input(u, b, scaled, offset, turn):
    """``u_c = c(u, b)`` (m,), a new array: ``(1 + eps) u[i]`` for ``i`` in ``scaled`` (int64 indices),
    ``(1 + kappa) u[k] + delta`` at ``k = offset`` (:func:`turn_terms`), every other entry as it is.
    A kernel (the fused engine compiles it as it is)."""
    uc = u.copy()
    for a in range(scaled.shape[0]):
        i = scaled[a]
        uc[i] = (1.0 + b[0]) * uc[i]
    delta, kappa = turn_terms(b, turn)
    uc[offset] = (1.0 + kappa) * uc[offset] + delta
    return uc


def input_jacobians(u, b, scaled, offset, turn):
    """``(C_u (m, m), C_b (m, dim))``: ``d u_c / d u`` (diagonal: ``1 + eps`` on the scaled inputs,
    ``1 + kappa`` on the turning input, 1 elsewhere) and ``d u_c / d b`` (``u[i]`` in column 0 for
    the scaled inputs; at the turning input 1 in the offset's column, ``u[k]`` in the scale's) of
    :func:`correct_input`. A kernel (the fused engine compiles it as it is)."""
    m, k = u.shape[0], offset
    Cu = np.eye(m)
    Cb = np.zeros((m, b.shape[0]))                          # a thrust state's column (c.11.12) stays 0
    for a in range(scaled.shape[0]):
        i = scaled[a]
        Cu[i, i] = 1.0 + b[0]
        Cb[i, 0] = u[i]
    Cu[k, k] = 1.0 + turn_terms(b, turn)[1]
    if turn == TURN_OFFSET:
        Cb[k, 1] = 1.0
    elif turn == TURN_SCALE:
        Cb[k, 1] = u[k]
    else:
        Cb[k, 1], Cb[k, 2] = 1.0, u[k]
    return Cu, Cb


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
    #: The turning input's error: "offset" (delta), "scale" (kappa) or "both" (delta and kappa; c.11.8).
    turn: str = "offset"
    #: A thrust-angle state ``beta`` last (c.11.12): the rear axle moves at ``beta`` from the heading.
    #: It does not act on the input (its column of ``C_b`` is 0) but turns the pose's increment,
    #: :func:`radarslam.slam.bias.thrust_turn`.
    thrust: bool = False

    @property
    def dim(self) -> int:
        """Number of bias states: 2 (speed scale and the turn's offset or scale), 3 with both; one
        more with the thrust angle."""
        return (3 if self.turn == "both" else 2) + int(self.thrust)

    def with_thrust(self, on: bool) -> "InputBias":
        """This bias with (``on``) or without the thrust-angle state, last, named ``thrust_angle`` (rad)."""
        if on == self.thrust:
            return self
        names, units = (self.names + ("thrust_angle",), self.units + ("rad",)) if on else \
            (self.names[:-1], self.units[:-1])
        return replace(self, thrust=on, names=names, units=units)

    def with_turn(self, turn: str) -> "InputBias":
        """This model's bias with the turning input's error of form ``turn`` (c.11.8), its states'
        names and units to match (the scale's name: the offset's with ``_scale``, unit 1)."""
        scale_name = self.names[1].replace("_offset", "") + "_scale"
        names, units = {"offset": (self.names, self.units),
                        "scale": ((self.names[0], scale_name), (self.units[0], "1")),
                        "both": (self.names + (scale_name,), self.units + ("1",))}[turn]
        return replace(self, turn=turn, names=names, units=units)

    @property
    def turn_code(self) -> int:
        """The turning input's error as the kernels take it: TURN_OFFSET, TURN_SCALE or TURN_BOTH."""
        return TURN_CODES[self.turn]

    @property
    def scaled_index(self) -> np.ndarray:
        """The scaled inputs as the kernels take them: an int64 array."""
        return np.array(self.scaled, dtype=np.int64)

    def _turn(self, b) -> tuple[float, float]:
        """``(delta, kappa)`` of the bias states ``b``: the turning input's offset and scale."""
        return turn_terms(b, self.turn_code)

    def correct(self, u: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``u_c = c(u, b)`` (m,): the input with the bias states ``b`` applied (:func:`correct_input`)."""
        return correct_input(np.asarray(u, dtype=float), np.asarray(b, dtype=float), self.scaled_index,
                             self.offset, self.turn_code)

    def uncorrect(self, u: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``c^{-1}(u, b)``: the reading whose correction is ``u`` (the simulator's biased odometer)."""
        um = np.array(u, dtype=float)
        for i in self.scaled:
            um[i] = um[i] / (1.0 + b[0])
        delta, kappa = self._turn(b)
        um[self.offset] = (um[self.offset] - delta) / (1.0 + kappa)
        return um

    def jacobians(self, u: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(C_u (m, m), C_b (m, dim))`` of :func:`input_jacobians`."""
        return input_jacobians(np.asarray(u, dtype=float), np.asarray(b, dtype=float), self.scaled_index,
                               self.offset, self.turn_code)

    def _turn_values(self, offset: float, scale: float) -> list[float]:
        return {"offset": [offset], "scale": [scale], "both": [offset, scale]}[self.turn]

    def _thrust_values(self, value_deg: float) -> list[float]:
        return [math.radians(value_deg)] if self.thrust else []

    def prior_std(self, f) -> np.ndarray:
        """The prior std ``(dim,)`` of the states from the ``filter`` config section ``f``."""
        return np.array([f.bias_scale_std, *self._turn_values(math.radians(getattr(f, self.offset_keys[0])),
                                                               f.bias_turn_scale_std),
                         *self._thrust_values(f.bias_thrust_std_deg)])

    def drift(self, f) -> np.ndarray:
        """The random-walk intensity ``(dim,)`` of the states (per sqrt(s)) from ``f``."""
        return np.array([f.bias_scale_drift_per_rt_s,
                         *self._turn_values(math.radians(getattr(f, self.offset_keys[1])),
                                            f.bias_turn_scale_drift_per_rt_s),
                         *self._thrust_values(f.bias_thrust_drift_deg_per_rt_s)])


#: The unicycle's ``[v, psi]`` and the body-velocity model's ``[v_x, v_y, omega]``: a speed scale and
#: a turn-rate (gyro) offset in rad/s.
TURN_RATE_KEYS = ("bias_turn_rate_std_deg_s", "bias_turn_rate_drift_deg_s_per_rt_s")
#: The Ackermann model's ``[v_e, alpha]``: a wheel-speed scale and a steering offset in rad.
STEERING_KEYS = ("bias_steering_std_deg", "bias_steering_drift_deg_per_rt_s")
