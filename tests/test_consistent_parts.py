"""The parts of the consistent extended-landmark filter (docs/method.md a.7.1, a.7.3, c.8):
the measurement-contour gate, the per-landmark batch update, the cluster-mean initialisation and
the spread of landmarks without an extent."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from radarslam.extent.sifting import chi2_2dof_quantile, literal_contour, measurement_contour
from radarslam.slam import EkfSlam, ekf
from radarslam.slam.association import BatchAssociator, Spreads
from radarslam.slam.state import SlamState

import associator_oracles as oracle
from helpers import quiet_config, rect_points, scan


def _spd(rng, n, scale):
    A = rng.normal(size=(n, 2, 2)) * scale
    return A @ A.transpose(0, 2, 1) + 1e-3 * np.eye(2)


@pytest.mark.parametrize("probability", [0.9, 0.95, 0.99, 0.999])
def test_measurement_contour_accepts_draws_of_the_predicted_spread_at_the_stated_rate(probability):
    """Detections drawn from N(p, gamma_z X + W + P^n) pass the gate with the gate probability
    (binomial 4-sigma bound over 20,000 draws); drawn from twice the spread they do not (negative
    control)."""
    rng = np.random.default_rng(7)
    n_lm, n = 40, 500
    p = rng.uniform(-30, 30, (n_lm, 2))
    spread = 0.25 * _spd(rng, n_lm, 1.5)
    Pn = _spd(rng, n_lm, 0.3)
    g = chi2_2dof_quantile(probability)
    assert g == pytest.approx(stats.chi2.ppf(probability, 2), rel=1e-12)
    hits = draws = hits_wide = 0
    for j in range(n_lm):
        W = _spd(rng, n, 0.4)
        S = spread[j] + W + Pn[j]                                    # (n, 2, 2)
        L = np.linalg.cholesky(S)
        z = p[j] + np.einsum("nij,nj->ni", L, rng.normal(size=(n, 2)))
        z_wide = p[j] + math.sqrt(2.0) * np.einsum("nij,nj->ni", L, rng.normal(size=(n, 2)))
        hits += measurement_contour(z, W, p[j:j + 1], spread[j:j + 1], Pn[j:j + 1], g)[:, 0].sum()
        hits_wide += measurement_contour(z_wide, W, p[j:j + 1], spread[j:j + 1], Pn[j:j + 1], g)[:, 0].sum()
        draws += n
    sd = math.sqrt(probability * (1 - probability) / draws)
    assert abs(hits / draws - probability) < 4 * sd + 1e-12, hits / draws
    # twice the covariance: P(chi2_2 <= g / 2) = 1 - (1 - p)^(1/2), far below p
    expected_wide = 1.0 - math.sqrt(1.0 - probability)
    assert abs(hits_wide / draws - expected_wide) < 4 * math.sqrt(expected_wide * (1 - expected_wide) / draws)
    assert hits_wide / draws < probability - 8 * sd


def test_measurement_contour_matrix_matches_a_direct_evaluation():
    rng = np.random.default_rng(3)
    m, N = 37, 9
    z, p = rng.uniform(-10, 10, (m, 2)), rng.uniform(-10, 10, (N, 2))
    W, S, Pn = _spd(rng, m, 0.5), _spd(rng, N, 1.0), _spd(rng, N, 0.2)
    got = measurement_contour(z, W, p, S, Pn, 5.0)
    for i in range(m):
        for j in range(N):
            e = z[i] - p[j]
            assert got[i, j] == (e @ np.linalg.solve(S[j] + W[i] + Pn[j], e) <= 5.0)
    X = _spd(rng, N, 1.0)
    lit = literal_contour(z, p, X, 1.3)
    for i in range(m):
        for j in range(N):
            e = z[i] - p[j]
            assert lit[i, j] == (e @ np.linalg.solve(X[j], e) <= 1.69)


def _linear_state(rng, n_lm=4):
    """A state whose heading is known exactly (no heading variance or cross-covariance): the
    sensor-frame measurement Rot(-theta) (p - t) is then linear in the uncertain entries."""
    n = 3 + 2 * n_lm
    A = rng.normal(size=(n, n)) * 0.3
    P = A @ A.T + np.eye(n) * 0.05
    P[2, :] = P[:, 2] = 0.0
    x = np.r_[rng.uniform(-2, 2, 2), 0.7, rng.uniform(-15, 15, 2 * n_lm)]
    return x, P


@pytest.mark.parametrize("seed", range(5))
def test_batch_update_equals_the_sequential_updates_in_the_linear_case(seed):
    rng = np.random.default_rng(seed)
    x, P = _linear_state(rng)
    j, m = int(rng.integers(4)), int(rng.integers(2, 12))
    Sigma = _spd(rng, 1, 0.4)[0]
    h, Hs, idx = ekf.sensor_xy_measurement(x, j)
    zs = h + rng.normal(0, 0.5, (m, 2))
    xs, Ps = x, P
    for z in zs:
        hh, H2, idx2 = ekf.sensor_xy_measurement(xs, j)
        xs, Ps = ekf.update(xs, Ps, z - hh, H2, idx2, Sigma)
    xb, Pb = ekf.update(x, P, zs.mean(axis=0) - h, Hs, idx, Sigma / m)
    np.testing.assert_allclose(xb, xs, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Pb, Ps, rtol=0, atol=1e-9)
    # negative control: the batch with the undivided noise is a different (weaker) update
    xw, Pw = ekf.update(x, P, zs.mean(axis=0) - h, Hs, idx, Sigma)
    assert np.abs(Pw - Ps).max() > 1e-3


def test_sensor_xy_jacobian_matches_finite_differences():
    rng = np.random.default_rng(5)
    x = np.r_[rng.uniform(-3, 3, 2), 1.1, rng.uniform(-10, 10, 6)]
    for j in range(3):
        h, Hs, idx = ekf.sensor_xy_measurement(x, j)
        for c, i in enumerate(idx):
            dx = np.zeros_like(x)
            dx[i] = 1e-6
            fd = (ekf.sensor_xy_measurement(x + dx, j)[0] - ekf.sensor_xy_measurement(x - dx, j)[0]) / 2e-6
            np.testing.assert_allclose(Hs[:, c], fd, rtol=1e-6, atol=1e-8)


def test_batch_associator_assigns_as_the_sequential_scheme_scores_first_and_updates_once_per_landmark():
    rng = np.random.default_rng(11)
    n_lm = 6
    L = rng.uniform(-15, 15, (n_lm, 2)) + np.array([20.0, 0.0])
    x = np.r_[0.0, 0.0, 0.2, L.ravel()]
    P = np.diag(np.r_[0.01, 0.01, 1e-4, np.full(2 * n_lm, 0.3)])
    pts = np.concatenate([L[j] + rng.normal(0, 0.5, (5, 2)) for j in range(n_lm)])
    d = pts - x[:2]
    polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - x[2]])
    cand = np.arange(polar.shape[0])
    R = np.diag([0.25, math.radians(1.0) ** 2])
    spreads = Spreads(np.repeat(0.25 * np.eye(2)[None], n_lm, 0), np.ones(n_lm, dtype=bool))
    batch = BatchAssociator(20.0, 3, 5)
    st = SlamState.from_mean(x.copy(), P.copy())
    out, nis = batch.associate(st, polar, cand, R, spreads)
    # the assignment is the sequential scheme's first choice for each detection at the prior state
    first = [oracle.best_match(SlamState.from_mean(x, P), s, 3, R, spreads)
             for s in polar]
    assert out.tolist() == [j if D < 20.0 else -1 for j, D, *_ in first]
    assert nis.size == np.unique(out[out >= 0]).size          # one update per landmark
    assert np.all(np.diag(st.P) <= np.diag(P) + 1e-12)        # updates never add uncertainty


def test_cluster_mean_initialisation_and_prior_spread():
    """landmarks.init = cluster: the landmark sits at the mean of the cluster's detections, with
    the mean's noise plus the prior spread gamma_z r^2 I (not at the nearest detection with R)."""
    base = quiet_config(use_extent=True)
    cfg = replace(base, landmarks=replace(base.landmarks, init="cluster"),
                  extent=replace(base.extent, pre_init_spread="prior", prior_extent_radius_m=1.2))
    pts = rect_points(9.0, 2.0, 4.0, 2.0, 10, seed=1)
    slam = EkfSlam(cfg)
    slam.update(scan(1, pts))
    assert len(slam.landmarks) == 1
    np.testing.assert_allclose(slam.x[3:5], pts.mean(axis=0), atol=1e-9)
    C = slam.P[3:5, 3:5]
    prior = 0.25 * 1.2**2 * np.eye(2)
    assert np.all(np.linalg.eigvalsh(C - prior) > 0)          # at least the prior spread
    assert np.all(np.linalg.eigvalsh(C - prior) < 0.25)       # plus a mean's noise of 10 detections
    nearest = EkfSlam(base)
    nearest.update(scan(1, pts))
    assert np.linalg.norm(nearest.x[3:5] - pts.mean(axis=0)) > 0.3   # negative control: the paper's init


def test_pre_init_spread_inflates_the_noise_before_the_extent_exists():
    base = quiet_config(use_extent=True)
    cfgs = {m: replace(base, extent=replace(base.extent, pre_init_spread=m)) for m in ("none", "prior", "scatter")}
    slams = {m: EkfSlam(c) for m, c in cfgs.items()}
    for m, s in slams.items():
        s.update(scan(1, rect_points(9.0, 2.0, 4.0, 2.0, 8, seed=0)))
        s.update(scan(2, rect_points(9.0, 2.0, 4.0, 2.0, 6, seed=2)))
        assert not s.landmarks[0].extent.initialized
    spread = {m: s.extent.spreads([r.extent for r in s.landmarks]) for m, s in slams.items()}
    assert not spread["none"][1].any()
    np.testing.assert_allclose(spread["prior"][0][0], 0.25 * 2.0**2 * np.eye(2))
    ext = slams["scatter"].landmarks[0].extent
    buffered = ext.buffer[:ext.n_buffered]
    np.testing.assert_allclose(spread["scatter"][0][0], np.cov(buffered.T))
