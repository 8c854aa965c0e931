"""Evaluation metrics: pose errors, avg. RMSE, NEES band, landmark matching, GT ellipses, per-step GWD,
and the trial bootstrap statistics."""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.core.errors import InputError
from radarslam.extent import ellipse_to_matrix, matrix_to_ellipse
from radarslam.metrics.extent import (CONVENTIONS, extent_metrics, ground_truth_extents, gwd_per_step,
                                      rectangle_centers)
from radarslam.metrics.gwd import gaussian_wasserstein_distance
from radarslam.metrics.landmarks import landmark_metrics, match
from radarslam.metrics.pose import avg_rmse, chi2_band, pose_errors, pose_nees
from radarslam.metrics.statistics import bootstrap_avg_rmse, bootstrap_counts, percentile_interval, rmse_over_defined
from radarslam.simulation.world import carpark_vehicles


def rectangles_of(vehicles) -> np.ndarray:
    return np.array([[v.x_left, v.y_bottom, v.size_x, v.size_y] for v in vehicles])


def test_pose_errors_wrap_heading():
    est = np.array([[1.0, 1.0, 0.05], [0.0, 0.0, 2 * math.pi - 0.05]])
    tru = np.array([[0.0, 1.0, 2 * math.pi - 0.05], [3.0, 4.0, 0.05]])
    pos, head = pose_errors(est, tru)
    assert np.allclose(pos, [1.0, 5.0]) and np.allclose(head, [0.1, -0.1])


def test_avg_rmse_definition():
    e = np.array([[1.0, 3.0], [1.0, 1.0]])  # runs x steps
    assert math.isclose(avg_rmse(e), (1.0 + math.sqrt(5.0)) / 2)
    assert math.isclose(avg_rmse(np.array([2.0, 4.0])), 3.0)


def test_nees_and_chi2_band():
    rng = np.random.default_rng(0)
    K = 4000
    covs = np.tile(np.diag([0.5, 2.0, 0.01]), (K, 1, 1))
    true = np.zeros((K, 3))
    est = rng.multivariate_normal(np.zeros(3), covs[0], size=K)
    nees = pose_nees(est, covs, true)
    assert abs(nees.mean() - 3.0) < 5 * math.sqrt(6.0 / K)  # chi2(3): mean 3, variance 6
    lo, hi = chi2_band(3, 100)
    assert lo < 3.0 < hi and math.isclose(lo, 2.54, abs_tol=0.02) and math.isclose(hi, 3.50, abs_tol=0.02)
    # Negative control: a covariance 4x too small makes the NEES 4x too large.
    assert pose_nees(est, covs / 4, true).mean() > hi * 3


def test_match_is_one_to_one_with_gate():
    centers = np.array([[0.0, 0.0], [10.0, 0.0]])
    pos = np.array([[0.5, 0.0], [0.2, 0.1], [10.0, 6.0], [9.0, 0.0]])
    a = match(pos, centers, 5.0)
    assert a.tolist() == [-1, 0, -1, 1]


def test_ground_truth_conventions():
    vs = carpark_vehicles(profile_config().world)
    rects = rectangles_of(vs)
    for conv, f in CONVENTIONS.items():
        X = ground_truth_extents(rects, conv)
        for v, x in zip(vs, X):
            axes, o = matrix_to_ellipse(x)
            assert np.allclose(axes, [f * v.length, f * v.width])
            assert math.isclose(o, v.orientation, abs_tol=1e-12)
            # the metric's own kernel is the estimator's eq. (8) to the last bit
            np.testing.assert_array_equal(x, ellipse_to_matrix([f * v.length, f * v.width], v.orientation))
    np.testing.assert_array_equal(rectangle_centers(rects), np.array([v.center for v in vs]))


