"""The fused engine's prediction with odometry-bias states (docs/method.md c.11; ``filter.odometry_bias
= "states"``): the platform block is then ``[x, y, theta, b_1 .. b_m]`` (``cfg.platform = 3 + m``)
and each prediction runs the kernels of :class:`~radarslam.slam.bias.BiasStates`,
compiled as they are: the correction of the input by the bias and its Jacobians
(:func:`~radarslam.models.input_bias.correct_input`, :func:`~radarslam.models.input_bias.input_jacobians`),
the bias states' transition (:func:`~radarslam.slam.bias.bias_transition`) and the platform block's
prediction (:func:`~radarslam.slam.bias.platform_prediction`), around the motion model's own step and
Jacobians (:func:`~radarslam.slam.fused.tracking._motion`). Without bias states (``cfg.platform == 3``)
:func:`predict_platform` is :func:`~radarslam.slam.fused.tracking.predict` itself; the engine calls
:func:`predict_step`, where that is a compile-time flag of its family.
"""

from __future__ import annotations

import math

from numba import njit

from radarslam.core.jit import compile_kernels, compiled_only
from radarslam.models.input_bias import correct_input, input_jacobians, turn_terms
from radarslam.slam.state_loops import write_platform_rows
from radarslam.slam.bias import bias_transition, platform_jacobian, platform_prediction, thrust_turn
from radarslam.slam.fused.tracking import _fej_motion_jacobian, _motion, predict
from radarslam.slam.layout import POSE_DIM

_K = compile_kernels(turn_terms, correct_input, input_jacobians, bias_transition, platform_jacobian,
                     platform_prediction, thrust_turn)
_correct_input = _K["correct_input"]
_input_jacobians = _K["input_jacobians"]
_bias_transition = _K["bias_transition"]
_platform_prediction = _K["platform_prediction"]
_thrust_turn = _K["thrust_turn"]


@njit(cache=True, inline="always")
def _finite(a):  # pragma: no cover - compiled
    for v in a.ravel():
        if not math.isfinite(v):
            return False
    return True


@njit(cache=True, inline="always")
def predict_platform(x, P, u, dt, U, Q, pose_first, model, cfg):  # pragma: no cover - compiled
    """c.2, or with bias states c.11.2 (:meth:`radarslam.slam.bias.BiasStates.predict_terms`), in
    place: the model ``model`` steps at the input ``u`` corrected by the bias states ``x[3:p]``
    (``cfg.bias_scaled``, ``cfg.bias_offset``, ``cfg.bias_turn``), the bias decays and drifts
    (``cfg.bias_drift``, ``cfg.bias_tau``); with ``cfg.fej`` the pose Jacobian's heading column from
    ``pose_first``, which then becomes the new pose (c.2.1, c.11.7). Returns False, leaving the
    state as it was, if the prediction is not finite. The engine calls :func:`predict_step`."""
    return predict_step(x, P, u, dt, U, Q, pose_first, model, cfg, cfg.platform > POSE_DIM)


@njit(cache=True, inline="always")
def predict_step(x, P, u, dt, U, Q, pose_first, model, cfg, bias):  # pragma: no cover - compiled
    """:func:`predict_platform` with ``bias`` (``cfg.platform > 3``) the engine's compile-time flag
    (engine.Family): without it the prediction of c.2 alone, and the bias states' code pruned."""
    if bias:
        return predict_biased(x, P, u, dt, U, Q, pose_first, model, cfg)
    return predict(x, P, u, dt, U, Q, pose_first, model, cfg)


@compiled_only
def predict_biased(x, P, u, dt, U, Q, pose_first, model, cfg):  # pragma: no cover - compiled
    """:func:`predict_platform` with the bias states (c.11.2)."""
    p = cfg.platform
    b = x[POSE_DIM:p].copy()
    uc = _correct_input(u, b, cfg.bias_scaled, cfg.bias_offset, cfg.bias_turn)
    Cu, Cb = _input_jacobians(u, b, cfg.bias_scaled, cfg.bias_offset, cfg.bias_turn)
    pose, Fx, Fu = _motion(x, uc, dt, model, cfg)
    if cfg.bias_thrust >= 0:                                # c.11.12: the increment turned by the thrust angle
        pose, Fx, Fu, Fb = _thrust_turn(x[:POSE_DIM], pose, Fx, Fu, Cb, b, cfg.bias_thrust)
    else:
        Fb = Fu @ Cb
    if cfg.fej:
        Fx = _fej_motion_jacobian(Fx, pose, pose_first)
    phi, qb = _bias_transition(dt, cfg.bias_drift, cfg.bias_tau)
    s, Pss, Psl = _platform_prediction(pose, b, P, Fx, Fu, Cu, Fb, phi, qb, U, Q)
    if not (_finite(s) and _finite(Pss) and _finite(Psl)):
        return False
    x[:p] = s
    write_platform_rows(P, Pss, Psl)
    if cfg.fej:
        pose_first[0], pose_first[1], pose_first[2] = s[0], s[1], s[2]
    return True
