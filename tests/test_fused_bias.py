"""The fused engine with odometry-bias states (docs/method.md c.11, ``filter.odometry_bias = "states"``)
against its steps form run event by event (the filter object, EkfSlam with filter.fused false), and its prediction against :class:`BiasStates`'.

The platform block is then ``[x, y, theta, b_1 .. b_m]``: every landmark index, the records and the
prediction follow it. The oracle is ``EkfSlam`` event by event (numba backend, ``filter.fused``
false): the same associations and landmark ids after every scan, the poses, maps, NIS and the bias
states and their covariances after every scan to 1e-9 (tests/test_fused.py's comparison), on car-park
runs simulated with a biased odometer, for each form of the turn's error (c.11.8), a Gauss-Markov
bias, first-estimates Jacobians (c.11.7), each associator, turn-dependent noise with the
correlated-R equivalent (c.11.8-c.11.9) and Doppler odometry (c.10.5, the body-velocity model's
states); Victoria Park's Ackermann runs are in tests/test_fused_victoria_park.py.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from conftest import require

require("numba")

from radarslam.config import merge_tables, profile_config  # noqa: E402
from radarslam.config.variants import CONSISTENT  # noqa: E402
from radarslam.models.ackermann import AckermannModel  # noqa: E402
from radarslam.models.body_velocity import BodyVelocityModel  # noqa: E402
from radarslam.models.motion import UnicycleModel  # noqa: E402
from radarslam.slam import _fused  # noqa: E402
from radarslam.slam.bias import BiasStates  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402
from radarslam.slam.fused import tracking  # noqa: E402
from radarslam.slam.fused.bias import predict_platform  # noqa: E402
from radarslam.slam.fused.plan import _bias_parameters  # noqa: E402
from test_fused import _assert_same_run, _overlay, _scenario  # noqa: E402

#: A car park whose odometer reads the speed 4 % high with a 0.5 deg/s turn-rate offset (c.11.4).
BIASED = {"odometer": {"speed_scale": 1.04, "turn_rate_bias_deg_s": 0.5}}
STATES = {"filter": {"odometry_bias": "states"}}
CASES = {
    "offset": {},
    "scale": {"filter": {"bias_turn": "scale"}},
    "both": {"filter": {"bias_turn": "both"}},
    "gauss-markov-both": {"filter": {"bias_turn": "both", "bias_tau_s": 10.0}},
    "fej": {"filter": {"jacobians": "fej"}},
    "fej-scale-batch": {"filter": {"jacobians": "fej", "bias_turn": "scale"}, "landmarks": {"associator": "batch"}},
    "consistent": CONSISTENT.overlay,
    "consistent-fej-both": merge_tables(CONSISTENT.overlay, {"filter": {"jacobians": "fej", "bias_turn": "both"}}),
    "jcbb": {"landmarks": {"associator": "jcbb"}, "extent": {"use_in_slam": True}},
    "turn-noise-corr-r": {"filter": {"turn_noise_gain": 0.5, "measurement_corr_scans": 3.0}},
    "thrust-fej": {"filter": {"bias_thrust": True, "jacobians": "fej"}},
}


def _biased_carpark(doppler: bool = False):
    cfg = _overlay(profile_config("apsipa"), BIASED)
    if doppler:
        cfg = replace(cfg, radar=replace(cfg.radar, doppler=True))
    return cfg


@pytest.mark.parametrize("name", sorted(CASES))
@pytest.mark.parametrize("trial", [3, 4])
def test_bias_states_same_as_the_steps_form(name, trial):
    """Every decision and every estimate after every scan, the bias states included; the states
    moved (they are not at their prior 0) and changed the run (negative control: without them)."""
    cfg = _biased_carpark()
    events = _scenario(cfg, trial).events
    run = _overlay(cfg, merge_tables(STATES, CASES[name]))
    assert _assert_same_run(run, events) > 1000                  # a real run: a thousand associations or more
    r, _ = _fused.run(EkfSlam(run), events)
    m = EkfSlam(run).bias_model.dim
    assert r["bias"].shape == (r["poses"].shape[0], m) and r["bias_covs"].shape == (r["poses"].shape[0], m, m)
    assert np.abs(r["bias"][-1]).max() > 1e-3                         # the states were estimated
    without = {k: {kk: vv for kk, vv in v.items() if kk != "bias_thrust"} for k, v in CASES[name].items()}
    plain, _ = _fused.run(EkfSlam(_overlay(cfg, without)), events)      # the thrust is a bias state (c.11.12)
    assert plain["bias"].shape == (plain["poses"].shape[0], 0)
    assert np.abs(r["poses"] - plain["poses"]).max() > 1e-6


def test_speed_scale_is_learnt_by_the_fused_engine():
    """The estimated speed scale after a run with an odometer reading 4 % high is near the correction
    ``1 / 1.04 - 1`` (``u_c = (1 + eps) u``; the states' purpose, c.11.4), within 4 of its own std
    (its prior std is 0.05: the scans taught it); and not near 0, which the filter without the
    states implicitly assumes (negative control)."""
    cfg = _biased_carpark()
    run = _overlay(cfg, merge_tables(STATES, CONSISTENT.overlay))
    est, std = [], []
    for trial in (1, 2, 3):
        r, _ = _fused.run(EkfSlam(run), _scenario(cfg, trial).events)
        est.append(r["bias"][-1, 0])
        std.append(math.sqrt(r["bias_covs"][-1, 0, 0]))
    assert max(std) < 0.02
    for e, s in zip(est, std):
        assert abs(e - (1.0 / 1.04 - 1.0)) < 4 * s, (est, std)
        assert abs(e) > 4 * s, (est, std)


@pytest.mark.parametrize("mode", ["doppler", "both"])
def test_bias_states_with_doppler_odometry_same_as_the_steps_form(mode):
    """Under Doppler odometry (c.10.5) the body-velocity model's states ([speed scale, yaw-rate
    offset] on ``[v_x, v_y, omega]``) through the fused engine: the steps form's run."""
    cfg = _biased_carpark(doppler=True)
    events = _scenario(cfg, 3).events
    run = _overlay(cfg, merge_tables(STATES, merge_tables(CONSISTENT.overlay, {"filter": {"odometry": mode}})))
    assert EkfSlam(run).bias_model.names == ("speed_scale", "yaw_rate_offset")
    assert _assert_same_run(run, events) > 1500


