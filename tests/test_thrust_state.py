"""The thrust-angle state (docs/method.md c.11.12, ``filter.bias_thrust``): a car whose rear axle moves
at ``beta`` from its heading. The step's Jacobians against central differences, an analytic step,
``beta = 0`` as the plain step, the dense augmented EKF, the compiled prediction against Python's,
the refusals, and the estimate on simulated point landmarks with a known thrust angle (the filter
without the state as the negative control)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from consistency_bounds import nees_band
from test_odometry_bias import (
    DT,
    INPUT_STD,
    MODELS,
    _controls,
    _point_config,
    _world,
    _wrapped,
    assert_dense_prediction,
    track,
)

from radarslam.config import profile_config
from radarslam.core.errors import ConfigError
from radarslam.models.ackermann import AckermannModel
from radarslam.models.body_velocity import BodyVelocityModel
from radarslam.models.motion import UnicycleModel
from radarslam.simulation.point_run import simulate_point_run
from radarslam.slam import EkfSlam
from radarslam.slam.bias import BiasStates


def _thrust_bias(model, tau=0.0) -> BiasStates:
    spec = model.input_bias.with_thrust(True)
    return BiasStates(spec, np.full(spec.dim, 0.02), np.full(spec.dim, 1e-3), tau)


def _step(model, bias, s, u, dt):
    """The augmented step written from its definition (c.11.12): the model's step at the corrected
    input, its position increment turned by ``beta = s[-1]``, the biases decayed."""
    pose = s[:3]
    nxt = model.step(pose, bias.spec.correct(u, s[3:]), dt)
    c, si = math.cos(s[-1]), math.sin(s[-1])
    d = nxt[:2] - pose[:2]
    out = np.concatenate([pose[:2] + [c * d[0] - si * d[1], si * d[0] + c * d[1]], nxt[2:]])
    return np.concatenate([out, bias.transition(dt)[0] * s[3:]])


@pytest.mark.parametrize("model, u", MODELS, ids=lambda v: getattr(v, "name", ""))
@pytest.mark.parametrize("tau", [0.0, 4.0])
@pytest.mark.parametrize("theta", [0.4, 1e-9, 2.0 * math.pi - 1e-9])
def test_thrust_jacobians_match_central_differences(model, u, tau, theta):
    """``F_s`` with the thrust's column and ``G`` against central differences of the augmented step."""
    bias = _thrust_bias(model, tau)
    u, dt, h = np.array(u), 0.1, 1e-6
    s0 = np.array([1.0, -2.0, theta, 0.03, -0.01, math.radians(0.7)])
    F, G, _ = bias.jacobians(s0[:3], s0[3:], u, dt, model)
    n = s0.size
    Fn = np.column_stack([_wrapped(_step(model, bias, s0 + h * e, u, dt) - _step(model, bias, s0 - h * e, u, dt))
                          / (2 * h) for e in np.eye(n)])
    Gn = np.column_stack([_wrapped(_step(model, bias, s0, u + h * e, dt) - _step(model, bias, s0, u - h * e, dt))
                          / (2 * h) for e in np.eye(u.size)])
    np.testing.assert_allclose(F, Fn, atol=1e-8)
    np.testing.assert_allclose(G, Gn[:3], atol=1e-8)
    assert abs(F[0, 5]) + abs(F[1, 5]) > 0.01                 # the thrust moves the position (not a zero column)


def test_unicycle_with_thrust_moves_at_beta_from_the_heading():
    """Analytic: a straight step of the unicycle (``psi = 0``) with ``beta`` goes ``v dt`` along
    ``theta + beta`` and keeps the heading; ``beta = 0`` known exactly (variance 0) is the model's
    own step and covariance."""
    model = UnicycleModel()
    bias = _thrust_bias(model)
    x = np.array([2.0, 1.0, 0.3, 0.0, 0.0, 0.02])
    P = np.eye(6) * 1e-2
    U, Q = np.diag([0.01, 1e-4]), np.diag([1e-6, 1e-6, 1e-7])
    s, _, _ = bias.predict_terms(x, P, np.array([10.0, 0.0]), 0.5, model, U, Q)
    np.testing.assert_allclose(s[:3], [2.0 + 5.0 * math.cos(0.32), 1.0 + 5.0 * math.sin(0.32), 0.3], atol=1e-14)
    x[5] = 0.0
    P[5, 5] = 0.0                                               # a thrust known to be 0: nothing added to P
    s0, P0, _ = bias.predict_terms(x, P, np.array([10.0, 0.1]), 0.5, model, U, Q)
    plain = BiasStates(model.input_bias, np.full(2, 0.02), np.full(2, 1e-3), 0.0)
    s1, P1, _ = plain.predict_terms(x[:5], P[:5, :5], np.array([10.0, 0.1]), 0.5, model, U, Q)
    assert np.array_equal(s0[:5], s1) and np.array_equal(s0[3:5], x[3:5])
    np.testing.assert_allclose(P0[:5, :5], P1, rtol=1e-14, atol=1e-16)


