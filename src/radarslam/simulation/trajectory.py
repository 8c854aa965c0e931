"""The platform trajectory (docs/method.md b.2) and the odometer (b.3)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.config import OdometerConfig, TrajectoryConfig, WorldConfig
from radarslam.core.angles import wrap_2pi_scalar
from radarslam.models.motion import UnicycleModel
from radarslam.simulation.world import row_geometry


def commanded_controls(traj: TrajectoryConfig, world: WorldConfig | None = None) -> np.ndarray:
    """True controls ``u_k = [v, psi]`` for k = 1..K as rows ``(K, 2)``.

    [PROP] convention of b.2: pose k comes from pose k-1 with u_k, psi != 0 for
    ``turn_start <= k <= turn_end``. Row 0 (u_1) is never applied: pose 1 is the initial pose.
    With a generated car park (``world.layout = "rows"``) the serpentine of b.1.1 instead.
    """
    if world is not None and world.layout == "rows":
        return serpentine_controls(traj, world)
    k = np.arange(1, traj.n_steps + 1)
    u = np.zeros((traj.n_steps, 2))
    u[:, 0] = traj.speed_mps
    u[(k >= traj.turn_start) & (k <= traj.turn_end), 1] = traj.turn_rate_rad_s
    return u


def serpentine_controls(traj: TrajectoryConfig, world: WorldConfig) -> np.ndarray:
    """Controls ``(K, 2)`` of the drive through a generated car park (docs/method.md b.1.1).

    From the initial pose (the start of aisle 0, heading +x) the platform drives each aisle's
    straight at ``trajectory.speed_mps``, then a half turn of radius ``pitch / 2`` into the next
    aisle: aisles 0, 1, ..., A - 1 and back down, again and again, until K steps. The turn takes a
    whole number of steps, ``T = ceil(pi r / (v dt))``, at the rate ``psi = pi / (T dt)`` (the
    heading turns by exactly pi) and at the speed that makes the discrete half turn end exactly one
    pitch over (a little below v). Left turns going +x upwards, right turns going -x upwards, and
    the mirror image on the way down.
    """
    pitch, _, straight = row_geometry(world)
    v, dt = traj.speed_mps, traj.dt_s
    n_aisles = (world.rows + 1) // 2
    n_straight = max(1, round(straight / (v * dt)))
    n_turn = max(1, math.ceil(math.pi * 0.5 * pitch / (abs(v) * dt)))
    psi = math.pi / (n_turn * dt)
    # APSIPA eq. (5) moves along the chord at the mid-step heading: T such steps turning by pi in
    # all move sideways by v_turn dt / sin(pi / (2 T)), exactly the pitch at this speed (<= v)
    v_turn = pitch * math.sin(math.pi / (2 * n_turn)) / dt
    u = np.zeros((traj.n_steps, 2))
    u[:, 0] = v
    k, aisle, up, plus_x = 1, 0, True, True   # row 0 (u_1) is never applied
    while k < traj.n_steps:
        k += n_straight
        if (up and aisle == n_aisles - 1) or (not up and aisle == 0):
            up = not up                        # at the last aisle: back the other way
        if n_aisles > 1:
            aisle += 1 if up else -1
        # going +x a left turn (psi > 0) leads up, going -x a right turn does
        u[k:k + n_turn, 1] = (1.0 if plus_x == up else -1.0) * psi
        u[k:k + n_turn, 0] = v_turn
        k += n_turn
        plus_x = not plus_x
    return u


#: Gains of the driver of b.1.1: turn rate per metre of cross-track error (rad/s/m), per radian of
#: heading error (rad/s/rad), and speed change per metre ahead of or behind the plan (1/s).
DRIVER_GAINS = (0.15, 1.0, 0.5)


def driven_path(traj: TrajectoryConfig, world: WorldConfig, process_noise: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poses ``(K, 3)`` and the controls actually applied ``(K, 2)`` of a driver who follows the
    planned serpentine (:func:`serpentine_controls`) through a generated car park (b.1.1).

    The process noise of APSIPA eq. (5) makes an open-loop path wander off (over a 2000-step drive
    its heading random walk alone puts it tens of metres off the aisles), so each step the driver
    corrects the planned control by the cross-track, heading and along-track error of the previous
    true pose against the noise-free plan (:data:`DRIVER_GAINS`). The odometer measures these
    applied controls (b.3), as a car's odometer measures what its driver does.
    """
    model = UnicycleModel()
    plan_u = serpentine_controls(traj, world)
    plan = _integrate(traj, plan_u, np.zeros((traj.n_steps, 3)))
    k_lat, k_head, k_along = DRIVER_GAINS
    u = plan_u.copy()
    poses = np.empty((traj.n_steps, 3))
    poses[0] = plan[0]
    for k in range(1, traj.n_steps):
        x, y, th = poses[k - 1]
        px, py, pth = plan[k - 1]
        c, s = math.cos(pth), math.sin(pth)
        along = c * (x - px) + s * (y - py)
        lateral = -s * (x - px) + c * (y - py)
        heading = math.remainder(th - pth, 2.0 * math.pi)
        u[k, 0] = plan_u[k, 0] - k_along * along
        u[k, 1] = plan_u[k, 1] - k_lat * lateral - k_head * heading
        p = model.step(poses[k - 1], u[k], traj.dt_s) + process_noise[k]
        p[2] = wrap_2pi_scalar(p[2])
        poses[k] = p
    return poses, u


def noise_free_path(traj: TrajectoryConfig, world: WorldConfig | None = None) -> np.ndarray:
    """Poses ``(K, 3)`` of the commanded controls without process noise."""
    return true_path(traj, np.zeros((traj.n_steps, 3)), world)


def true_path(traj: TrajectoryConfig, process_noise: np.ndarray, world: WorldConfig | None = None) -> np.ndarray:
    """Poses ``(K, 3)``: APSIPA eq. (5) with the process noise ``omega_k`` (row k-1) added."""
    return _integrate(traj, commanded_controls(traj, world), process_noise)


def _integrate(traj: TrajectoryConfig, u: np.ndarray, process_noise: np.ndarray) -> np.ndarray:
    """Poses ``(K, 3)`` of the controls ``u`` from the initial pose, APSIPA eq. (5) plus the noise."""
    model = UnicycleModel()
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
    """``u_bar_k = S u_k + eta_k + bias`` with ``eta ~ N(0, U)`` (APSIPA eq. 6), ``(K, 2)``;
    ``S = diag(odometer.speed_scale, 1)`` (docs/method.md b.3; the identity by default, which leaves
    every reading bit for bit as without it)."""
    std = np.array([odo.speed_std_mps, math.radians(odo.turn_rate_std_deg_s)])
    bias = np.array([odo.speed_bias_mps, math.radians(odo.turn_rate_bias_deg_s)])
    scale = np.array([odo.speed_scale, 1.0])
    return controls * scale + rng.standard_normal(controls.shape) * std + bias
