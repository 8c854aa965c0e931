"""The extent pipeline inside SLAM (docs/method.md a.3-a.8, Decisions 3-6)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from helpers import quiet_config, rect_points, scan

from radarslam.core.types import Odometry
from radarslam.extent.ellipse_fit import _fit_ellipse
from radarslam.extent.measurement import converted_measurement_covs, select_scan_W
from radarslam.extent.random_matrix import rm_predict, rm_update
from radarslam.models.radar import polar_to_xy, xy_to_polar
from radarslam.slam.filter import EkfSlam

CAR = (9.0, 2.0, 4.0, 2.0)  # a 4 x 2 car centred at (11, 3)


def run_scans(cfg, n_scans, n_pts=6, first=8, odometry=False, car=CAR):
    slam = EkfSlam(cfg)
    slam.update(scan(1, rect_points(*car, first, seed=0)))
    for k in range(2, n_scans + 1):
        if odometry:
            slam.predict(Odometry(0.16 * (k - 1), 0.16, np.array([0.0, 0.0])))
        slam.update(scan(k, rect_points(*car, n_pts, seed=k)))
    return slam


def test_extent_initialises_after_more_than_20_buffered_detections():
    cfg = quiet_config()
    slam = EkfSlam(cfg)
    slam.update(scan(1, rect_points(*CAR, 8, seed=0)))
    total = 0
    for k in range(2, 12):
        rep = slam.update(scan(k, rect_points(*CAR, 6, seed=k)))
        st = slam.landmarks[0].extent               # the landmark's extent after this scan
        total += rep.associations.get(0, np.empty(0)).size
        if total <= cfg.extent.n_init:
            assert not st.initialized and st.n_buffered == total, k
        else:
            break
    assert st.initialized and st.initialized_at == k and st.alpha == cfg.extent.alpha0
    assert 20 < total <= 26
    # EFA upper bound on the buffered points (converted with each scan's updated pose): X = 4 C.
    assert np.allclose(st.X, st.X_efa)
    lam = np.linalg.eigvalsh(st.X)
    assert 1.0 < math.sqrt(lam[1]) < 4.0 and 0.5 < math.sqrt(lam[0]) < 2.0


def test_extent_step_equals_kernels_by_hand():
    """RM predict + update with the prior centroid/cov and the updated pose (Decision 3, h.4)."""
    cfg = quiet_config()
    slam = run_scans(cfg, 6, odometry=True)
    st = slam.landmarks[0].extent
    assert st.initialized
    X0, a0 = st.X.copy(), st.alpha
    slam.predict(Odometry(1.0, 0.16, np.array([0.0, 0.0])))
    p_prior = slam.x[3:5].copy()
    P_prior = slam.P[3:5, 3:5].copy()
    s = scan(7, rect_points(*CAR, 7, seed=70))
    rep = slam.update(s)
    st = slam.landmarks[0].extent                   # after the scan
    idx = rep.associations[0]
    assert idx.size == 7
    polar = s.polar[idx]
    Xp, ap = rm_predict(X0, a0, 0.16, cfg.extent.tau_s)
    pts = polar_to_xy(slam.x[:3], polar)  # the updated pose
    W = select_scan_W(converted_measurement_covs(slam.x[:3], slam.P[:3, :3], polar, slam.R), "max_trace")
    X1, a1 = rm_update(Xp, ap, p_prior, P_prior, pts, W, gamma=0.25)
    assert math.isclose(st.alpha, a0 * math.exp(-0.16 / 100) + 2 * (1 - math.exp(-0.16 / 100)) + 7, rel_tol=1e-12)
    assert math.isclose(st.alpha, a1, rel_tol=1e-12)
    assert np.allclose(st.X, X1, atol=1e-12)
    # The per-scan EFA refit: 4 C of this scan's points.
    fit = _fit_ellipse(pts)
    assert np.allclose(st.X_efa, fit[1], atol=1e-12)


def test_posterior_landmark_flag_changes_the_update():
    from dataclasses import replace

    cfg = quiet_config()
    cfg2 = replace(cfg, extent=replace(cfg.extent, use_posterior_landmark=True))
    a = run_scans(cfg, 9).landmarks[0].extent.X
    b = run_scans(cfg2, 9).landmarks[0].extent.X
    assert not np.allclose(a, b) and np.allclose(a, b, atol=0.5)  # second-order difference (h.4)


def test_efa_keeps_previous_estimate_with_fewer_than_3_points():
    slam = run_scans(quiet_config(), 6)
    before = slam.landmarks[0].extent.X_efa.copy()
    slam.update(scan(7, rect_points(*CAR, 2, seed=71)))
    assert np.array_equal(slam.landmarks[0].extent.X_efa, before)


def test_extent_converges_towards_moment_ellipse():
    """Many scans of uniform rectangle points: RMA semi-axes approach (L/sqrt 3, W/sqrt 3)."""
    slam = run_scans(quiet_config(), 150, n_pts=8)
    lam = np.sort(np.linalg.eigvalsh(slam.landmarks[0].extent.X))[::-1]
    axes = np.sqrt(lam)
    assert np.allclose(axes, [4 / math.sqrt(3), 2 / math.sqrt(3)], rtol=0.15)


def test_extent_dropped_with_its_landmark():
    slam = run_scans(quiet_config(), 6)
    assert slam.landmarks[0].extent.initialized
    for k in range(7, 17):
        slam.update(scan(k))
    assert slam.landmarks == [] and slam.state.n_landmarks == 0
    snap = slam.snapshot()
    assert snap.rma.shape == (0, 2, 2) and snap.efa.shape == (0, 2, 2)


def literal(cfg):
    """The paper's literal contour test (kappa = 1), kept for ablations."""
    return replace(cfg, extent=replace(cfg.extent, sifting_mode="literal"))


