"""The part in view centred anywhere on its object (docs/method.md c.17, ``extent.view_offset``):
the batch noise's extra term, the engines' agreement, the refusals, and the drag it removes on a
simulated road between guard rails (with the default as the negative control)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from conftest import require

from radarslam.config import profile_config
from radarslam.core.errors import ConfigError
from radarslam.simulation.guard_rail import Road, objects, road_config, run_road
from radarslam.slam import EkfSlam, ekf
from radarslam.slam.association import JointBatchAssociator, Spreads
from radarslam.slam.state import SlamState


def _rot(theta):
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s], [s, c]])


def test_batch_noise_adds_the_spread_once_undivided(rng):
    """``(Rot^T gX Rot + R_xy) / m + k Rot^T gX Rot``: the analytic form for every m; k = 0 is the
    a.7.3 noise bit for bit; without a spread (``has`` false) the offset adds nothing."""
    A = rng.normal(size=(2, 2))
    gX, R_xy, theta = A @ A.T, np.diag([0.04, 0.09]), 0.7
    S = _rot(theta).T @ gX @ _rot(theta)
    for m in (1, 4, 50):
        for k in (0.0, 1.0, 2.5):
            np.testing.assert_allclose(ekf.batch_noise(theta, gX, True, R_xy, m, k), (S + R_xy) / m + k * S,
                                       rtol=1e-13, atol=1e-15)
        assert np.array_equal(ekf.batch_noise(theta, gX, True, R_xy, m, 0.0), ekf.batch_noise(theta, gX, True, R_xy, m))
        assert np.array_equal(ekf.batch_noise(theta, gX, False, R_xy, m, 3.0), R_xy / m)
    # the offset does not average down: m -> infinity leaves k S
    np.testing.assert_allclose(ekf.batch_noise(theta, gX, True, R_xy, 10 ** 9, 1.0), S, atol=1e-9)


def test_offset_k_is_a_uniform_point_of_the_ellipse():
    """``offset_k gamma_z X = X / 4``: the covariance of a point uniform over the ellipse of X, the
    sample oracle (200k draws) within 1%; for each spread model's gamma_z."""
    from radarslam.slam.view_offset import view_offset_k

    rng = np.random.default_rng(7)
    r = np.sqrt(rng.uniform(size=200_000))
    a = rng.uniform(0, 2 * np.pi, size=r.size)
    X = np.array([[25.0, 3.0], [3.0, 0.5]])                  # a long, thin, turned object
    L = np.linalg.cholesky(X)
    pts = (L @ np.vstack([r * np.cos(a), r * np.sin(a)])).T
    np.testing.assert_allclose(np.cov(pts.T), X / 4, rtol=0.01, atol=0.01)
    for model in ("surface", "contour", "scatter-centres"):
        cfg = profile_config("automotive")
        cfg = replace(cfg, extent=replace(cfg.extent, view_offset="uniform", spread_model=model))
        k = view_offset_k(cfg.estimator, False)
        assert k * cfg.extent.spread_factor * X == pytest.approx(X / 4)


@pytest.mark.parametrize("overlay, key", [
    ({"landmarks": {"associator": "jcbb"}}, "landmarks.associator"),
    ({"landmarks": {"associator": "nearest-neighbour"}}, "landmarks.associator"),
    ({"extent": {"use_in_slam": False}}, "use_in_slam"),
    ({"extent": {"view_model": "partial"}}, "partial-view"),
])
def test_refused_where_it_has_no_place(overlay, key):
    cfg = profile_config("automotive")
    sections = {s: replace(getattr(cfg, s), **kv) for s, kv in overlay.items()}
    sections["extent"] = replace(sections.get("extent", cfg.extent), view_offset="uniform")
    with pytest.raises(ConfigError, match=r"^extent\.view_offset: .*" + key.replace(".", r"\.")) as e:
        EkfSlam(replace(cfg, **sections))
    assert "\n" not in str(e.value)
    EkfSlam(replace(cfg, extent=replace(cfg.extent, view_offset="uniform")))   # the profile's own: accepted


