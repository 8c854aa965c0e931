"""Rigid 2-D alignment against fixes: analytic oracle, outlier rejection, negative control."""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.metrics.alignment import (
    error_against_fixes,
    rigid_align_2d,
    robust_rigid_align_2d,
)


def _rot(a):
    return np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])


def test_rigid_align_recovers_known_transform():
    r = np.random.default_rng(0)
    est = r.uniform(-50, 50, (200, 2))
    R0, t0 = _rot(0.7), np.array([12.0, -3.0])
    R, t = rigid_align_2d(est, est @ R0.T + t0)
    assert np.allclose(R, R0, atol=1e-12) and np.allclose(t, t0, atol=1e-10)


def test_no_reflection_for_mirrored_data():
    r = np.random.default_rng(1)
    est = r.uniform(-10, 10, (50, 2))
    R, _ = rigid_align_2d(est, est * [1, -1])
    assert math.isclose(np.linalg.det(R), 1.0)


def test_robust_alignment_rejects_gps_jumps():
    r = np.random.default_rng(2)
    est = np.cumsum(r.normal(0, 1, (400, 2)), axis=0)
    R0, t0 = _rot(-1.1), np.array([100.0, 40.0])
    ref = est @ R0.T + t0 + r.normal(0, 0.5, (400, 2))
    ref[100:130] += 140.0  # a burst of 140 m jumps, as in the Victoria Park GPS
    R, t, inl = robust_rigid_align_2d(est, ref)
    assert np.allclose(R, R0, atol=1e-2) and not inl[100:130].any() and inl.sum() >= 360
    Rn, tn = rigid_align_2d(est, ref)  # negative control: the plain fit is pulled away
    assert np.linalg.norm(tn - t0) > 5.0


def test_error_against_fixes_interpolates_track():
    t = np.linspace(0, 100, 101)
    pos = np.column_stack([t, 0.5 * t])
    ft = np.array([0.5, 10.25, 50.0, 99.9, 120.0])  # the last is outside the span
    fxy = np.column_stack([ft, 0.5 * ft]) @ _rot(0.3).T + [5.0, 5.0]
    res = error_against_fixes(t, pos, ft, fxy)
    assert res["n_fixes"] == 4 and res["rmse_m"] < 1e-9 and math.isclose(res["rotation_deg"], math.degrees(0.3))


def test_gps_speed_outliers_flag_jumps_only():
    t = np.arange(0.0, 100.0, 0.5)
    xy = np.column_stack([3.0 * t, np.zeros_like(t)])  # 3 m/s
    xy[40:44] += [0.0, 140.0]  # a 140 m jump for 2 s
    from radarslam.metrics.alignment import gps_speed_outliers

    bad = gps_speed_outliers(t, xy, 8.0)
    assert bad[40:44].all() and bad.sum() == 4


def test_error_against_fixes_does_not_hide_drift():
    """The default evaluation keeps every consistent fix: drift in the estimate shows in the RMSE."""
    t = np.linspace(0, 100, 201)
    truth = np.column_stack([3 * t, np.sin(t / 10) * 20])
    est = truth.copy()
    est[150:] += [15.0, 0.0]  # the estimate drifts 15 m at the end
    res = error_against_fixes(t, est, t, truth, max_speed=8.0)
    assert res["n_fixes"] == 201 and res["rmse_m"] > 5.0
    flattering = error_against_fixes(t, est, t, truth, robust=True)
    assert flattering["rmse_m"] < res["rmse_m"]  # what residual-based rejection would report


def test_error_at_fixes_is_the_published_protocol_by_hand():
    """Estimates at 0, 0.1, 0.2, 0.3 s; fixes at 0.01, 0.19, 0.26 s: with 25 ms, estimate 0 matches
    the fix at 0.01 (10 ms) and estimate 0.2 the fix at 0.19; 0.1 and 0.3 have no fix within 25 ms
    (0.3 is 40 ms from 0.26). No alignment: the errors are the plain distances."""
    import math

    from radarslam.metrics.alignment import error_at_fixes

    times = np.array([0.0, 0.1, 0.2, 0.3])
    pos = np.array([[0.0, 0.0], [5.0, 5.0], [3.0, 4.0], [9.0, 9.0]])
    fix_t = np.array([0.01, 0.19, 0.26])
    fix_xy = np.array([[1.0, 0.0], [0.0, 0.0], [9.0, 9.0]])
    r = error_at_fixes(times, pos, fix_t, fix_xy, tolerance=0.025)
    assert r["n_matched"] == 2 and r["index"].tolist() == [0, 2] and r["fix"].tolist() == [0, 1]
    np.testing.assert_allclose(r["errors_m"], [1.0, 5.0])
    assert r["rmse_m"] == pytest.approx(math.sqrt((1.0 + 25.0) / 2)) and r["max_m"] == 5.0
    # a rigid shift of the estimate is NOT aligned away (the aligned evaluation would give 0)
    r2 = error_at_fixes(times, pos + [10.0, 0.0], fix_t, fix_xy)
    assert r2["rmse_m"] > 9.0
    wide = error_at_fixes(times, pos, fix_t, fix_xy, tolerance=0.05)
    assert wide["n_matched"] == 3 and wide["fix"].tolist() == [0, 1, 2]