def test_literal_contour_sifting_with_extent():
    """Literal mode: a point within gamma_s but outside the kappa-ellipse is not a candidate."""
    slam_on = run_scans(literal(quiet_config(use_extent=True)), 6)
    slam_off = run_scans(quiet_config(use_extent=False), 6)
    c = slam_on.x[3:5]
    X = slam_on.landmarks[0].extent.X
    lam, U = np.linalg.eigh(X)
    outside = c + U[:, 0] * math.sqrt(lam[0]) * 1.5  # 1.5 semi-minor axes out: q = 2.25 > 1
    assert np.linalg.norm(outside - c) < 3.0
    r_on = slam_on.update(scan(7, outside[None, :]))
    r_off = slam_off.update(scan(7, outside[None, :]))
    assert r_on.n_candidates == 0 and r_off.n_candidates == 1


@pytest.mark.parametrize("probability", [0.9, 0.99])
def test_measurement_contour_gate_is_the_predicted_spread(probability):
    """Measurement-contour mode (the default): a detection is a candidate exactly when
    (z - p)^T (gamma_z X + W(z) + P^n)^-1 (z - p) <= -2 log(1 - p), evaluated here by hand; the
    radius test of 3 m no longer decides (the gate reaches beyond it along the long axis)."""
    cfg = quiet_config(use_extent=True)
    cfg = replace(cfg, extent=replace(cfg.extent, gate_probability=probability))
    assert cfg.extent.sifting_mode == "measurement-contour"
    slam = run_scans(cfg, 6)
    g = -2.0 * math.log(1.0 - probability)
    X = slam.landmarks[0].extent.X
    p, Pn = slam.x[3:5].copy(), slam.P[3:5, 3:5].copy()
    lam, U = np.linalg.eigh(X)
    for axis in (0, 1):
        # the gate's radius along this axis of X, found by bisection on the hand-evaluated q
        def q(d):
            z = p + d * U[:, axis]
            s = xy_to_polar(slam.x[:3], z[None, :])
            W = converted_measurement_covs(slam.x[:3], slam.P[:3, :3], s, slam.R)[0]
            e = z - p
            return float(e @ np.linalg.solve(0.25 * X + W + Pn, e))

        lo, hi = 0.0, 20.0
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if q(mid) <= g else (lo, mid)
        for d, expected in ((0.97 * lo, 1), (1.03 * lo, 0)):
            probe = run_scans(cfg, 6)
            assert np.array_equal(probe.x, slam.x)
            rep = probe.update(scan(7, (p + d * U[:, axis])[None, :]))
            assert rep.n_candidates == expected, (axis, d, lo)


