"""A turn-dependent odometry model (docs/method.md c.11.8) and correlated measurement errors (c.11.9):
the turn-scale bias state's Jacobians by central differences, the heteroscedastic turn noise against
its analytic form and a Monte Carlo of the integrated heading, the equivalent white R, the fused
engine's refusal, and the turn scale estimated on simulated odometry with a known scale error (with
the filter without the state as the negative control)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import profile_config, validate
from radarslam.core.errors import ConfigError
from radarslam.core.types import Odometry
from radarslam.models.ackermann import AckermannModel
from radarslam.models.body_velocity import BodyVelocityModel
from radarslam.models.motion import UnicycleModel
from radarslam.simulation.point_run import simulate_point_run
from radarslam.slam import EkfSlam, _fused
from radarslam.slam.bias import BiasStates, turn_noise

from consistency_bounds import nees_band
from test_odometry_bias import track

MODELS = [(UnicycleModel(), [3.0, 0.3]), (AckermannModel(), [3.0, 0.2]), (BodyVelocityModel(), [3.0, 0.4, 0.3])]


def _wrapped(d: np.ndarray) -> np.ndarray:
    d = d.copy()
    d[2] = math.remainder(d[2], 2.0 * math.pi)
    return d


@pytest.mark.parametrize("model, u", MODELS, ids=lambda v: getattr(v, "name", ""))
@pytest.mark.parametrize("turn", ["scale", "both"])
@pytest.mark.parametrize("theta", [0.4, 2.0 * math.pi - 1e-9])
def test_turn_scale_jacobians_match_central_differences(model, u, turn, theta):
    """F_s = [[F_x, F_u C_b], [0, Phi]] and G = F_u C_u with the turn scale kappa (c.11.8) against
    central differences of the augmented step, tau = 4 s."""
    spec = model.input_bias.with_turn(turn)
    bias = BiasStates(spec, [0.05] * spec.dim, [1e-3] * spec.dim, 4.0)
    u, dt, h = np.array(u), 0.1, 1e-6
    s0 = np.concatenate([[1.0, -2.0, theta], [0.03, -0.04, 0.02][:spec.dim]])
    n = s0.size

    def step(s, uu):
        phi, _ = bias.transition(dt)
        return np.concatenate([model.step(s[:3], spec.correct(uu, s[3:]), dt), phi * s[3:]])

    F, G, _ = bias.jacobians(s0[:3], s0[3:], u, dt, model)
    Fn = np.column_stack([_wrapped(step(s0 + h * e, u) - step(s0 - h * e, u)) / (2 * h) for e in np.eye(n)])
    Gn = np.column_stack([_wrapped(step(s0, u + h * e) - step(s0, u - h * e)) / (2 * h) for e in np.eye(u.size)])
    np.testing.assert_allclose(F, Fn, atol=1e-8)
    np.testing.assert_allclose(G, Gn[:3], atol=1e-8)
    assert F.shape == (3 + spec.dim, 3 + spec.dim)


@pytest.mark.parametrize("model, u", MODELS, ids=lambda v: getattr(v, "name", ""))
def test_turn_scale_correction_and_names(model, u):
    """``c(c^{-1}(u, b), b) = u``; the scale multiplies the turning input (an error proportional to
    the turn, zero when driving straight) and the offset adds to it; the states are named."""
    u = np.array(u)
    k = model.input_bias.offset
    for turn, b in (("scale", [0.04, 0.05]), ("both", [0.04, -0.02, 0.05])):
        spec = model.input_bias.with_turn(turn)
        np.testing.assert_allclose(spec.correct(spec.uncorrect(u, b), b), u, rtol=1e-15)
        assert spec.correct(u, b)[k] == pytest.approx(1.05 * u[k] + (b[1] if turn == "both" else 0.0), rel=1e-15)
        straight = u.copy()
        straight[k] = 0.0
        assert spec.with_turn("scale").correct(straight, [0.0, 0.05])[k] == 0.0
    names = AckermannModel.input_bias.with_turn("both").names
    assert names == ("speed_scale", "steering_offset", "steering_scale")
    assert UnicycleModel.input_bias.with_turn("scale").names[1] == "turn_rate_scale"


#: The keys of c.11.8-c.11.9 at their defaults (the Victoria Park profiles set them, c.11.10).
PLAIN = {"turn_noise_gain": 0.0, "measurement_corr_scans": 1.0}


def _plain_trees():
    cfg = profile_config("victoria-park-trees")
    return replace(cfg, filter=replace(cfg.filter, **PLAIN))


def _ackermann_config(**filter_keys):
    cfg = _plain_trees()
    filter_keys = {**PLAIN, **filter_keys}
    return validate(replace(cfg, filter=replace(cfg.filter, initial_pose=[0.0, 0.0, 0.0],
                                                initial_pose_std=[1e-6, 1e-6, 1e-6], **filter_keys)))


def test_turn_noise_is_the_analytic_covariance():
    """One prediction with ``turn_noise_gain`` k adds ``G diag(0, (k alpha)^2) G^T`` to the pose
    covariance of the plain prediction (c.11.8), and under c.11.6's ``odometry_tau_s`` the term is
    scaled like U by ``2 tau / dt``; with k = 0 U is the profile's for every sample."""
    alpha, v, dt, k = 0.3, 2.0, 0.025, 0.5
    u = np.array([v, alpha])
    np.testing.assert_allclose(turn_noise(np.diag([1.0, 2.0]), u, 1, k * k), np.diag([1.0, 2.0 + (k * alpha) ** 2]))
    plain, turn = EkfSlam(_ackermann_config()), EkfSlam(_ackermann_config(turn_noise_gain=k))
    for s in (plain, turn):
        s.predict(Odometry(t=dt, dt=dt, control=u))
    _, Fu = AckermannModel().jacobians(np.zeros(3), u, dt)
    np.testing.assert_allclose(turn.P[:3, :3] - plain.P[:3, :3], (k * alpha) ** 2 * np.outer(Fu[:, 1], Fu[:, 1]),
                               rtol=1e-12, atol=1e-18)
    tau = dict(odometry_tau_s=2.0, odometry_sample_s=dt)
    p2, t2 = EkfSlam(_ackermann_config(**tau)), EkfSlam(_ackermann_config(turn_noise_gain=k, **tau))
    for s in (p2, t2):
        s.predict(Odometry(t=dt, dt=dt, control=u))
    np.testing.assert_allclose(t2.P[:3, :3] - p2.P[:3, :3],
                               (k * alpha) ** 2 * (2 * 2.0 / dt) * np.outer(Fu[:, 1], Fu[:, 1]), rtol=1e-12)