# ---------------------------------------------------------------------------------------- the prediction
MODELS = [(UnicycleModel(), tracking.UNICYCLE, 2), (AckermannModel(), tracking.ACKERMANN, 2),
          (BodyVelocityModel(), tracking.BODY_VELOCITY, 3)]


@pytest.mark.parametrize("model, code, n_u", MODELS, ids=lambda v: getattr(v, "name", ""))
@pytest.mark.parametrize("turn", ["offset", "scale", "both"])
@pytest.mark.parametrize("tau", [0.0, 4.0])
def test_prediction_compiled_same_as_bias_states(model, code, n_u, turn, tau):
    """The engine's prediction with bias states equals :meth:`BiasStates.predict_terms` (c.11.2) on
    random states, with the standard and the first-estimates Jacobians (c.11.7): the platform block,
    its covariance, its cross-covariance with the landmarks; the landmarks' block untouched."""
    spec = model.input_bias.with_turn(turn)
    bias = BiasStates(spec, np.full(spec.dim, 0.05), np.full(spec.dim, 2e-3), tau)
    cfg = profile_config("victoria-park" if code == tracking.ACKERMANN else "apsipa")
    params = _fused._parameters(EkfSlam(cfg))._replace(**_bias_parameters(bias))
    p = bias.platform_dim
    assert params.platform == p == 3 + spec.dim
    rng = np.random.default_rng(11)
    U, Q = np.diag(rng.uniform(0.01, 0.1, n_u)), np.diag(rng.uniform(1e-4, 1e-3, 3))
    for _ in range(30):
        n = p + 2 * int(rng.integers(0, 5))
        x = np.concatenate([rng.uniform(-50, 50, 2), [rng.uniform(0, 2 * math.pi)], rng.normal(0, 0.05, spec.dim),
                            rng.uniform(-50, 50, n - p)])
        A = rng.normal(size=(n, n))
        P = A @ A.T + n * np.eye(n)
        u = np.concatenate([[rng.uniform(-1, 7)], rng.uniform(-0.5, 0.5, n_u - 1)])
        dt = float(rng.uniform(0.01, 0.3))
        first = x[:3] + rng.normal(0.0, [0.3, 0.3, 0.02])
        for fej in (False, True):
            s, Pss, Psl = bias.predict_terms(x, P, u, dt, model, U, Q, first if fej else None)
            xf, Pf, pf = x.copy(), P.copy(), first.copy()
            assert predict_platform(xf, Pf, u, dt, U, Q, pf, code, params._replace(fej=fej))
            np.testing.assert_allclose(xf[:p], s, rtol=1e-13, atol=1e-12)
            np.testing.assert_array_equal(pf, xf[:3] if fej else first)
            np.testing.assert_array_equal(xf[p:], x[p:])
            np.testing.assert_allclose(Pf[:p, :p], Pss, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(Pf[:p, p:], Psl, rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(Pf[p:, :p], Psl.T, rtol=1e-12, atol=1e-12)
            np.testing.assert_array_equal(Pf[p:, p:], P[p:, p:])
            assert np.abs(xf[3:p] - x[3:p]).max() <= np.abs(x[3:p]).max()      # the bias decays or stays


def test_prediction_without_bias_is_the_plain_one_and_refuses_non_finite():
    """``cfg.platform`` 3 is :func:`tracking.predict` itself, bit for bit; with bias states a
    non-finite prediction leaves the state as it was."""
    slam = EkfSlam(profile_config("apsipa"))
    params = _fused._parameters(slam)
    assert params.platform == 3 and params.bias_scaled.shape == (0,)
    rng = np.random.default_rng(3)
    x = np.array([1.0, 2.0, 0.4, 5.0, 6.0])
    P = np.eye(5) + 0.1
    u, dt = np.array([3.0, 0.2]), 0.1
    a, Pa = x.copy(), P.copy()
    b, Pb = x.copy(), P.copy()
    assert predict_platform(a, Pa, u, dt, slam.U, slam.Q, x[:3].copy(), params.motion, params)
    assert tracking.predict(b, Pb, u, dt, slam.U, slam.Q, x[:3].copy(), params.motion, params)
    assert np.array_equal(a, b) and np.array_equal(Pa, Pb)
    on = EkfSlam(replace(slam.config, filter=replace(slam.config.filter, odometry_bias="states")))
    bp = _fused._parameters(on)
    x = np.concatenate([on.x, rng.uniform(-5, 5, 2)])
    P = np.eye(7)
    assert not predict_platform(x, P, np.array([1e308, 0.1]), 1e10, on.U, on.Q, x[:3].copy(), bp.motion, bp)
    assert np.array_equal(x[:5], on.x) and np.array_equal(P, np.eye(7))
