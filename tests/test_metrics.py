"""Evaluation metrics: pose errors, avg. RMSE, NEES band, landmark matching, GT ellipses, per-step GWD."""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.extent import matrix_to_ellipse
from radarslam.metrics.extent import CONVENTIONS, ground_truth_extents, gwd_per_step
from radarslam.metrics.landmarks import landmark_metrics, match
from radarslam.metrics.pose import avg_rmse, chi2_band, pose_errors, pose_nees
from radarslam.simulation.world import carpark_vehicles, vehicle_centers
from radarslam.slam.filter import MapSnapshot


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
    for conv, f in CONVENTIONS.items():
        X = ground_truth_extents(vs, conv)
        for v, x in zip(vs, X):
            axes, o = matrix_to_ellipse(x)
            assert np.allclose(axes, [f * v.length, f * v.width])
            assert math.isclose(o, v.orientation, abs_tol=1e-12)
    assert math.isclose(CONVENTIONS["moment"], 1 / math.sqrt(3))


def _snapshot(positions, rma, efa):
    n = len(positions)
    return MapSnapshot(np.arange(n), np.array(positions, float).reshape(n, 2), np.tile(np.eye(2), (n, 1, 1)),
                       np.array(rma, float).reshape(n, 2, 2), np.array(efa, float).reshape(n, 2, 2), np.ones(n, int))


def test_gwd_per_step_perfect_estimate_zero_and_stale_excluded():
    vs = carpark_vehicles(profile_config().world)
    centers = vehicle_centers(vs)
    gt = ground_truth_extents(vs, "moment")
    present = np.ones((2, len(vs)), bool)
    present[1, 5] = False  # vehicle 5 departed before scan 2
    nan = np.full((2, 2), np.nan)
    maps = [_snapshot([centers[2], centers[5], centers[8]], [gt[2], gt[5], nan], [gt[2], gt[5] * 2, nan])] * 2
    rma, efa, count = gwd_per_step(maps, centers, present, gt, 5.0)
    assert rma[0] == 0.0 and count[0] == 2 and count[1] == 1  # no extent on the third; the stale one dropped
    # EFA of vehicle 5 is 2 X: coaxial closed form with axes scaled by sqrt 2.
    a = np.array([vs[5].length, vs[5].width]) / math.sqrt(3)
    assert math.isclose(efa[0], np.linalg.norm(a * (math.sqrt(2) - 1)) / 2, rel_tol=1e-9)
    assert efa[1] == 0.0
    rma_s, _, count_s = gwd_per_step(maps, centers, present, gt, 5.0, include_stale=True)
    assert count_s[1] == 2


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