def test_turn_noise_matches_a_monte_carlo_of_the_heading():
    """Over 200 samples of a drive whose steering sweeps 0 to 0.5 rad, the filter's heading variance
    with ``turn_noise_gain`` k equals that of 4000 dead-reckoned paths whose steering noise has the
    std ``sqrt(s0^2 + (k alpha)^2)`` (c.11.8), to 10 %; without the term it is more than 3 times too
    small (the negative control)."""
    s0, k, dt, v, n = math.radians(0.5), 0.1, 0.025, 2.0, 200   # small enough for the linearisation
    alphas = np.linspace(0.0, 0.5, n)
    rng = np.random.default_rng(11)
    model = AckermannModel()
    poses = np.zeros((4000, 3))
    std = np.sqrt(s0 ** 2 + (k * alphas) ** 2)
    for a, sd in zip(alphas, std):
        noisy = a + rng.standard_normal(poses.shape[0]) * sd
        poses = np.array([model.step(p, np.array([v, al]), dt) for p, al in zip(poses, noisy)])
    ref = poses[0, 2]
    mc_var = np.var(np.remainder(poses[:, 2] - ref + math.pi, 2 * math.pi))   # headings wrap at 2 pi
    keys = dict(steering_std_deg=math.degrees(s0), speed_std_mps=0.0, process_var_xy_m2=0.0,
                process_var_heading_rad2=0.0)
    on, off = EkfSlam(_ackermann_config(turn_noise_gain=k, **keys)), EkfSlam(_ackermann_config(**keys))
    for a in alphas:
        for s in (on, off):
            s.predict(Odometry(t=0.0, dt=dt, control=np.array([v, a])))
    assert on.P[2, 2] == pytest.approx(mc_var, rel=0.10)
    assert off.P[2, 2] < mc_var / 3


def test_measurement_corr_scans_scales_r_and_the_fused_engine_carries_both():
    """``measurement_corr_scans`` n_c: association and update take ``n_c R`` (c.11.9), landmark
    creation keeps R; the fused engine carries both new options (its runs equal its steps form's,
    tests/test_fused_victoria_park.py); n_c < 1 and a negative gain are refused, and turn noise
    needs a model with a turning input."""
    cfg = _plain_trees()
    base = EkfSlam(cfg)
    assert base.R_assoc is base.R
    corr = EkfSlam(replace(cfg, filter=replace(cfg.filter, measurement_corr_scans=4.0)))
    np.testing.assert_allclose(corr.R_assoc, 4.0 * base.R, rtol=1e-15)
    np.testing.assert_allclose(corr.R, base.R, rtol=0)
    EkfSlam(replace(cfg, filter=replace(cfg.filter, turn_noise_gain=0.3)))
    with pytest.raises(ConfigError, match="measurement_corr_scans"):
        validate(replace(cfg, filter=replace(cfg.filter, measurement_corr_scans=0.5)))
    with pytest.raises(ConfigError, match="turn_noise_gain"):
        validate(replace(cfg, filter=replace(cfg.filter, turn_noise_gain=-0.1)))
    with pytest.raises(ConfigError, match="bias_turn"):
        validate(replace(cfg, filter=replace(cfg.filter, bias_turn="gain")))

    class NoBias(UnicycleModel):
        input_bias = None
    with pytest.raises(ConfigError, match="turn_noise_gain"):
        EkfSlam(replace(cfg, filter=replace(cfg.filter, turn_noise_gain=0.3, motion_model="unicycle")),
                motion_model=NoBias())