@pytest.mark.parametrize("seed", range(6))
def test_compiled_joint_batch_matches_python_with_the_offset(seed):
    """The compiled batch-joint update with ``offset_k`` equals the Python reference (1e-12), and the
    offset changes the update (the negative control: k = 0 gives another state)."""
    require("numba")
    import associator_oracles as oracle

    rng = np.random.default_rng(100 + seed)
    n = 8
    x = np.concatenate([[1.0, -2.0, 0.3], rng.uniform(-30, 30, 2 * n)])
    A = rng.normal(size=(x.size, x.size)) * 0.1
    P = A @ A.T + 0.05 * np.eye(x.size)
    lm = x[3:].reshape(-1, 2)[rng.integers(n, size=60)] + rng.normal(0, 1.5, (60, 2))
    d = lm - x[:2]
    polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - x[2]])
    cand = np.arange(polar.shape[0])
    R = np.diag([0.16, math.radians(1.0) ** 2])
    B = rng.normal(size=(n, 2, 2))
    spreads = Spreads(0.25 * (B @ B.transpose(0, 2, 1)) * 4, rng.random(n) < 0.7, offset_k=1.0)
    states = {}
    for name, assoc, sp in (("py", lambda *a: oracle.joint_batch(*a, 20.0, 3), spreads),
                            ("nb", JointBatchAssociator(20.0, 3, 5, backend="numba").associate, spreads),
                            ("k0", JointBatchAssociator(20.0, 3, 5, backend="numba").associate,
                             replace(spreads, offset_k=0.0))):
        st = SlamState.from_mean(x.copy(), P.copy())
        out, _ = assoc(st, polar, cand, R, sp)
        states[name] = (out, st.x.copy(), st.P.copy())
    assert np.array_equal(states["py"][0], states["nb"][0]) and (states["py"][0] >= 0).sum() > 0
    np.testing.assert_allclose(states["nb"][1], states["py"][1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(states["nb"][2], states["py"][2], rtol=0, atol=1e-12)
    assert np.abs(states["k0"][1] - states["py"][1]).max() > 1e-6


def test_the_road_world_is_what_it_says():
    """Rails of the stated length on both sides, posts alternating at the stated offset."""
    road = Road(speed_mps=20.0, duration_s=5.0)
    rails, posts = objects(road)
    assert np.allclose(rails[:, 1] - rails[:, 0], road.rail_length_m)
    assert set(np.unique(rails[:, 2])) == {-road.rail_offset_m, road.rail_offset_m}
    assert np.allclose(np.abs(posts[:, 1]), road.post_offset_m) and np.all(np.diff(np.sign(posts[:, 1])) != 0)
    assert rails[:, 1].max() > road.speed_mps * (1 + road.speed_swing) * road.duration_s + road.range_m


@pytest.mark.slow
def test_guard_rails_drag_the_pose_and_the_offset_stops_it():
    """At 20 m/s past guard rails for 20 s, seeds 2-21 (apart from the reporting seed 1; measured
    there: the default's along-track error -0.128 m on average over the drive, the offset's -0.018,
    the paired difference +0.110 with standard error 0.014): the default's pose lags along the road
    (the negative control, below -0.06 m), and the offset takes at least half of the lag away, its
    paired improvement's 99% t interval above zero."""
    from scipy import stats

    base = profile_config("automotive")
    road = Road(speed_mps=20.0, duration_s=20.0)
    along = {mode: np.array([run_road(road_config(base, mode), road, s)["along_mean_m"] for s in range(2, 22)])
             for mode in ("none", "uniform")}
    d = along["uniform"] - along["none"]
    assert along["none"].mean() < -0.06, along
    assert abs(along["uniform"].mean()) < 0.5 * abs(along["none"].mean()), along
    assert d.mean() - stats.t.ppf(0.995, d.size - 1) * d.std(ddof=1) / np.sqrt(d.size) > 0.0, d
