"""A car with five radars and every fixed error of docs/method.md c.16 at once, for the online states of c.11,
c.11.12, c.13.1 and c.13.2 (docs/method.md c.13.3).

The car drives loops about a circle of radius 30 m at 6 +- 3 m/s (accelerations up to 1.5 m/s^2)
with its turn rate swinging about the circle's, among point landmarks on both sides of the road. The
true errors (:class:`CarErrors`): the wheel speed reads ``1 / (1 + scale)`` of the truth and the gyro
``gyro_offset`` too little (the odometer of c.11.4), the rear axle moves at the thrust angle from the
heading (c.11.12), radar ``j`` is turned by ``yaw_offsets[j]`` from its stated mounting (c.13.1) and
its scan stamped ``t`` is measured at ``t + time_offsets[j]`` (c.13.2). The radars scan in turn, one
every ``SCAN_EVERY`` odometry steps; each sees the landmarks within 1-50 m and +-60 deg of its own
boresight with range and azimuth noise. The filter is told the stated mountings (:data:`RIG`) only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from radarslam.config import RigSensorConfig, profile_config, validate
from radarslam.core.angles import wrap_pi
from radarslam.core.mounting import Mounting
from radarslam.core.types import Odometry, Scan
from radarslam.models.motion import UnicycleModel
from radarslam.slam.bias import turned_step

__all__ = ["DT", "INPUT_STD", "RIG", "SCAN_EVERY", "TOLERANCE", "CarErrors", "car_config", "car_controls", "car_world",
           "one_drive", "pose_nees_of_drive", "simulate_car_rig", "truth_vector"]

#: The odometry's step (s) and the scans' spacing (odometry steps per scan, radars in turn).
DT = 0.02
SCAN_EVERY = 2
#: The odometer's white noise: speed (m/s) and turn rate (rad/s).
INPUT_STD = (0.05, 0.005)
#: The precision asked of each kind of state (docs/method.md c.13.3).
TOLERANCE = {"scale": 1e-3, "gyro": math.radians(0.1), "thrust": math.radians(0.1), "yaw": math.radians(0.1),
             "time": 0.005}
#: A nuScenes-like rig: front, front-left, front-right, back-left, back-right ``(x, y, yaw)`` (m, m, rad)
#: about the rear axle.
RIG = ((3.4, 0.0, 0.0), (2.4, 0.8, math.radians(80.0)), (2.4, -0.8, math.radians(-80.0)),
       (-0.6, 0.8, math.radians(170.0)), (-0.6, -0.8, math.radians(-170.0)))


@dataclass(frozen=True)
class CarErrors:
    """The car's true fixed errors: wheel-speed scale (the filter's ``eps``), gyro offset (rad/s),
    thrust angle (rad), and each radar's yaw offset (rad) and time offset (s), in :data:`RIG`'s order."""

    scale: float = 0.01
    gyro_offset: float = 0.0
    thrust: float = math.radians(0.5)
    yaw_offsets: tuple = tuple(math.radians(a) for a in (1.5, -1.5, 1.0, -0.5, -0.5))
    time_offsets: tuple = (0.0, 0.015, 0.030, 0.045, 0.060)

    def scaled(self, yaw: float = 1.0, time: float = 1.0) -> "CarErrors":
        """The same errors with the radars' yaw offsets times ``yaw`` and their time offsets times ``time``."""
        return replace(self, yaw_offsets=tuple(yaw * a for a in self.yaw_offsets),
                       time_offsets=tuple(time * t for t in self.time_offsets))


def car_controls(duration_s: float) -> np.ndarray:
    """True ``[v, omega]`` per step: 6 +- 3 m/s (period 13 s), the circle's turn rate plus +-0.1 rad/s."""
    t = np.arange(int(round(duration_s / DT))) * DT
    v = 6.0 + 3.0 * np.sin(2 * math.pi * t / 13.0)
    return np.column_stack([v, v / 30.0 + 0.1 * np.sin(2 * math.pi * t / 11.0)])


def car_world(rng: np.random.Generator, n: int = 160) -> np.ndarray:
    """``n`` point landmarks 4-16 m either side of the 30 m circle (centre (0, 30))."""
    side = np.where(np.arange(n) % 2 == 0, 1.0, -1.0)
    rad, a = 30.0 + side * rng.uniform(4.0, 16.0, n), rng.uniform(0, 2 * math.pi, n)
    return np.column_stack([rad * np.cos(a), rad * np.sin(a) + 30.0])


def _step(model, pose, u, dt, thrust):
    return turned_step(pose, model.step(pose, u, dt), thrust)