def test_moment_ellipse_has_the_rectangle_covariance():
    """Decision 7: a uniform spread over the ``moment`` ellipse (covariance X / 4) has the covariance
    of a uniform spread over the rectangle, diag(sx^2, sy^2) / 12."""
    rects = np.array([[0.0, 0.0, 4.6, 1.9], [3.0, -1.0, 2.0, 5.0]])
    for r, X in zip(rects, ground_truth_extents(rects, "moment")):
        np.testing.assert_allclose(X / 4, np.diag([r[2] ** 2, r[3] ** 2]) / 12, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("rects, match", [(np.zeros((2, 3)), "rectangles: expected shape"),
                                          ([[0.0, 0.0, 0.0, 1.0]], "size_x, size_y > 0"),
                                          ([[0.0, np.nan, 1.0, 1.0]], "finite")])
def test_ground_truth_rejects_bad_rectangles(rects, match):
    with pytest.raises(InputError, match=match):
        ground_truth_extents(rects)
    with pytest.raises(InputError, match="convention"):
        ground_truth_extents(np.ones((1, 4)), "huge")


def _history(positions, rma, efa, K=2):
    n = len(positions)
    pos = np.array(positions, float).reshape(n, 2)
    return ([pos] * K, [np.array(rma, float).reshape(n, 2, 2)] * K, [np.array(efa, float).reshape(n, 2, 2)] * K)


def test_gwd_per_step_perfect_estimate_zero_and_stale_excluded():
    vs = carpark_vehicles(profile_config().world)
    rects = rectangles_of(vs)
    centers = rectangle_centers(rects)
    gt = ground_truth_extents(rects, "moment")
    present = np.ones((2, len(vs)), bool)
    present[1, 5] = False  # vehicle 5 departed before scan 2
    nan = np.full((2, 2), np.nan)
    pos, rma_h, efa_h = _history([centers[2], centers[5], centers[8]], [gt[2], gt[5], nan], [gt[2], gt[5] * 2, nan])
    rma, efa, count = gwd_per_step(pos, rma_h, efa_h, centers, present, gt, 5.0)
    assert rma[0] == 0.0 and count[0] == 2 and count[1] == 1  # no extent on the third; the stale one dropped
    # EFA of vehicle 5 is 2 X: coaxial closed form with axes scaled by sqrt 2.
    a = np.array([vs[5].length, vs[5].width]) / math.sqrt(3)
    assert math.isclose(efa[0], np.linalg.norm(a * (math.sqrt(2) - 1)) / 2, rel_tol=1e-9)
    assert efa[1] == 0.0
    rma_s, _, count_s = gwd_per_step(pos, rma_h, efa_h, centers, present, gt, 5.0, include_stale=True)
    assert count_s[1] == 2


def test_extent_metrics_equal_a_direct_gwd_computation():
    """Every convention: the mean over matched landmarks of the GWD to that convention's ellipse."""
    rects = np.array([[0.0, 0.0, 4.0, 2.0], [10.0, 0.0, 2.0, 5.0]])
    centers = rectangle_centers(rects)
    rng = np.random.default_rng(4)
    pos = centers + rng.normal(scale=0.3, size=(2, 2))
    rma = np.array([ellipse_to_matrix(rng.uniform(0.5, 2.5, 2), rng.uniform(0, math.pi)) for _ in range(2)])
    efa = np.array([ellipse_to_matrix(rng.uniform(0.5, 2.5, 2), rng.uniform(0, math.pi)) for _ in range(2)])
    present = np.ones((3, 2), bool)
    m = extent_metrics([pos[:1], pos, pos], [rma[:1], rma, rma], [efa[:1], efa, efa], rects, present, 5.0)
    np.testing.assert_array_equal(m["gwd_count"], [1, 2, 2])
    for conv in CONVENTIONS:
        gt = ground_truth_extents(rects, conv)
        for est, X in (("rma", rma), ("efa", efa)):
            d = [gaussian_wasserstein_distance(pos[i], X[i], centers[i], gt[i]) for i in range(2)]
            np.testing.assert_allclose(m[f"gwd_{est}_{conv}"], [d[0], np.mean(d), np.mean(d)], rtol=1e-12)
            assert m[f"gwd_{est}_final_{conv}"] == m[f"gwd_{est}_{conv}"][-1]


def test_gwd_per_step_rejects_inconsistent_input():
    rects = np.array([[0.0, 0.0, 4.0, 2.0]])
    c, gt = rectangle_centers(rects), ground_truth_extents(rects)
    pos, rma, efa = _history([c[0]], [gt[0]], [gt[0]], K=3)
    with pytest.raises(InputError, match="present: expected shape \\(3, 1\\)"):
        gwd_per_step(pos, rma, efa, c, np.ones((2, 1), bool), gt, 5.0)
    with pytest.raises(InputError, match="rma, efa"):
        gwd_per_step(pos, rma[:2], efa, c, np.ones((3, 1), bool), gt, 5.0)
    with pytest.raises(InputError, match="gt_extents"):
        gwd_per_step(pos, rma, efa, c, np.ones((3, 1), bool), np.zeros((2, 2, 2)), 5.0)


def test_landmark_metrics_on_a_hand_made_history():
    """Three vehicles; 0 mapped from scan 2, 1 never, 2 departs at scan 3 and its landmark is deleted at 5."""
    centers = np.array([[0.0, 10.0], [10.0, 0.0], [-10.0, 0.0]])
    poses = np.zeros((6, 3))
    present = np.ones((6, 3), bool)
    present[2:, 2] = False
    hist = [np.array([[-10.0, 0.5]]), np.array([[0.5, 10.0], [-10, 0.5]]), np.array([[0.5, 10.0], [-10, 0.5]]),
            np.array([[0.5, 10.0], [-10, 0.5], [30.0, 30.0]]), np.array([[0.5, 10.0]]), np.array([[0.3, 10.0]])]
    m = landmark_metrics(hist, poses, centers, present, 20.0, 5.0, 2)
    assert m["false_per_scan"].tolist() == [0, 0, 0, 1, 0, 0]
    assert m["stale_per_scan"].tolist() == [0, 0, 1, 1, 0, 0]
    assert m["missed_per_scan"].tolist() == [0, 1, 1, 1, 1, 1]  # vehicle 1 from its 2nd scan in range
    assert m["inclusion_delay"][0] == 1 and np.isnan(m["inclusion_delay"][1]) and m["inclusion_delay"][2] == 0
    assert m["removal_delay"][2] == 2  # back in range at scan 3 (index 2), first unmapped at scan 5
    assert math.isclose(m["final_errors"][0], 0.3) and np.isnan(m["final_errors"][1])


# --------------------------------------------------------------------------------------------- statistics


def test_bootstrap_replicates_equal_avg_rmse_of_resampled_trials():
    rng = np.random.default_rng(5)
    e = np.abs(rng.standard_normal((9, 6)))
    idx = np.random.default_rng(11).integers(0, 9, size=(50, 9))
    counts = bootstrap_counts(9, 50, np.random.default_rng(11))
    assert np.array_equal(counts, [np.bincount(i, minlength=9) for i in idx])
    assert np.all(counts.sum(axis=1) == 9)
    boot = bootstrap_avg_rmse(e, counts)
    np.testing.assert_allclose(boot, [avg_rmse(e[i]) for i in idx], rtol=1e-13)


def test_bootstrap_rejects_bad_input():
    with pytest.raises(InputError, match="n_boot"):
        bootstrap_counts(3, 0, np.random.default_rng(0))
    with pytest.raises(InputError, match="rng"):
        bootstrap_counts(3, 2, 7)
    with pytest.raises(InputError, match="counts"):
        bootstrap_avg_rmse(np.ones((4, 2)), np.ones((5, 3)))
    with pytest.raises(InputError, match="level"):
        percentile_interval(np.arange(10.0), 1.0)


def test_percentile_interval_of_a_known_sample():
    x = np.arange(1001.0)  # quantile q of 0..1000 is 1000 q exactly (linear interpolation)
    np.testing.assert_allclose(percentile_interval(x, 0.95), [25.0, 975.0], rtol=1e-13)
    np.testing.assert_allclose(percentile_interval(x[::-1], 0.5), [250.0, 750.0], rtol=1e-13)


def test_rmse_over_defined_by_hand():
    nan = np.nan
    g = np.array([[nan, 1.0, 3.0], [nan, nan, 4.0]])
    rmse, n = rmse_over_defined(g)
    np.testing.assert_array_equal(n, [0, 1, 2])
    assert math.isnan(rmse[0]) and rmse[1] == 1.0 and rmse[2] == pytest.approx(math.sqrt(12.5), rel=1e-15)


def test_shape_gwd_ignores_the_centroid_offset():
    """An estimate with the exact moment extent, 1 m off the car's centre: the moment GWD is the
    offset (1 m), the shape GWD 0; a 20% too long estimate on the exact centre scores the same in
    both (docs/method.md e, item 4)."""
    rect = np.array([[0.0, 0.0, 4.5, 1.8]])
    X = ground_truth_extents(rect, "moment")
    centre = np.array([[2.25, 0.9]])
    long_X = X.copy()
    long_X[0, 0, 0] *= 1.44
    positions = [centre + [1.0, 0.0], centre]
    rma = [X, long_X]
    m = extent_metrics(positions, rma, rma, rect, np.ones((2, 1), bool), 5.0)
    assert np.allclose(m["gwd_rma_moment"], [1.0, 0.2 * 4.5 / np.sqrt(3)])
    assert np.allclose(m["gwd_rma_shape"], [0.0, 0.2 * 4.5 / np.sqrt(3)])
    assert m["gwd_efa_final_shape"] == m["gwd_rma_final_shape"]


def test_compiled_matching_equals_scipy_assignment():
    """metrics._compiled.match_scans (every scan in one call) returns what match() (scipy's
    linear_sum_assignment) returns, scan by scan: random maps, crowded ones (several vehicles within
    the gate of a landmark and the reverse), more landmarks than vehicles and fewer, subsets of vehicles."""
    pytest.importorskip("numba")
    from radarslam.metrics.landmarks import match_flat

    rng = np.random.default_rng(0)
    scans = assigned = contested = 0
    for _ in range(60):
        V = int(rng.integers(0, 15))
        centers = rng.uniform(0, 30, (V, 2))
        sizes = rng.integers(0, 25, 40)
        pos = (centers[rng.integers(0, V, sizes.sum())] + rng.normal(0, 2.5, (sizes.sum(), 2)) if V and rng.random() < 0.5
               else rng.uniform(-5, 35, (sizes.sum(), 2)))
        off = np.concatenate([[0], np.cumsum(sizes)])
        vehicles = rng.random((40, V)) < 0.8
        got = match_flat(pos, off, centers, vehicles, 5.0)
        for k in range(40):
            idx = np.flatnonzero(vehicles[k])
            p = pos[off[k]:off[k + 1]]
            want = np.array([idx[x] if x >= 0 else -1 for x in match(p, centers[idx], 5.0)], dtype=int)
            assert np.array_equal(got[off[k]:off[k + 1]], want)
            scans += 1
            assigned += int((want >= 0).sum())
            if idx.size and p.shape[0]:
                contested += int(np.any(np.sum(np.linalg.norm(p[:, None] - centers[idx][None], axis=2) <= 5.0, axis=1) > 1))
    assert scans == 2400 and assigned > 5000 and contested > 300


def test_compiled_matching_is_not_greedy():
    """Negative control: on a scan where the nearest pairs are not the optimal assignment, the
    matching takes the optimum (total 2.2 m, against 1.0 + inf for nearest-first)."""
    pytest.importorskip("numba")
    from radarslam.metrics.landmarks import match_flat

    centers = np.array([[0.0, 0.0], [2.0, 0.0]])
    pos = np.array([[1.0, 0.0], [-1.2, 0.0]])     # landmark 0 is nearest to vehicle 0 (1.0) and 1 (1.0)
    got = match_flat(pos, np.array([0, 2]), centers, np.ones((1, 2), dtype=bool), 2.5)
    assert got.tolist() == [1, 0] == match(pos, centers, 2.5).tolist()
