"""Doppler and moving cars in the simulated car park (docs/method.md b.4.3).

Both options draw from their own child streams of the trial's generator
(``scenario.child_stream``, by spawn key, apart from the initial error's child), so the parked cars, the clutter and the odometer readings
are the same draws with or without them; with both off nothing here runs and the simulation is
bit-identical to the one without this module.

- Moving cars (``world.moving_vehicles = N``): ``4 x 2`` m axis-aligned rectangles driving to and
  fro along straight lanes at ``world.moving_speed_mps``, detected by the surface model like the
  parked cars (same density, count noise, P_D and range-azimuth noise). Their detections carry the
  source label :func:`moving_source` ``(i) = -2 - i`` (clutter is -1, parked cars >= 0).
- Doppler (``radar.doppler``): a detection of an object with world velocity ``w`` seen in the
  true direction ``u`` (sensor frame) has ``d = u . (R(theta)^T w - v_s) + n``, ``n ~ N(0,
  doppler_std^2)``, ``v_s`` the sensor's velocity in the sensor frame (0 for the parked cars'
  ``w``). Clutter (false alarms) has ``d`` uniform in ``+-radar.clutter_doppler_max_mps``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.config import Config
from radarslam.core.angles import wrap_pi
from radarslam.core.mounting import Mounting
from radarslam.models.doppler import sensor_velocity

#: Size (m) of a moving car along and across its lane.
MOVING_SIZE = (4.0, 2.0)


def moving_source(i: int | np.ndarray):
    """Source label of moving car ``i`` in :attr:`GroundTruth.sources`: ``-2 - i``."""
    return -2 - i


def is_moving_source(src: np.ndarray) -> np.ndarray:
    """Whether each source label is a moving car's."""
    return np.asarray(src) <= -2


@dataclass(frozen=True)
class MovingTraffic:
    """The moving cars of a trial.

    Attributes
    ----------
    centres : ndarray, shape (K, N, 2)
        Centre of each car at every scan (m, world frame).
    velocities : ndarray, shape (K, N, 2)
        Their velocities (m/s, world frame).
    sizes : ndarray, shape (N, 2)
        ``[size_x, size_y]`` (m).
    """

    centres: np.ndarray
    velocities: np.ndarray
    sizes: np.ndarray


def moving_traffic(config: Config, rng: np.random.Generator) -> MovingTraffic:
    """Lanes of ``world.moving_vehicles`` cars: each along x or y (equally likely), its lane line
    uniform in the scene shrunk by 10 m on each side, a triangle wave along it between the shrunk
    scene's ends starting at a uniform phase, at ``world.moving_speed_mps``."""
    n, K, dt = config.world.moving_vehicles, config.trajectory.n_steps, config.trajectory.dt_s
    lo, hi = config.radar.scene_min_m + 10.0, config.radar.scene_max_m - 10.0
    if hi <= lo:
        lo, hi = config.radar.scene_min_m, config.radar.scene_max_m
    axis = rng.integers(0, 2, n)
    lane = rng.uniform(lo, hi, n)
    phase = rng.uniform(0.0, 2.0 * (hi - lo), n)
    t = np.arange(K)[:, None] * dt
    s = np.mod(phase[None, :] + config.world.moving_speed_mps * t, 2.0 * (hi - lo))
    along = np.where(s < hi - lo, lo + s, hi - (s - (hi - lo)))
    speed = np.where(s < hi - lo, 1.0, -1.0) * config.world.moving_speed_mps
    centres = np.empty((K, n, 2))
    vel = np.zeros((K, n, 2))
    for i in range(n):
        a = int(axis[i])
        centres[:, i, a], centres[:, i, 1 - a] = along[:, i], lane[i]
        vel[:, i, a] = speed[:, i]
    sizes = np.array([MOVING_SIZE if a == 0 else MOVING_SIZE[::-1] for a in axis], dtype=float).reshape(n, 2)
    return MovingTraffic(centres, vel, sizes)