def simulate_car_rig(errors: CarErrors, landmarks: np.ndarray, controls: np.ndarray, rng: np.random.Generator,
                     *, input_std=INPUT_STD, range_std: float = 0.1, azimuth_std: float = math.radians(0.5)):
    """``(events, true poses at the scans' stamps (S, 3))`` of the drive (module docstring); the
    odometer's readings carry white noise of ``input_std`` (speed m/s, turn rate rad/s)."""
    model = UnicycleModel()
    spec = model.input_bias.with_thrust(True)
    b = np.array([errors.scale, errors.gyro_offset, errors.thrust])
    pose, prev, u_prev = np.zeros(3), np.zeros(3), controls[0]
    events, poses = [], []
    std = np.asarray(input_std, dtype=float)
    for k, u in enumerate(controls):
        if k % SCAN_EVERY == 0 and k > 0:
            j = (k // SCAN_EVERY) % len(RIG)
            tau = errors.time_offsets[j]                        # |tau| < DT * SCAN_EVERY
            true = _step(model, pose, u, tau, errors.thrust) if tau >= 0 else \
                _step(model, prev, u_prev, DT + tau, errors.thrust)
            x, y, yaw = RIG[j]
            c, s = math.cos(true[2]), math.sin(true[2])
            sp = np.array([true[0] + c * x - s * y, true[1] + s * x + c * y])
            d = landmarks - sp
            r = np.hypot(d[:, 0], d[:, 1])
            phi = wrap_pi(np.arctan2(d[:, 1], d[:, 0]) - true[2] - yaw - errors.yaw_offsets[j])
            seen = (r >= 1.0) & (r <= 50.0) & (np.abs(phi) <= math.radians(60.0))
            polar = np.column_stack([r[seen], phi[seen]]) + rng.standard_normal((int(seen.sum()), 2)) * [range_std, azimuth_std]
            events.append(Scan(t=k * DT, index=k // SCAN_EVERY, polar=polar, sensor=Mounting(x, y, yaw, sensor_id=j)))
            poses.append(pose.copy())
        events.append(Odometry(t=(k + 1) * DT, dt=DT, control=spec.uncorrect(u, b) + rng.standard_normal(2) * std))
        prev, u_prev = pose, u
        pose = _step(model, pose, u, DT, errors.thrust)
    return events, np.array(poses)




def car_config():
    """Point landmarks (the tree profile's scheme, one detection per landmark and scan) with the
    simulation's noise, the rig's stated mountings and every car state on."""
    cfg = profile_config("victoria-park-trees")
    f = replace(cfg.filter, motion_model="unicycle", odometry_bias="states", range_std_m=0.1, azimuth_std_deg=0.5,
                speed_std_mps=INPUT_STD[0], turn_rate_std_deg_s=math.degrees(INPUT_STD[1]), process_var_xy_m2=1e-9,
                process_var_heading_rad2=1e-10, initial_pose=[0.0, 0.0, 0.0], initial_pose_std=[1e-3, 1e-3, 1e-4],
                turn_noise_gain=0.0, measurement_corr_scans=1.0, noise_interval_s=DT, fused=False,
                bias_scale_std=0.02, bias_scale_drift_per_rt_s=0.0, bias_turn_rate_std_deg_s=0.5,
                bias_turn_rate_drift_deg_s_per_rt_s=0.0, bias_thrust=True, bias_thrust_std_deg=1.0,
                radar_yaw_states=True, radar_yaw_std_deg=2.0, radar_yaw_reference="rig",
                radar_time_states=True, radar_time_std_ms=50.0, max_range_m=50.0, field_of_view_deg=120.0)
    sensors = [RigSensorConfig(j, x, y, math.degrees(yaw)) for j, (x, y, yaw) in enumerate(RIG)]
    return validate(replace(cfg, filter=f, sensors=sensors, landmarks=replace(cfg.landmarks, confirm_window=15)))


def truth_vector(e: CarErrors) -> tuple[np.ndarray, list[str]]:
    """The 12 states' true values in the filter's order, and their kinds."""
    x = np.concatenate([[e.scale, e.gyro_offset, e.thrust], e.yaw_offsets, e.time_offsets])
    return x, ["scale", "gyro", "thrust"] + ["yaw"] * len(RIG) + ["time"] * len(RIG)


def one_drive(seed: int, duration_s: float, errors: CarErrors = CarErrors(), config=None) -> tuple[np.ndarray, np.ndarray]:
    """The car states' estimate and covariance at the end of drive ``seed`` (under ``config``, default
    :func:`car_config`)."""
    from radarslam.slam import EkfSlam

    rng = np.random.default_rng(seed)
    events, _ = simulate_car_rig(errors, car_world(np.random.default_rng(10_000 + seed)), car_controls(duration_s), rng,
                                 input_std=INPUT_STD)
    slam = EkfSlam(config or car_config())
    for ev in events:
        slam.process(ev)
    p = slam.bias_model.platform_dim
    return slam.x[3:p].copy(), slam.P[3:p, 3:p].copy()


def pose_nees_of_drive(seed: int, duration_s: float, errors: CarErrors = CarErrors(), config=None,
                       input_std=INPUT_STD) -> np.ndarray:
    """The pose's NEES (3 dof) after every scan of drive ``seed`` (:func:`one_drive`'s drive, the odometer's
    white noise of ``input_std``; ``config`` default :func:`car_config` with its turn-rate std set to
    ``input_std``'s), against the true pose at the scan's stamp."""
    from radarslam.slam import EkfSlam

    rng = np.random.default_rng(seed)
    events, poses = simulate_car_rig(errors, car_world(np.random.default_rng(10_000 + seed)), car_controls(duration_s),
                                     rng, input_std=input_std)
    cfg = config or car_config()
    cfg = replace(cfg, filter=replace(cfg.filter, speed_std_mps=float(input_std[0]),
                                      turn_rate_std_deg_s=math.degrees(float(input_std[1]))))
    slam, out = EkfSlam(cfg), []
    for ev in events:
        slam.process(ev)
        if isinstance(ev, Scan):
            e = slam.pose - poses[len(out)]
            e[2] = wrap_pi(e[2])
            out.append(float(e @ np.linalg.solve(slam.pose_cov, e)))
    return np.array(out)