def test_thrust_prediction_equals_the_dense_augmented_ekf(rng):
    """The O(N) prediction with the thrust state equals ``F P F^T + G U G^T + Q`` on the whole state."""
    model = UnicycleModel()
    assert_dense_prediction(_thrust_bias(model), model, np.array([1.0, 2.0, 0.7, 0.02, 0.01, 0.01]), rng)


def test_thrust_option_and_refusals():
    """``bias_thrust`` adds one state, last, named thrust_angle with the profile's prior std; refused
    without the bias states and under Doppler odometry (the fit measures v_y itself)."""
    cfg = profile_config("apsipa")
    on = replace(cfg, filter=replace(cfg.filter, odometry_bias="states", bias_thrust=True, bias_thrust_std_deg=0.8))
    slam = EkfSlam(on)
    assert slam.bias_model.names == ("speed_scale", "turn_rate_offset", "thrust_angle")
    assert slam.x.shape == (6,) and slam.P[5, 5] == pytest.approx(math.radians(0.8) ** 2)
    with pytest.raises(ConfigError, match="filter.bias_thrust: expected false with filter.odometry_bias 'none'"):
        EkfSlam(replace(cfg, filter=replace(cfg.filter, bias_thrust=True)))
    with pytest.raises(ConfigError, match="filter.bias_thrust: expected false with filter.odometry 'doppler'"):
        EkfSlam(replace(on, radar=replace(on.radar, doppler=True), filter=replace(on.filter, odometry="doppler")))


@pytest.mark.parametrize("model, code, n_u", [(UnicycleModel(), "UNICYCLE", 2), (AckermannModel(), "ACKERMANN", 2),
                                              (BodyVelocityModel(), "BODY_VELOCITY", 3)],
                         ids=lambda v: getattr(v, "name", ""))
