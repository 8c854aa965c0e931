"""The Victoria Park car's Ackermann model: Jacobians, straight lines, circles, the encoder speed."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from radarslam.core.errors import InputError
from radarslam.models.ackermann import AckermannModel, centre_speed
from radarslam.models.motion import motion_model_from_config

from test_ekf import JAC_TOL, numjac

L, H, A, B = 2.83, 0.76, 0.95, 0.5
DT = 0.025  # the dataset's odometry period

POSES = [
    np.array([1.0, -2.0, 0.3]),
    np.array([0.0, 0.0, 1e-4]),                    # heading just above 0
    np.array([3.0, 4.0, 2 * math.pi - 1e-4]),      # heading just below 2 pi
    np.array([-50.0, 120.0, math.pi]),
]
CONTROLS = [
    np.array([3.0, 0.0]),        # straight
    np.array([3.0, 1e-4]),       # steering near 0
    np.array([2.5, 0.5]),        # hard left
    np.array([4.0, -0.5]),       # hard right
    np.array([6.6, 0.56]),       # the data's extremes
    np.array([-0.05, -0.3]),     # creeping backwards
    np.array([0.0, 0.2]),        # standing still
]


@pytest.mark.parametrize("pose", POSES)
@pytest.mark.parametrize("u", CONTROLS)
def test_jacobians_match_central_differences(pose, u):
    m = AckermannModel()
    Fx, Fu = m.jacobians(pose, u, DT)
    assert Fx.shape == (3, 3) and Fu.shape == (3, 2)
    # The heading row wraps to [0, 2 pi); its differences are wrapped before dividing.
    assert np.allclose(Fx, numjac(lambda p: m.step(p, u, DT), pose, wrap_rows=(2,)), atol=JAC_TOL)
    assert np.allclose(Fu, numjac(lambda uu: m.step(pose, uu, DT), u, wrap_rows=(2,)), atol=JAC_TOL)


def test_jacobians_at_a_long_step_and_other_geometry():
    """Nothing in the Jacobians assumes a small dt or the default geometry."""
    m = AckermannModel(L=3.1, H=0.6, a=-0.4, b=-0.3)
    for pose in POSES:
        u = np.array([5.0, -0.45])
        Fx, Fu = m.jacobians(pose, u, 0.7)
        assert np.allclose(Fx, numjac(lambda p: m.step(p, u, 0.7), pose, wrap_rows=(2,)), atol=JAC_TOL)
        assert np.allclose(Fu, numjac(lambda uu: m.step(pose, uu, 0.7), u, wrap_rows=(2,)), atol=JAC_TOL)


@pytest.mark.parametrize("phi", [0.0, 0.7, math.pi, 2 * math.pi - 1e-9])
def test_straight_motion_moves_the_laser_along_the_heading(phi):
    m = AckermannModel()
    pose = np.array([10.0, -3.0, phi])
    nxt = m.step(pose, np.array([4.0, 0.0]), DT)
    # alpha = 0: v_c = v_e and no yaw, so the laser moves v_e dt = 0.1 m along the heading.
    assert np.allclose(nxt[:2], pose[:2] + 0.1 * np.array([math.cos(phi), math.sin(phi)]), atol=1e-12)
    assert math.isclose(nxt[2], phi % (2 * math.pi), abs_tol=1e-12)


def test_heading_is_wrapped_to_0_2pi():
    m = AckermannModel()
    left = m.step(np.array([0.0, 0.0, 2 * math.pi - 1e-3]), np.array([5.0, 0.5]), DT)
    right = m.step(np.array([0.0, 0.0, 1e-3]), np.array([5.0, -0.5]), DT)
    assert 0.0 <= left[2] < 0.1 and 2 * math.pi - 0.1 < right[2] < 2 * math.pi


def test_rear_left_wheel_speed_conversion():
    # tan(0.3) = 0.3093362496, H / L = 0.2685512367: v_c = 3 / (1 - 0.0830726324) = 3.2717967704
    assert math.isclose(centre_speed(3.0, 0.3, L, H), 3.2717967704, rel_tol=1e-10)
    assert centre_speed(3.0, 0.0, L, H) == 3.0
    # Turning right the left wheel is on the outside and faster than the axle centre.
    assert centre_speed(3.0, -0.3, L, H) < 3.0


def _circle_run(alpha: float, v_e: float, n_steps: int):
    """Integrate one full turn at constant control; return the model, the poses and the prediction."""
    m = AckermannModel()
    pose0 = np.array([5.0, -2.0, 1.0])
    v_c = centre_speed(v_e, alpha, L, H)
    omega = v_c * math.tan(alpha) / L
    dt = 2 * math.pi / abs(omega) / n_steps
    poses = [pose0]
    for _ in range(n_steps):
        poses.append(m.step(poses[-1], np.array([v_e, alpha]), dt))
    poses = np.array(poses)
    # Prediction: the rear-axle centre C circles the instantaneous centre O at R = L / tan(alpha),
    # O lying R along C's left normal (a negative R puts it on the right).
    R = L / math.tan(alpha)
    c, s = math.cos(pose0[2]), math.sin(pose0[2])
    lever = L + A
    C0 = pose0[:2] - np.array([lever * c - B * s, lever * s + B * c])
    O = C0 + R * np.array([-s, c])
    return m, poses, R, O, dt


def _rear_axle(poses: np.ndarray) -> np.ndarray:
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    lever = L + A
    return poses[:, :2] - np.column_stack([lever * c - B * s, lever * s + B * c])


@pytest.mark.parametrize("alpha", [0.3, -0.5, 0.05])
def test_constant_steering_traces_the_predicted_circle(alpha):
    n = 20_000
    m, poses, R, O, dt = _circle_run(alpha, 3.0, n)
    # Euler drift bound: each step leaves the circle tangentially, changing the radius by a factor
    # sqrt(1 + (omega dt)^2); over a full turn (omega dt = 2 pi / n) at most rho * 2 pi^2 / n.
    rho = math.hypot(L + A, R - B)                          # laser at (L + a, b), centre at (0, R)
    tol = rho * 2 * math.pi**2 / n
    assert np.max(np.abs(np.linalg.norm(poses[:, :2] - O, axis=1) - rho)) < tol
    assert np.max(np.abs(np.linalg.norm(_rear_axle(poses) - O, axis=1) - abs(R))) < abs(R) * 2 * math.pi**2 / n
    # One full turn brings heading and position back.
    assert math.isclose(poses[-1, 2], poses[0, 2], abs_tol=1e-9)
    assert np.linalg.norm(poses[-1, :2] - poses[0, :2]) < tol
    # The turn direction follows the steering sign (CCW for alpha > 0).
    dphi = np.unwrap(poses[:, 2])
    assert np.sign(dphi[1] - dphi[0]) == np.sign(alpha)


def test_encoder_wheel_runs_at_the_measured_speed():
    """The rear-left wheel, H to the left of the axle centre, covers v_e T on a circle of R - H."""
    alpha, v_e, n = 0.3, 3.0, 20_000
    m, poses, R, O, dt = _circle_run(alpha, v_e, n)
    c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
    wheel = _rear_axle(poses) + H * np.column_stack([-s, c])
    assert np.allclose(np.linalg.norm(wheel - O, axis=1), R - H, atol=R * 2 * math.pi**2 / n)
    path = np.sum(np.linalg.norm(np.diff(wheel, axis=0), axis=1))
    assert math.isclose(path, v_e * dt * n, rel_tol=1e-3)


def test_laser_lever_arm_is_measured_from_the_front_axle():
    m = AckermannModel()
    assert math.isclose(m.lever, 3.78)
    # Turning on the spot is impossible, but at low speed and full lock the laser's lateral speed
    # is omega (L + a): check it against the model directly, heading 0.
    u = np.array([1.0, 0.5])
    nxt = m.step(np.zeros(3), u, DT)
    v_c = centre_speed(1.0, 0.5, L, H)
    omega = v_c * math.tan(0.5) / L
    assert math.isclose(nxt[1], DT * omega * 3.78, rel_tol=1e-12)
    assert math.isclose(nxt[0], DT * (v_c - omega * B), rel_tol=1e-12)


def test_built_from_the_filter_section_by_name():
    """filter.motion_model = "ackermann" builds the model from the filter section's geometry, also
    in a fresh interpreter that has not imported the module (lazy registration)."""
    from dataclasses import replace

    from radarslam.config import profile_config

    f = profile_config("victoria-park").filter
    m = motion_model_from_config(f)
    assert isinstance(m, AckermannModel) and m.lever == f.vehicle_L_m + f.sensor_a_m and m.b == f.sensor_b_m
    assert motion_model_from_config(replace(f, sensor_a_m=0.0)).lever == f.vehicle_L_m
    code = ("from radarslam.config import profile_config; import radarslam.models.motion as m; "
            "assert type(m.motion_model_from_config(profile_config('victoria-park').filter)).__name__ == 'AckermannModel'")
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("kw", [dict(L=0.0), dict(L=-1.0), dict(H=-0.1), dict(a=math.nan), dict(b="x")])
def test_bad_geometry_is_rejected(kw):
    with pytest.raises(InputError):
        AckermannModel(**kw)
