"""Odometry-bias states in the EKF's platform block (docs/method.md c.11).

Under ``filter.odometry_bias = "states"`` the state opens with ``s = [x, y, theta, eps, delta]``:
the pose and the motion model's two bias states (its
:class:`~radarslam.models.input_bias.InputBias`), each a random walk, or with
``filter.bias_tau_s > 0`` a first-order Gauss-Markov process, about its nominal 0. The prediction
with the odometer reading ``u`` over ``dt`` (c.11.2):

    pose' = f(pose, c(u, b), dt),   b' = Phi b,   Phi = diag(phi),  phi = exp(-dt / tau) (1 for a random walk),

    F_s = [[F_x, F_u C_b], [0, Phi]],   G = F_u C_u,
    P_ss <- F_s P_ss F_s^T + blockdiag(G U G^T + Q, Q_b),   P_sl <- F_s P_sl,

with ``F_x, F_u`` the model's Jacobians at the corrected input ``c(u, b)``, ``C_u, C_b`` those of
the correction, and ``Q_b = diag(q^2 tau / 2 (1 - phi^2))`` (``q^2 dt`` for the random walk), ``q``
the drift. The measurements do not depend on ``b``; SLAM learns it through ``P_sl``.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import ConfigError
from radarslam.slam import ekf
from radarslam.slam.layout import POSE_DIM
from radarslam.slam.state import SlamState

__all__ = ["BiasStates", "bias_states", "bias_transition", "control_noise", "initial_state", "measurement_noise",
           "platform_jacobian", "platform_prediction", "predict_terms", "thrust_turn", "turn_noise", "turn_noise_index"]


class BiasStates:
    """The bias states of a filter: the model's :class:`~radarslam.models.input_bias.InputBias`
    ``spec``, their prior std ``(m,)``, drift ``(m,)`` (per sqrt(s)) and time constant ``tau`` (s;
    0 = random walk)."""

    def __init__(self, spec, prior_std: np.ndarray, drift: np.ndarray, tau: float, yaw=None, time=None):
        self.spec = spec
        #: Each radar's yaw offset (a :class:`~radarslam.slam.radar_yaw.RadarYawStates`, c.13.1), after
        #: the model's states, or None.
        self.yaw = yaw
        #: Each radar's time offset (a :class:`~radarslam.slam.radar_time.RadarTimeStates`, c.13.2),
        #: after the yaw offsets, or None.
        self.time = time
        extra = [(s.dim, s.prior_std, s.drift) for s in (yaw, time) if s is not None]
        self.prior_std = np.concatenate([np.asarray(prior_std, dtype=float)] + [np.full(n, sd) for n, sd, _ in extra])
        self.drift = np.concatenate([np.asarray(drift, dtype=float)] + [np.full(n, q) for n, _, q in extra])
        self.tau = float(tau)
        n_yaw = 0 if yaw is None else yaw.dim
        n_time = 0 if time is None else time.dim
        self.dim = int(spec.dim) + n_yaw + n_time
        self.names = tuple(spec.names) + (() if yaw is None else yaw.names) + (() if time is None else time.names)
        self.units = tuple(spec.units) + ("rad",) * n_yaw + ("s",) * n_time
        #: The thrust angle's position among the states (c.11.12), -1 without it.
        self.thrust_index = int(spec.dim) - 1 if spec.thrust else -1

    def yaw_index(self, sensor_id: int) -> int | None:
        """The state index (in the whole state) of radar ``sensor_id``'s yaw offset, or None."""
        if self.yaw is None:
            return None
        j = self.yaw.position(sensor_id)
        return None if j is None else POSE_DIM + int(self.spec.dim) + j

    def time_index(self, sensor_id: int) -> int | None:
        """The state index (in the whole state) of radar ``sensor_id``'s time offset (c.13.2), or None."""
        if self.time is None:
            return None
        j = self.time.position(sensor_id)
        return None if j is None else POSE_DIM + int(self.spec.dim) + (0 if self.yaw is None else self.yaw.dim) + j

    @property
    def platform_dim(self) -> int:
        """The size of the platform block: the pose and the bias states."""
        return POSE_DIM + self.dim

    def transition(self, dt: float) -> tuple[float, np.ndarray]:
        """``(phi, Q_b (m,))`` of :func:`bias_transition` over ``dt``."""
        return bias_transition(dt, self.drift, self.tau)

    def jacobians(self, pose: np.ndarray, b: np.ndarray, u: np.ndarray, dt: float, model):
        """``(F_s (p, p), G (3, len(u)), u_c)``: the platform block's transition Jacobian
        ``[[F_x, F_u C_b], [0, Phi]]`` (:func:`platform_jacobian`), the Jacobian of the new pose in
        the measured input ``F_u C_u``, and the corrected input (c.11.2)."""
        uc = self.spec.correct(u, b)
        Cu, Cb = self.spec.jacobians(u, b)
        Fx, Fu = model.jacobians(pose, uc, dt)
        _, Fx, Fu, Fb = _thrust(self.thrust_index, pose, model.step(pose, uc, dt), Fx, Fu, Cb, b)
        phi, _ = self.transition(dt)
        return platform_jacobian(Fx, Fb, phi), Fu @ Cu, uc

    def predict_terms(self, x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, model, U: np.ndarray,
                      Q: np.ndarray, pose_first: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:func:`radarslam.slam.ekf.predict_terms` for the platform block with bias states: the new
        block ``(p,)``, its covariance ``(p, p)`` and its cross-covariance with the landmarks
        ``(p, n - p)``, without touching ``x`` or ``P`` (c.11.2; :func:`platform_prediction`);
        :func:`~radarslam.slam.ekf.apply_prediction` writes them. With ``pose_first`` (3,), the first
        estimate of the current pose, the pose block's heading column is the first-estimates one
        (c.2.1, c.11.7); ``F_u C_b`` and ``Phi`` stay at the estimate (the global rotation and
        translation leave the biases unchanged, so these columns do not enter the nullspace
        condition). The fused engine runs the same kernels (:mod:`radarslam.slam.fused.bias`)."""
        p = self.platform_dim
        pose, b = x[:POSE_DIM], x[POSE_DIM:p]
        uc = self.spec.correct(u, b)
        Cu, Cb = self.spec.jacobians(u, b)
        Fx, Fu = model.jacobians(pose, uc, dt)
        new_pose, Fx, Fu, Fb = _thrust(self.thrust_index, pose, model.step(pose, uc, dt), Fx, Fu, Cb, b)
        if pose_first is not None:
            Fx = ekf.fej_motion_jacobian(Fx, new_pose, pose_first)
        phi, qb = self.transition(dt)
        return platform_prediction(new_pose, b, P, Fx, Fu, Cu, Fb, phi, qb, U, Q)


def _thrust(j: int, pose, new_pose, Fx, Fu, Cb, b):
    """``(new_pose, F_x, F_u, F_b)`` with the thrust angle (the bias state ``j``) when ``j >= 0``
    (:func:`thrust_turn`), else the model's own with ``F_b = F_u C_b``."""
    if j >= 0:
        return thrust_turn(pose, new_pose, Fx, Fu, Cb, b, j)
    return new_pose, Fx, Fu, Fu @ Cb


def bias_transition(dt, drift, tau):
    """``(phi, Q_b (m,))``: the decay of the bias states over ``dt`` and the variance their drift
    ``drift`` (m,) adds (c.11.2): for a random walk (``tau <= 0``) ``(1, q^2 dt)``, for a
    Gauss-Markov process of time constant ``tau`` ``(exp(-dt / tau), q^2 tau / 2 (1 - phi^2))``.
    A kernel (the fused engine compiles it as it is)."""
    q2 = drift * drift
    if tau <= 0.0:
        return 1.0, q2 * dt
    phi = math.exp(-dt / tau)
    return phi, q2 * (0.5 * tau) * (1.0 - phi * phi)


def turned_step(pose: np.ndarray, new_pose: np.ndarray, beta: float) -> np.ndarray:
    """``new_pose`` with the position increment from ``pose`` turned by the thrust angle ``beta``
    (c.11.12; the heading's step unchanged): the mean of :func:`thrust_turn`, for the simulators and
    the pose's rate of c.13.2. A kernel (``new_pose`` a float array)."""
    c, s = math.cos(beta), math.sin(beta)
    dx, dy = new_pose[0] - pose[0], new_pose[1] - pose[1]
    out = new_pose.copy()
    out[0], out[1] = pose[0] + c * dx - s * dy, pose[1] + s * dx + c * dy
    return out


def thrust_turn(pose, new_pose, Fx, Fu, Cb, b, j):
    """The step with the thrust angle ``beta = b[j]`` (c.11.12): the model's position increment
    ``d = new_pose[:2] - pose[:2]`` turned by ``beta``, ``x' = x + R(beta) d`` (the heading's step
    unchanged), and its Jacobians ``(new_pose (3,), F_x, F_u, F_b (3, m))``: the position rows of
    ``F_x``'s heading column and of ``F_u`` turned by ``R(beta)``, ``F_b = F_u C_b`` with, in the
    thrust's column ``j``, ``d x' / d beta = (-d'_y, d'_x)``, ``d' = R(beta) d``. A kernel (the fused
    engine compiles it as it is)."""
    c, s = math.cos(b[j]), math.sin(b[j])
    dx, dy = new_pose[0] - pose[0], new_pose[1] - pose[1]
    rx, ry = c * dx - s * dy, s * dx + c * dy
    out = new_pose.copy()
    out[0], out[1] = pose[0] + rx, pose[1] + ry
    Fx2 = Fx.copy()
    Fx2[0, 2], Fx2[1, 2] = c * Fx[0, 2] - s * Fx[1, 2], s * Fx[0, 2] + c * Fx[1, 2]
    Fu2 = Fu.copy()
    for i in range(Fu.shape[1]):
        Fu2[0, i], Fu2[1, i] = c * Fu[0, i] - s * Fu[1, i], s * Fu[0, i] + c * Fu[1, i]
    Fb = Fu2 @ Cb
    Fb[0, j], Fb[1, j], Fb[2, j] = -ry, rx, 0.0
    return out, Fx2, Fu2, Fb


def platform_jacobian(Fx, Fb, phi):
    """``F_s = [[F_x, F_b], [0, phi I]]`` (p, p), ``p = 3 + m`` with ``m`` the columns of ``F_b``
    (``F_u C_b``, and the thrust's column, c.11.2, c.11.12). A kernel (the fused engine compiles it
    as it is)."""
    m = Fb.shape[1]
    p = POSE_DIM + m
    F = np.zeros((p, p))
    F[:POSE_DIM, :POSE_DIM] = Fx
    F[:POSE_DIM, POSE_DIM:] = Fb
    for i in range(m):
        F[POSE_DIM + i, POSE_DIM + i] = phi
    return F


def platform_prediction(pose_new, b, P, Fx, Fu, Cu, Fb, phi, qb, U, Q):
    """The prediction of the platform block with bias states (c.11.2): the new block
    ``s = [pose_new, phi b]`` (p,), ``P_ss = F_s P_ss F_s^T + blockdiag(G U G^T + Q, diag(qb))``
    (symmetrised, (p, p)) and ``F_s P_sl`` (p, n - p), with ``F_s`` of :func:`platform_jacobian` and
    ``G = F_u C_u``; ``F_x``, ``F_u`` the model's Jacobians at the corrected input (``F_x`` the
    first-estimates one under FEJ; both turned by a thrust state, c.11.12), ``C_u`` the correction's
    and ``F_b`` the bias columns (``F_u C_b``, :func:`thrust_turn`). ``P`` is left as it is. A
    kernel (the fused engine compiles it as it is)."""
    m = b.shape[0]
    p = POSE_DIM + m
    F = platform_jacobian(Fx, Fb, phi)
    G = Fu @ Cu
    Pss = F @ np.ascontiguousarray(P[:p, :p]) @ np.ascontiguousarray(F.T)
    Pss[:POSE_DIM, :POSE_DIM] += G @ U @ np.ascontiguousarray(G.T) + Q
    for i in range(m):
        Pss[POSE_DIM + i, POSE_DIM + i] += qb[i]
    Pss = 0.5 * (Pss + Pss.T)
    s = np.empty(p)
    s[:POSE_DIM] = pose_new
    s[POSE_DIM:] = phi * b
    return s, Pss, F @ np.ascontiguousarray(P[:p, p:])


def bias_states(model, f, yaw=None, time=None) -> BiasStates | None:
    """The filter's bias states under ``filter.odometry_bias`` (``f``, the ``filter`` section) for
    ``model``: None for ``"none"``; for ``"states"`` the model's declared ones, or a one-line
    :class:`ConfigError` when the model declares none."""
    if f.odometry_bias == "none":
        if f.bias_thrust:
            raise ConfigError("filter.bias_thrust: expected false with filter.odometry_bias 'none' (the thrust angle "
                              "is one of the odometry-bias states, c.11.12), got true")
        return None
    spec = getattr(model, "input_bias", None)
    if spec is None:
        raise ConfigError(f"filter.odometry_bias: expected 'none' with motion model {getattr(model, 'name', model)!r} "
                          f"(it declares no input_bias, docs/method.md c.11), got {f.odometry_bias!r}")
    spec = spec.with_turn(f.bias_turn)                      # c.11.8: the turn's offset, scale or both
    if f.bias_thrust and f.odometry != "odometer":
        raise ConfigError(f"filter.bias_thrust: expected false with filter.odometry {f.odometry!r} (the Doppler fit "
                          f"measures the lateral velocity itself; the thrust state is the odometer's, c.11.12), got true")
    spec = spec.with_thrust(bool(f.bias_thrust))            # c.11.12: the thrust angle, last
    if (f.bias_thrust or yaw is not None or time is not None) and f.bias_tau_s > 0:
        raise ConfigError(f"filter.bias_tau_s: expected 0 with filter.bias_thrust, filter.radar_yaw_states or "
                          f"filter.radar_time_states (constants of the car, which a Gauss-Markov tau would decay; "
                          f"c.11.12, c.13.1, c.13.2), got {f.bias_tau_s!r}")
    return BiasStates(spec, spec.prior_std(f), spec.drift(f), f.bias_tau_s, yaw, time)


def initial_state(f, bias: BiasStates | None) -> SlamState:
    """The filter's first state from the ``filter`` section ``f`` (b.5): the initial pose and, with
    ``bias``, the bias states at their nominal 0 with their prior std (c.11.1)."""
    if bias is None:
        return SlamState.initial(f.initial_pose, f.initial_pose_std)
    st = SlamState.initial(f.initial_pose, f.initial_pose_std, np.zeros(bias.dim), bias.prior_std)
    if bias.yaw is not None and bias.yaw.zero_mean:          # c.13.1: the rig's mean yaw offset held at 0
        from radarslam.slam.radar_yaw import ZERO_MEAN_STD, zero_mean_update

        first = POSE_DIM + bias.spec.dim
        zero_mean_update(st.x, st.P, np.arange(first, first + bias.yaw.dim), ZERO_MEAN_STD)
    return st


def predict_terms(bias: BiasStates | None, x: np.ndarray, P: np.ndarray, u: np.ndarray, dt: float, model,
                  U: np.ndarray, Q: np.ndarray, pose_first: np.ndarray | None = None):
    """The prediction's terms for :func:`radarslam.slam.ekf.apply_prediction`: without bias states
    :func:`radarslam.slam.ekf.predict_terms` (c.2, with ``pose_first`` under FEJ), else
    :meth:`BiasStates.predict_terms` (c.11.2; with ``pose_first`` too, c.11.7)."""
    if bias is None:
        return ekf.predict_terms(x, P, u, dt, model, U, Q, pose_first)
    return bias.predict_terms(x, P, u, dt, model, U, Q, pose_first)


def control_noise(model, f) -> np.ndarray:
    """The control covariance U of each odometry sample (docs/method.md c.11.6): the model's
    ``control_cov(f)`` (white noise per sample, the paper's), or under ``filter.odometry_tau_s > 0``
    that of input errors that are first-order Gauss-Markov processes with the stds of U and time
    constant tau, replaced by the white noise of the same effect on the integrated pose over times
    much longer than tau: each sample's variance ``sigma^2 2 tau / dt`` with ``dt`` =
    ``filter.odometry_sample_s``. The same U for every sample, so both engines take it."""
    U = model.control_cov(f)
    tau, dt = f.odometry_tau_s, f.odometry_sample_s
    if tau == 0:
        return U
    if not dt > 0:
        raise ConfigError(f"filter.odometry_sample_s: expected the odometry sample interval (s, > 0) with "
                          f"filter.odometry_tau_s = {tau:g}, got {dt!r}")
    return U * (2.0 * tau / dt)


def turn_noise_index(model, f) -> int | None:
    """The index of the turning input whose variance grows with the turn under ``filter.turn_noise_gain``
    (c.11.8; the model's ``input_bias.offset``), or None when the gain is 0; a one-line
    :class:`ConfigError` for a model that declares no turning input or under Doppler odometry."""
    if f.turn_noise_gain == 0:
        return None
    spec = getattr(model, "input_bias", None)
    if spec is None or f.odometry != "odometer":
        raise ConfigError(f"filter.turn_noise_gain: expected 0 with motion model {getattr(model, 'name', model)!r} "
                          f"and filter.odometry {f.odometry!r} (needs an odometer and a model with an input_bias, "
                          f"docs/method.md c.11.8), got {f.turn_noise_gain!r}")
    return int(spec.offset)


def turn_noise(U: np.ndarray, u: np.ndarray, index: int, gain2: float) -> np.ndarray:
    """The heteroscedastic control covariance of one sample (c.11.8): ``U`` with
    ``gain2 u[index]^2`` added to the turning input's variance (``gain2 = k^2``, times
    ``2 tau / dt`` under filter.odometry_tau_s, as U's own variance, c.11.6)."""
    Uk = U.copy()
    Uk[index, index] += gain2 * u[index] * u[index]
    return Uk


def turn_noise_gain2(f) -> float:
    """``k^2``, scaled like U by c.11.6's ``2 tau / dt`` when ``filter.odometry_tau_s > 0``."""
    k2 = f.turn_noise_gain ** 2
    return k2 * (2.0 * f.odometry_tau_s / f.odometry_sample_s) if f.odometry_tau_s > 0 else k2


def measurement_noise(R: np.ndarray, f) -> np.ndarray:
    """The measurement covariance of association and update (c.11.9): ``R`` for independent errors
    per scan, ``n_c R`` when each landmark's error is correlated over consecutive scans with the
    integrated correlation time ``n_c`` = ``filter.measurement_corr_scans`` (scans)."""
    return R if f.measurement_corr_scans == 1 else R * f.measurement_corr_scans