def moving_detections(traffic: MovingTraffic, k: int, pose: np.ndarray, config: Config,
                      rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The moving cars' detections at scan ``k`` (1-based) from the true ``pose``: ``polar (m, 2)``
    (noisy), the true azimuths ``(m,)`` and the sources ``(m,)``; the surface model of b.4."""
    radar = config.radar
    polar, true_az, src = [np.empty((0, 2))], [np.empty(0)], [np.empty(0, dtype=int)]
    for i in range(traffic.sizes.shape[0]):
        c, size = traffic.centres[k - 1, i], traffic.sizes[i]
        if math.hypot(c[0] - pose[0], c[1] - pose[1]) > radar.max_range_m:
            continue
        n = math.floor(radar.points_per_m2 * size[0] * size[1] + math.sqrt(radar.points_var) * rng.standard_normal())
        if n <= 0:
            continue
        pts = c - 0.5 * size + rng.random((n, 2)) * size
        pts = pts[rng.random(n) < radar.detection_probability]
        d = pts - pose[:2]
        az = np.arctan2(d[:, 1], d[:, 0]) - pose[2]
        r = np.hypot(d[:, 0], d[:, 1]) + radar.range_std_m * rng.standard_normal(az.size)
        a = az + math.radians(radar.azimuth_std_deg) * rng.standard_normal(az.size)
        flip = r < 0.0
        r[flip] *= -1.0
        a[flip] += math.pi
        polar.append(np.column_stack([r, wrap_pi(a)]))
        true_az.append(az)
        src.append(np.full(az.size, moving_source(i), dtype=int))
    return np.concatenate(polar), np.concatenate(true_az), np.concatenate(src)


def sensor_poses(poses: np.ndarray, mount) -> np.ndarray:
    """The radar's poses ``(K, 3)`` from the platform's ``poses`` and its ``mount`` (a
    :class:`~radarslam.core.mounting.Mounting`): ``[p + R(theta) l, theta + yaw_m]``."""
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    return np.column_stack([poses[:, 0] + c * mount.x - s * mount.y, poses[:, 1] + s * mount.x + c * mount.y,
                            poses[:, 2] + mount.yaw])


def platform_velocities(controls: np.ndarray) -> np.ndarray:
    """``[v (m/s), psi (rad/s)]`` at each scan, ``(K, 2)``: the control that moves pose k on (the
    last scan keeps the last control); row k - 1 of the trial's controls moves pose k - 1 to k."""
    K = controls.shape[0]
    return controls[np.minimum(np.arange(1, K + 1), K - 1)]


def scan_doppler(true_az: np.ndarray, sources: np.ndarray, pose: np.ndarray, velocity: np.ndarray,
                 traffic: MovingTraffic | None, k: int, config: Config, rng: np.random.Generator) -> np.ndarray:
    """Radial velocities ``(m,)`` (m/s) of one scan's detections (module docstring, b.4.3).

    ``true_az`` are the noise-free azimuths in the sensor frame (the scan is drawn from the radar's
    pose, :func:`sensor_poses`); the sensor's mounting from ``[sensor]`` (the platform origin by
    default) sets its velocity, ``pose`` is the platform's.
    """
    radar, m = config.radar, Mounting.from_config(config.sensor)
    yaw_m = m.yaw
    vs = sensor_velocity(float(velocity[0]), 0.0, float(velocity[1]), m.x, m.y, yaw_m)
    u = np.column_stack([np.cos(true_az), np.sin(true_az)])
    obj = np.zeros((sources.size, 2))
    moving = is_moving_source(sources)
    if traffic is not None and moving.any():
        w = traffic.velocities[k - 1, -2 - sources[moving]]                 # world frame
        c, s = math.cos(pose[2] + yaw_m), math.sin(pose[2] + yaw_m)
        obj[moving] = np.column_stack([c * w[:, 0] + s * w[:, 1], -s * w[:, 0] + c * w[:, 1]])
    d = np.einsum("ij,ij->i", u, obj - vs) + radar.doppler_std_mps * rng.standard_normal(sources.size)
    clutter = sources == -1
    d[clutter] = rng.uniform(-radar.clutter_doppler_max_mps, radar.clutter_doppler_max_mps, int(clutter.sum()))
    return d
