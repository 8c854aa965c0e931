"""A complete simulated trial: the event stream the filter sees and the ground truth kept aside."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.config import Config, FilterConfig
from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting
from radarslam.core.types import Odometry, Scan
from radarslam.simulation.doppler import (MovingTraffic, moving_detections, moving_traffic, platform_velocities,
                                          scan_doppler, sensor_poses)
from radarslam.simulation.radar import simulate_scan
from radarslam.simulation.trajectory import (commanded_controls, driven_path, odometer_readings, process_noise,
                                              true_path)
from radarslam.simulation.world import Vehicle, carpark_vehicles, presence


@dataclass(frozen=True)
class GroundTruth:
    """What the evaluation knows and the filter does not.

    Attributes
    ----------
    poses : ndarray, shape (K, 3)
        True poses for k = 1..K.
    controls : ndarray, shape (K, 2)
        True controls (row k-1 moves pose k-1 to pose k; row 0 unused).
    vehicles : list of Vehicle
    present : ndarray of bool, shape (K, V)
    sources : list of ndarray of int
        Per scan, the producing vehicle of each detection (-1 = clutter, <= -2 a moving car:
        :func:`radarslam.simulation.doppler.moving_source`).
    traffic : MovingTraffic or None
        The moving cars (``world.moving_vehicles > 0``, b.4.3).
    """

    poses: np.ndarray
    controls: np.ndarray
    vehicles: list[Vehicle]
    present: np.ndarray
    sources: list[np.ndarray]
    traffic: MovingTraffic | None = None


@dataclass(frozen=True)
class Scenario:
    """The event stream ``[Scan 1, Odometry 2, Scan 2, ..., Odometry K, Scan K]`` and its truth."""

    events: list[Odometry | Scan]
    truth: GroundTruth
    odometry: np.ndarray  # (K, 2) readings, row 0 unused

    @property
    def scans(self) -> list[Scan]:
        return [e for e in self.events if isinstance(e, Scan)]


def generate_scenario(config: Config, rng: np.random.Generator, *, compiled: bool = True) -> Scenario:
    """Simulate one trial of the car park from ``rng``.

    The draws happen in a fixed order (process noise, odometer noise, then the scans in time
    order), so a scenario is reproducible bit for bit from its seed. With the surface spread model
    the scans are drawn in one compiled call (:mod:`._compiled`, the same draws bit for bit);
    ``compiled=False`` runs the reference, :func:`~.radar.simulate_scan` per scan.
    """
    traj = config.trajectory
    vehicles = carpark_vehicles(config.world)
    if config.world.layout == "rows":      # a driver follows the planned route (b.1.1)
        poses, controls = driven_path(traj, config.world, process_noise(traj, rng))
    else:
        controls = commanded_controls(traj)
        poses = true_path(traj, process_noise(traj, rng))
    odo = odometer_readings(controls, config.odometer, rng)
    events: list[Odometry | Scan] = []
    sources = []
    batch = None
    # Doppler and moving cars (b.4.3): their own child streams, spawned only when asked for, so
    # that with both off the draws (and the scenario) are the ones without them, bit for bit
    extra = config.radar.doppler or config.world.moving_vehicles > 0
    traffic = None
    if extra:
        doppler_rng, moving_rng = (child_stream(rng, c) for c in (DOPPLER_CHILD, MOVING_CHILD))
        if config.world.moving_vehicles:
            traffic = moving_traffic(config, moving_rng)
        velocity = platform_velocities(controls)
    gyro = None
    if config.radar.doppler:   # c.10.5: the true yaw rate of each interval plus noise, child stream 3
        gyro = controls[:, 1] + math.radians(config.odometer.gyro_std_deg_s) * child_stream(
            rng, GYRO_CHILD).standard_normal(controls.shape[0])
    # only the surface model is compiled; contour, visible-faces and scatter-centres (docs/method.md
    # b.4.1, b.4.2) always run through the Python reference, simulate_scan
    mount = Mounting.from_config(config.sensor)
    spose = poses if mount.is_identity else sensor_poses(poses, mount)    # b.4.3: measured from the radar
    # c.13: a mounted radar's scans stay in its frame, the filter measuring from its pose
    sensor = None if mount.is_identity else mount
    if compiled and config.radar.spread_model == "surface":
        from radarslam.simulation._compiled import simulate

        batch = simulate(spose[:traj.n_steps], vehicles, config.radar, rng, true_azimuth=extra)
    for k in range(1, traj.n_steps + 1):
        if k > 1:
            events.append(Odometry(t=(k - 1) * traj.dt_s, dt=traj.dt_s, control=odo[k - 1],
                                   gyro_rad_s=None if gyro is None else float(gyro[k - 1])))
        if batch is None:
            out = simulate_scan(spose[k - 1], vehicles, k, config.radar, rng, true_azimuth=extra)
        else:
            a, b = batch[0][k - 1], batch[0][k]
            out = tuple(arr[a:b] for arr in batch[1:])
        polar, src = out[0], out[1]
        channels = None
        if extra:
            polar, src, channels = _extras(out, k, poses[k - 1], spose[k - 1], velocity[k - 1], traffic, config,
                                           moving_rng, doppler_rng)
        events.append(Scan(t=(k - 1) * traj.dt_s, index=k, polar=polar, channels=channels, sensor=sensor))
        sources.append(src)
    truth = GroundTruth(poses, controls, vehicles, presence(vehicles, traj.n_steps), sources, traffic)
    return Scenario(events, truth, odo)


def _extras(out, k: int, pose: np.ndarray, spose: np.ndarray, velocity: np.ndarray, traffic, config: Config,
            moving_rng: np.random.Generator, doppler_rng: np.random.Generator):
    """Scan ``k`` (sensor frame; ``pose`` the platform's, ``spose`` the radar's) with the moving cars'
    detections appended (shuffled in with ``moving_rng`` when the radar shuffles) and the Doppler
    channel (b.4.3): ``(polar, sources, channels or None)``."""
    polar, src, az = out
    if traffic is not None:
        mp, maz, msrc = moving_detections(traffic, k, spose, config, moving_rng)
        if msrc.size:
            polar, src, az = np.concatenate([polar, mp]), np.concatenate([src, msrc]), np.concatenate([az, maz])
            if config.radar.shuffle_detections:
                order = moving_rng.permutation(src.size)
                polar, src, az = polar[order], src[order], az[order]
    if not config.radar.doppler:
        return polar, src, None
    return polar, src, {"doppler_mps": scan_doppler(az, src, pose, velocity, traffic, k, config, doppler_rng)}


#: The children of a trial's SeedSequence, each built from its spawn key (``trial key + (c,)``), so
#: that the trial's own stream (process noise, odometer, scans) is the same whether or not they are
#: drawn and no two options share a stream: the initial error (docs/method.md b.5), the Doppler
#: noise and the moving cars (b.4.3), the gyro (c.10.5).
INITIAL_ERROR_CHILD, DOPPLER_CHILD, MOVING_CHILD, GYRO_CHILD = 0, 1, 2, 3


def child_stream(rng: np.random.Generator, child: int) -> np.random.Generator:
    """The generator of child ``child`` of the SeedSequence behind ``rng`` (by its spawn key; the
    parent's state and spawn counter are not touched)."""
    ss = rng.bit_generator.seed_seq
    return np.random.default_rng(np.random.SeedSequence(ss.entropy, spawn_key=tuple(ss.spawn_key) + (child,),
                                                        pool_size=ss.pool_size))


def initial_error_stream(ss: np.random.SeedSequence) -> np.random.Generator:
    """The generator of trial stream ``ss``'s initial error: its child :data:`INITIAL_ERROR_CHILD`.

    Built from the spawn key (not ``ss.spawn``), so it does not depend on what was spawned before.
    """
    if not isinstance(ss, np.random.SeedSequence):
        raise InputError(f"ss: expected a numpy.random.SeedSequence, got {type(ss).__name__}")
    child = np.random.SeedSequence(ss.entropy, spawn_key=tuple(ss.spawn_key) + (INITIAL_ERROR_CHILD,),
                                   pool_size=ss.pool_size)
    return np.random.default_rng(child)


def initial_estimate(filt: FilterConfig, true_pose: np.ndarray, ss: np.random.SeedSequence) -> list[float]:
    """The filter's initial pose estimate for one trial (docs/method.md b.5).

    Parameters
    ----------
    filt : FilterConfig
        ``initial_error`` "fixed": ``initial_pose`` as configured (the paper's). "draw":
        ``true_pose + L z`` with ``z ~ N(0, I_3)`` from :func:`initial_error_stream` and
        ``L = diag(initial_pose_std)`` (m, m, rad), so the error is a draw from the filter's own
        initial covariance ``P_1``; every variant of a trial shares ``z``.
    true_pose : ndarray, shape (3,)
        True first pose [x_m, y_m, theta_rad].
    ss : numpy.random.SeedSequence
        The trial's stream (its child draws; the stream itself is not touched).

    Returns
    -------
    list of float, length 3
        [x_m, y_m, theta_rad]; the heading is not wrapped (the filter wraps after a prediction).
    """
    if filt.initial_error == "fixed":
        return list(filt.initial_pose)
    pose = np.asarray(true_pose, dtype=float)
    if pose.shape != (3,) or not np.all(np.isfinite(pose)):
        raise InputError(f"true_pose: expected 3 finite values [x_m, y_m, theta_rad], got {true_pose!r}")
    z = initial_error_stream(ss).standard_normal(3)
    return (pose + np.asarray(filt.initial_pose_std, dtype=float) * z).tolist()