def test_extent_inflated_noise_admits_far_side_detection():
    """R_eff = R + H_p (gamma X) H_p^T lowers the log distance of a detection on the far end of the car."""
    from radarslam.slam import ekf

    # A car straight ahead along y, its long axis across the line of sight: the far end of the car
    # is ~9 deg off the centroid at 11 m, Mahalanobis^2 ~ 90 with R alone.
    slam = run_scans(quiet_config(use_extent=True), 8, car=(-2.0, 10.0, 4.0, 2.0))
    j = 0
    X = slam.landmarks[j].extent.X
    far = slam.x[3:5] + np.array([1.8, 0.0])  # along the car's long axis
    s = scan(9, far[None, :]).polar[0]
    h, Hs, idx = ekf.landmark_measurement(slam.x, j)
    e = ekf.innovation(s, h)
    D_plain = ekf.log_distance(e, ekf.innovation_cov(slam.P, Hs, idx, slam.R))
    gX, has = slam.extent.spreads([r.extent for r in slam.landmarks])
    assert has[j]
    R_eff = ekf.r_eff(slam.R, Hs, gX[j])
    D_eff = ekf.log_distance(e, ekf.innovation_cov(slam.P, Hs, idx, R_eff))
    assert np.allclose(R_eff, slam.R + 0.25 * Hs[:, 3:] @ X @ Hs[:, 3:].T)
    assert D_eff < slam.config.landmarks.beta < D_plain


def test_ablation_switches_select_each_half_of_with_extent():
    """contour_sifting / inflate_noise switch the two uses of a.7 independently."""
    from dataclasses import replace

    base = literal(quiet_config(use_extent=True))
    no_contour = replace(base, extent=replace(base.extent, contour_sifting=False))
    no_inflate = replace(base, extent=replace(base.extent, inflate_noise=False))
    s1, s2, s3 = (run_scans(c, 6) for c in (base, no_contour, no_inflate))
    c = s1.x[3:5]
    lam, U = np.linalg.eigh(s1.landmarks[0].extent.X)
    outside = (c + U[:, 0] * math.sqrt(lam[0]) * 1.5)[None, :]
    assert s1.update(scan(7, outside)).n_candidates == 0
    assert s2.update(scan(7, outside)).n_candidates == 1  # radius sifting instead
    assert s3.update(scan(7, outside)).n_candidates == 0
    # the spread that inflates R: none without inflate_noise, gamma_z X with it
    gX3, has3 = s3.extent.spreads([r.extent for r in s3.landmarks])
    gX2, has2 = s2.extent.spreads([r.extent for r in s2.landmarks])
    assert not has3.any() and np.array_equal(gX3, np.zeros_like(gX3))
    assert has2[0] and np.array_equal(gX2[0], 0.25 * s2.landmarks[0].extent.X)
    # the alpha test always uses the plain R: its log distance ignores the extent
    from radarslam.slam import ekf
    from associator_oracles import nearest_landmarks

    s = scan(8, outside).polar[0]
    js = nearest_landmarks(s1.x.tolist(), s, s1.config.landmarks.n_nearest_new)
    gX1, _ = s1.extent.spreads([r.extent for r in s1.landmarks])
    plain = ekf.score_landmarks(s1.x, s1.P, s, js, s1.R)[1]
    inflated = ekf.score_landmarks(s1.x, s1.P, s, js, s1.R, [gX1[j].tolist() for j in js])[1]
    assert s1.associator.min_log_distance(s1.state, s, s1.R) == plain != inflated