def test_compiled_thrust_prediction_same_as_python(model, code, n_u):
    """The fused engine's prediction with the thrust state equals :meth:`BiasStates.predict_terms`."""
    pytest.importorskip("numba")
    from radarslam.slam import _fused
    from radarslam.slam.fused import tracking
    from radarslam.slam.fused.bias import predict_platform
    from radarslam.slam.fused.plan import _bias_parameters

    bias = _thrust_bias(model)
    cfg = profile_config("victoria-park" if code == "ACKERMANN" else "apsipa")
    params = _fused._parameters(EkfSlam(cfg))._replace(**_bias_parameters(bias))
    assert params.bias_thrust and params.platform == 6
    rng = np.random.default_rng(5)
    U, Q = np.diag(rng.uniform(0.01, 0.1, n_u)), np.diag(rng.uniform(1e-4, 1e-3, 3))
    for _ in range(20):
        n = 6 + 2 * int(rng.integers(0, 4))
        x = np.concatenate([rng.uniform(-50, 50, 2), [rng.uniform(0, 2 * math.pi)], rng.normal(0, 0.05, 3),
                            rng.uniform(-50, 50, n - 6)])
        A = rng.normal(size=(n, n))
        P = A @ A.T + n * np.eye(n)
        u = np.concatenate([[rng.uniform(-1, 7)], rng.uniform(-0.5, 0.5, n_u - 1)])
        dt = float(rng.uniform(0.01, 0.3))
        s, Pss, Psl = bias.predict_terms(x, P, u, dt, model, U, Q)
        xc, Pc = x.copy(), P.copy()
        assert predict_platform(xc, Pc, u, dt, U, Q, x[:3].copy(), getattr(tracking, code), params)
        np.testing.assert_allclose(xc[:6], s, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(Pc[:6, :6], Pss, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(Pc[:6, 6:], Psl, rtol=1e-10, atol=1e-10)


BETA = math.radians(0.5)            # the review's thrust angles of the nuScenes cars: -0.25 .. -0.51 deg


def _thrust_config(on: bool):
    cfg = _point_config("unicycle", "states")
    return replace(cfg, filter=replace(cfg.filter, bias_thrust=on))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_thrust_angle_is_learnt_on_points(seed):
    """A car moving 0.5 deg off its heading among point landmarks, with a 4 % speed scale and a
    0.75 deg/s turn-rate offset (c.11.4's drive): the final thrust estimate lies within 3 of its
    stds of the truth with the std below a fifth of the 1 deg prior; the pose NEES (3 dof) averaged
    over the run's 300 scans lies in the two-sided 95% band of one run's per-scan NEES, chi2(3) =
    [0.22, 9.35] (the scans are correlated: the per-scan band is the time average's conservative
    band, tests/consistency_bounds.py; measured 3.1, 6.1 and 7.6 on seeds 0-2). Negative controls on
    the same data: the filter told the odometry 10 times more precise than it is (speed and
    turn-rate stds / 10) lies above the band (measured 23, 59 and 54); without the state the same
    filter's NEES is at least twice as large and its position RMSE larger."""
    model = UnicycleModel()
    b_true = np.array([0.04, math.radians(0.75), BETA])
    spec = model.input_bias.with_thrust(True)
    run = simulate_point_run(model, _controls("unicycle"), DT, _world(seed), b_true, np.random.default_rng(seed),
                             input_std=INPUT_STD, spec=spec)
    on = _thrust_config(True)
    err1, nees1, slam = track(on, run)
    err0, nees0, _ = track(_thrust_config(False), run)
    beta, std = slam.bias[-1], math.sqrt(slam.state.bias_cov[-1, -1])
    assert abs(beta - BETA) < 3 * std and std < math.radians(1.0) / 5, (math.degrees(beta), math.degrees(std))
    lo, hi = nees_band(3, 1)
    assert lo <= nees1.mean() <= hi, (nees1.mean(), lo, hi)
    assert nees0.mean() > 2 * nees1.mean() and np.sqrt(np.mean(err0 ** 2)) > np.sqrt(np.mean(err1 ** 2)), \
        (nees0.mean(), nees1.mean())
    sharp = replace(on, filter=replace(on.filter, speed_std_mps=on.filter.speed_std_mps / 10,
                                       turn_rate_std_deg_s=on.filter.turn_rate_std_deg_s / 10))
    nees_sharp = track(sharp, run)[1]
    assert nees_sharp.mean() > hi, (nees_sharp.mean(), hi)


def test_recording_run_writes_the_car_states(tmp_path):
    """A recording run (nuScenes scene-0103's first 8 s, the Boston car, ``--profile automotive``) with
    the thrust state writes every state's value and std after every scan (bias.csv) and the final ones
    in metrics.json; the thrust estimate moves from its prior 0 toward the review's -0.51 deg, its std
    falls below a third of the 1 deg prior; without the states neither file nor key (negative control)."""
    from helpers import first_seconds, shared_data

    from radarslam.io.recording import read_recording
    from radarslam.runs.recording import run_recording, write_recording_outputs

    rec = read_recording(first_seconds(shared_data() / "nuscenes_radar" / "scene-0103", 8.0, tmp_path / "rec"))
    cfg = profile_config("automotive")
    on = replace(cfg, filter=replace(cfg.filter, odometry_bias="states", bias_thrust=True, online_car_states="allow"))
    run = run_recording(rec, on)
    (tmp_path / "on").mkdir()
    (tmp_path / "off").mkdir()
    names = write_recording_outputs(tmp_path / "on", run, {})
    rows = np.genfromtxt(tmp_path / "on" / "bias.csv", delimiter=",", names=True)
    assert "bias.csv" in names and rows.size == run.times.size
    assert rows.dtype.names[-2:] == ("thrust_angle", "thrust_angle_std")
    assert rows["thrust_angle_std"][0] == pytest.approx(math.radians(1.0), rel=1e-6)
    thrust = run.metrics["odometry_bias"]["thrust_angle"]
    assert thrust["final"] == rows["thrust_angle"][-1] and thrust["unit"] == "rad"
    assert thrust["final"] < -math.radians(0.2) and thrust["final_std"] < math.radians(1.0) / 3, thrust
    plain = run_recording(rec, cfg)
    assert "odometry_bias" not in plain.metrics and "bias.csv" not in write_recording_outputs(tmp_path / "off", plain, {})