# --------------------------------------------------------------------------------------------
# The turn scale on simulated odometry (c.11.8)
# --------------------------------------------------------------------------------------------
DT, DURATION, INPUT_STD = 0.05, 60.0, (0.05, math.radians(0.5))
KAPPA = 0.05                          # the odometer's turning input reads 1/1.05 of the truth


def _world(seed: int) -> np.ndarray:
    r = np.random.default_rng(2000 + seed)
    rad, a = 30.0 + r.uniform(-12, 12, 60), r.uniform(0, 2 * math.pi, 60)
    return np.column_stack([rad * np.cos(a), rad * np.sin(a) + 30.0])


def _controls() -> np.ndarray:
    """The unicycle about a 30 m circle with a turn rate that sweeps -0.1..0.3 rad/s (a scale error
    shows as a turn-dependent heading error)."""
    t = np.arange(int(DURATION / DT)) * DT
    v = 3.0 + 0.5 * np.sin(2 * math.pi * t / 23.0)
    return np.column_stack([v, v / 30.0 + 0.2 * np.sin(2 * math.pi * t / 11.0)])


def _config(bias: str):
    cfg = _plain_trees()
    f = replace(cfg.filter, motion_model="unicycle", odometry_bias=bias, bias_turn="scale", range_std_m=0.1,
                azimuth_std_deg=1.0, speed_std_mps=INPUT_STD[0], turn_rate_std_deg_s=math.degrees(INPUT_STD[1]),
                process_var_xy_m2=1e-9, process_var_heading_rad2=1e-10, initial_pose=[0.0, 0.0, 0.0],
                initial_pose_std=[1e-3, 1e-3, 1e-4], bias_turn_scale_std=0.1, bias_turn_scale_drift_per_rt_s=0.0)
    return validate(replace(cfg, filter=f))


_track = track        # position errors, pose NEES and the filter (tests/test_odometry_bias.py)


@pytest.mark.slow
def test_turn_scale_state_is_estimated_on_biased_odometry():
    """Three seeded runs with a 5 % turn-rate scale error (and a 3 % speed scale): with the turn-scale
    state the final kappa lies within 2 sigma of the truth in every run (a consistent filter misses
    with probability 0.046 each) and its std is below a quarter of the prior's; the pose NEES (3 dof)
    averaged over the 3 runs and their 300 scans lies in the two-sided 95% band of the per-scan mean
    of 3 runs, chi2(9) / 3 = [0.90, 6.34] (the scans are correlated: the per-scan band is the time
    average's conservative band, tests/consistency_bounds.py; measured 5.4). Negative controls on
    the same data: the filter told the odometry 10 times more precise than it is (speed and turn-rate
    stds / 10) lies above the band (measured 186); the filter without the states has a position RMSE
    at least 3 times larger and a pose NEES above 50."""
    model = UnicycleModel()
    spec = model.input_bias.with_turn("scale")
    truth = np.array([0.03, KAPPA])
    on = _config("states")
    sharp = replace(on, filter=replace(on.filter, speed_std_mps=on.filter.speed_std_mps / 10,
                                       turn_rate_std_deg_s=on.filter.turn_rate_std_deg_s / 10))
    nees1, nees_sharp = [], []
    for seed in range(3):
        run = simulate_point_run(model, _controls(), DT, _world(seed), truth, np.random.default_rng(seed),
                                 input_std=INPUT_STD, spec=spec)
        err1, n1, slam = _track(on, run)
        err0, n0, _ = _track(_config("none"), run)
        std = np.sqrt(np.diag(slam.state.bias_cov))
        assert slam.bias_model.names == ("speed_scale", "turn_rate_scale")
        assert abs(slam.bias[1] - KAPPA) < 2 * std[1], (seed, slam.bias, std)
        assert std[1] < 0.1 / 4
        assert np.sqrt(np.mean(err0 ** 2)) > 3 * np.sqrt(np.mean(err1 ** 2)), seed
        assert n0.mean() > 50, (seed, n0.mean())
        nees1.append(n1)
        nees_sharp.append(_track(sharp, run)[1])
    lo, hi = nees_band(3, len(nees1))
    assert lo <= np.mean(nees1) <= hi, (np.mean(nees1), lo, hi)
    assert np.mean(nees_sharp) > hi, (np.mean(nees_sharp), hi)
