"""Landmark management on hand-made scans (docs/method.md section c)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import profile_config, profile_overlay, to_dict
from radarslam.core.errors import InputError
from radarslam.core.types import Odometry, Scan
from radarslam.landmarks.clustering import dbscan_labels
from radarslam.landmarks.confirmation import push_bit, should_remove
from radarslam.models.radar import xy_to_polar
from radarslam.slam import ekf
from radarslam.slam.filter import EkfSlam

from helpers import POSE, blob, quiet_config, scan


def test_rule1_six_points_confirm_at_once():
    slam = EkfSlam(quiet_config())
    rep = slam.update(scan(1, blob([10.0, 3.0], 6)))
    assert len(slam.landmarks) == 1 and rep.confirmed == [0]
    # Initialised at the nearest detection (h.13), not the mean.
    nearest = blob([10.0, 3.0], 6)[np.argmin(np.linalg.norm(blob([10.0, 3.0], 6), axis=1))]
    assert np.allclose(slam.landmark_positions[0], nearest, atol=1e-9)


def test_five_points_only_start_a_tentative():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([10.0, 3.0], 5)))
    assert len(slam.landmarks) == 0 and slam.tentatives.count.shape[0] == 1


@pytest.mark.parametrize("hits,confirmed_at", [((1, 2, 3), 3), ((1, 3, 5), 5), ((1, 2, 5), 5), ((1, 4, 5), 5), ((2, 3, 7), None),
                                               ((1, 5, 6), None), ((1, 2), None)])
def test_rule2_three_hits_within_five_scans(hits, confirmed_at):
    slam = EkfSlam(quiet_config())
    first = None
    for k in range(1, 8):
        pts = [blob([12.0, -4.0], 3, seed=k)] if k in hits else []
        slam.update(scan(k, *pts))
        if slam.landmarks and first is None:
            first = k
    assert first == confirmed_at


def test_mn_deletes_landmark_missed_in_9_of_10_scans():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([8.0, 0.0], 6)))
    assert len(slam.landmarks) == 1
    for k in range(2, 10):
        rep = slam.update(scan(k))
        assert len(slam.landmarks) == 1, k  # not yet old enough (k - M + 1 < created)
    rep = slam.update(scan(10))
    assert len(slam.landmarks) == 0 and rep.removed == [0] and slam.x.shape == (3,)


def test_mn_keeps_landmark_associated_in_3_of_10_scans():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([8.0, 0.0], 6)))
    for k in range(2, 15):
        pts = [blob([8.0, 0.0], 2, seed=k)] if k % 3 == 0 else []  # >= 3 hits in every 10-scan window
        slam.update(scan(k, *pts))
    assert len(slam.landmarks) == 1


def test_mn_deletes_landmark_with_2_hits_in_window():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([8.0, 0.0], 6)))
    for k in range(2, 12):
        pts = [blob([8.0, 0.0], 2, seed=k)] if k in (4, 8) else []
        slam.update(scan(k, *pts))
        if k < 11:
            assert len(slam.landmarks) == 1, k  # the window 1..10 holds 3 hits (creation, 4, 8)
    assert len(slam.landmarks) == 0  # window 2..11 holds 2 hits


def test_mn_keeps_landmark_out_of_range():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([19.5, 0.0], 6)))
    _move_landmark(slam, 0, 25.0)  # now beyond R_max: misses do not count against it
    for k in range(2, 20):
        slam.update(scan(k))
    assert len(slam.landmarks) == 1


def _move_landmark(slam, j, px):
    x = slam.state.x.copy()
    x[slam.state.index(j)] = px
    slam.state.set(x, slam.state.P)


def _two_landmarks(cfg, p1, p2):
    slam = EkfSlam(cfg)
    for i, p in enumerate([p1, p2]):
        assert slam.state.add_landmark(xy_to_polar(POSE, np.array([p]))[0], slam.R, i + 1, slam.extent.new()) == i
    return slam


def test_merge_two_landmarks_closer_than_merge_distance():
    slam = _two_landmarks(quiet_config(), [10.0, 0.0], [10.0, 1.2])
    rep = slam.update(scan(3))
    assert [r.id for r in slam.landmarks] == [0] and rep.merged == [(0, 1)]
    assert np.allclose(slam.landmark_positions[0], [10.0, 0.0], atol=1e-9)  # the older one survives, no fusion


def test_no_merge_beyond_merge_distance():
    slam = _two_landmarks(quiet_config(), [10.0, 0.0], [10.0, 1.6])
    slam.update(scan(3))
    assert len(slam.landmarks) == 2


@pytest.mark.parametrize("p2,merged", [([10.5, 2.5], True), ([11.8, 1.8], False)])
def test_reference_profile_merge_rule(p2, merged):
    """Reference: closer than 3 m and |dx| <= 0.8 or |dy| <= 0.8."""
    slam = _two_landmarks(quiet_config("reference"), [10.0, 0.0], p2)
    slam.update(scan(3))
    assert len(slam.landmarks) == (1 if merged else 2)


def test_merge_transfers_initialised_extent_to_survivor():
    slam = _two_landmarks(quiet_config(), [10.0, 0.0], [10.0, 1.0])
    slam.landmarks[1].extent.X = np.diag([4.0, 1.0])
    slam.landmarks[1].extent.alpha = 50.0
    slam.update(scan(3))
    assert slam.landmarks[0].id == 0 and np.allclose(slam.landmarks[0].extent.X, np.diag([4.0, 1.0]))


def test_clutter_far_from_everything_never_becomes_a_landmark():
    """Isolated points (no neighbour within eps) are DBSCAN noise; scattered pairs never repeat."""
    slam = EkfSlam(quiet_config())
    r = np.random.default_rng(11)
    for k in range(1, 40):
        pts = r.uniform(-19, 19, (6, 2))
        pts = pts[np.linalg.norm(pts, axis=1) < 19.5]
        slam.update(scan(k, pts))
    assert len(slam.landmarks) == 0


def test_alpha_test_discards_cluster_close_to_landmark_in_log_distance():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([10.0, 0.0], 6)))
    # 4.5 m further in range on the same bearing: Mahalanobis^2 ~ (4.5/0.5)^2 = 81, log distance ~ 35 < 500.
    slam.update(scan(2, blob([14.5, 0.0], 6, spread=0.2)))
    assert len(slam.landmarks) == 1
    # The same cluster at 90 degrees is far in log distance and is confirmed.
    slam.update(scan(3, blob([0.0, 14.5], 6, spread=0.2)))
    assert len(slam.landmarks) == 2


def test_association_updates_state_and_sifting_radius():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([10.0, 0.0], 6)))
    P0 = slam.P.copy()
    rep = slam.update(scan(2, blob([10.0, 0.0], 3, seed=5), np.array([[10.0, 3.5]])))
    assert rep.n_candidates == 3 and rep.n_associated == 3
    assert np.trace(slam.P[3:, 3:]) < np.trace(P0[3:, 3:])


def test_beta_rejects_far_candidate():
    """A candidate within gamma_s but with log distance >= beta is discarded, not clustered."""
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([10.0, 0.0], 6, spread=0.05)))
    # 2.9 m lateral at 10 m range is ~16.6 deg, Mahalanobis^2 ~ 276 with R alone: D >> 20.
    rep = slam.update(scan(2, np.array([[10.0, 2.9]])))
    assert rep.n_candidates == 1 and rep.n_associated == 0


def test_empty_scan_is_a_noop_for_the_state():
    slam = EkfSlam(quiet_config())
    slam.update(scan(1, blob([10.0, 0.0], 6)))
    x, P = slam.x.copy(), slam.P.copy()
    rep = slam.update(Scan(0.16, 2, np.empty((0, 2))))
    assert rep.n_detections == 0 and np.array_equal(slam.x, x) and np.array_equal(slam.P, P)
    rep = slam.update(Scan(0.32, 3, np.zeros((0,))))
    assert rep.n_detections == 0


@pytest.mark.parametrize("polar,match", [
    (np.array([[5.0, np.nan]]), "scan.polar"),
    (np.array([[np.inf, 0.1]]), "scan.polar"),
    (np.ones((4, 3)), "scan.polar"),
    (np.array([[-1.0, 0.1]]), "scan.polar"),
])
def test_bad_scan_raises_value_error_naming_argument(polar, match):
    slam = EkfSlam(quiet_config())
    with pytest.raises(ValueError, match=match) as ei:
        slam.update(Scan(0.0, 1, polar))
    assert isinstance(ei.value, InputError)
    with pytest.raises(InputError, match=match):
        Scan.checked(0.0, 1, polar)


@pytest.mark.parametrize("control,dt,match", [
    (np.array([np.nan, 0.0]), 0.16, "odometry.control"),
    (np.array([1.0, 0.0, 3.0]), 0.16, "odometry.control"),
    (np.array([1.0, 0.0]), float("inf"), "odometry.dt"),
    (np.array([1.0, 0.0]), -0.1, "odometry.dt"),
])
def test_bad_odometry_raises(control, dt, match):
    slam = EkfSlam(quiet_config())
    with pytest.raises(InputError, match=match):
        slam.predict(Odometry(0.0, dt, control))


def test_non_finite_initial_pose_is_refused():
    from radarslam.config import validate
    from radarslam.core.errors import ConfigError

    cfg = profile_config()
    with pytest.raises(ConfigError, match="filter.initial_pose"):
        validate(replace(cfg, filter=replace(cfg.filter, initial_pose=[0.0, float("nan"), 0.0])))


def test_the_filter_equals_functions_called_by_hand():
    """EkfSlam.update on a scan = sift + ekf.update per associated detection, by hand."""
    cfg = quiet_config()
    slam = EkfSlam(cfg)
    slam.update(scan(1, blob([10.0, 2.0], 6)))
    slam.predict(Odometry(0.16, 0.16, np.array([4.0, 0.1])))
    x, P = slam.x.copy(), slam.P.copy()
    pts = blob([10.0, 2.0], 4, seed=9)
    s = scan(2, pts)
    rep = slam.update(s)
    for z in s.polar:
        h, Hs, idx = ekf.landmark_measurement(x, 0)
        e = ekf.innovation(z, h)
        assert ekf.log_distance(e, ekf.innovation_cov(P, Hs, idx, slam.R)) < cfg.landmarks.beta
        x, P = ekf.update(x, P, e, Hs, idx, slam.R)
    assert rep.n_associated == 4
    assert np.allclose(slam.x, x, atol=1e-12) and np.allclose(slam.P, P, atol=1e-12)


def test_mn_helpers():
    w = 0
    for b in [1, 0, 1, 1]:
        w = push_bit(w, b, 3)
    assert w == 0b011 and w.bit_count() == 2
    assert should_remove(10, 1, 0b11, (1 << 10) - 1, window=10, max_hits=2)
    assert not should_remove(9, 1, 0b11, (1 << 10) - 1, window=10, max_hits=2)
    assert not should_remove(10, 1, 0b111, (1 << 10) - 1, window=10, max_hits=2)


def test_the_merge_kernel_keeps_the_older():
    """The merge step's pair (landmarks.merging.closest_pair, compiled as the engine calls it): the
    closest pair within the distance, the later-created one dropped; none beyond it."""
    from radarslam.landmarks._compiled import compiled_closest_pair

    pos = np.array([[0.0, 0.0], [0.0, 1.0], [5.0, 5.0]])
    ids, created = np.array([0, 1, 2]), np.array([3, 1, 1])
    assert compiled_closest_pair(pos, created, ids, 1.5, np.inf) == (1, 0)
    assert compiled_closest_pair(pos, created, ids, 0.5, np.inf)[0] < 0


@pytest.mark.parametrize("min_samples", [1, 2, 3, 5])
def test_dbscan_labels_equal_sklearn_dbscan(min_samples):
    """Same labels as the public estimator, on random sets and on the 0.2 m clutter grid."""
    from sklearn.cluster import DBSCAN

    r = np.random.default_rng(4 + min_samples)
    for trial in range(300):
        pts = r.uniform(0, 15, (int(r.integers(0, 30)), 2))
        if trial % 3 == 0:
            pts = np.round(pts / 0.2) * 0.2 + 0.1  # grid points: distance ties are possible
        ours = dbscan_labels(pts, 2.5, min_samples)
        if pts.shape[0] == 0:
            assert ours.size == 0
            continue
        ref = DBSCAN(eps=2.5, min_samples=min_samples).fit(pts).labels_
        assert np.array_equal(ours, ref)


def test_profiles_differ_only_in_decision1_values():
    a, b = to_dict(profile_config("apsipa")), to_dict(profile_config("reference"))
    diff = {(sec, k) for sec in a if isinstance(a[sec], dict) for k in a[sec] if a[sec][k] != b[sec][k]}
    assert diff == {("landmarks", k) for k in profile_overlay("reference")["landmarks"]}
    assert b["landmarks"]["beta"] == 3.0 and a["landmarks"]["beta"] == 20.0
    assert math.isinf(a["landmarks"]["merge_axis_tol_m"]) and b["landmarks"]["merge_axis_tol_m"] == 0.8


def test_mn_ignores_misses_outside_the_field_of_view():
    """A 180-degree sensor does not count a landmark behind it as missed (M/N in-range test)."""
    cfg = quiet_config()
    cfg = replace(cfg, filter=replace(cfg.filter, field_of_view_deg=180.0))
    slam = EkfSlam(cfg)
    slam.update(scan(1, blob([8.0, 0.0], 6)))
    _move_landmark(slam, 0, -8.0)  # now behind the platform
    for k in range(2, 20):
        slam.update(scan(k))
    assert len(slam.landmarks) == 1
    _move_landmark(slam, 0, 8.0)  # in front again: misses count, deleted after M scans
    for k in range(20, 30):
        slam.update(scan(k))
    assert len(slam.landmarks) == 0


# ------------------------------------------------------------------ bad input never gives a non-finite state
@pytest.mark.parametrize("polar,key", [([["a", "b"]], "scan.polar"), ([[1.0, np.nan]], "scan.polar"),
                                       ([[np.inf, 0.0]], "scan.polar"), ([[-1.0, 0.0]], "scan.polar"),
                                       ([[1.0, 2.0, 3.0]], "scan.polar")])
def test_bad_detections_are_refused_naming_the_input(polar, key):
    from radarslam.core.errors import InputError
    from radarslam.core.types import Scan

    slam = EkfSlam(quiet_config())
    with pytest.raises(InputError, match=key):
        slam.update(Scan(0.0, 1, polar))
    assert np.all(np.isfinite(slam.x)) and slam.x.shape == (3,)


def test_scan_times_must_not_go_backwards():
    from radarslam.core.errors import InputError
    from radarslam.core.types import Scan

    slam = EkfSlam(quiet_config())
    slam.update(Scan(1.0, 1, np.empty((0, 2))))
    slam.update(Scan(1.0, 2, np.empty((0, 2))))            # equal times are fine
    with pytest.raises(InputError, match=r"scan\.t: expected scan times that do not go backwards, got 0\.5 after 1\.0"):
        slam.update(Scan(0.5, 3, np.empty((0, 2))))
    with pytest.raises(InputError, match=r"scan\.t: expected a finite number"):
        slam.update(Scan(float("nan"), 4, np.empty((0, 2))))


@pytest.mark.parametrize("control,dt,key", [([np.inf, 0.0], 0.16, "odometry.control"),
                                            (["x", 0.0], 0.16, "odometry.control"),
                                            ([1.0, 0.0], 0.0, "odometry.dt"), ([1.0, 0.0], "0.1x", "odometry.dt"),
                                            ([1e308, 0.0], 1e10, "odometry at t=")])
def test_bad_odometry_is_refused_and_the_state_stays_finite(control, dt, key):
    """Including a reading that is numerically valid but overflows the state (negative control of
    the finite check: the same filter accepts a normal reading)."""
    from radarslam.core.errors import InputError
    from radarslam.core.types import Odometry

    slam = EkfSlam(quiet_config())
    x0, P0 = slam.x.copy(), slam.P.copy()
    with pytest.raises(InputError, match=key):
        slam.predict(Odometry(0.0, dt, control))
    assert np.array_equal(slam.x, x0) and np.array_equal(slam.P, P0)
    slam.predict(Odometry(0.16, 0.16, np.array([4.0, 0.1])))
    assert np.all(np.isfinite(slam.x)) and not np.array_equal(slam.x, x0)


def test_large_scans_never_build_an_m_by_m_array():
    """5,000 detections: DBSCAN labels equal scikit-learn's and the peak memory of clustering and
    sifting stays far below one m x m float array (200 MB)."""
    import tracemalloc

    from sklearn.cluster import DBSCAN

    from radarslam.landmarks.sifting import sift

    rng = np.random.default_rng(0)
    pts = np.concatenate([rng.uniform(-60, 60, (4000, 2)),
                          rng.normal(0, 0.5, (1000, 2)) + rng.uniform(-50, 50, (20, 2)).repeat(50, axis=0)])
    tracemalloc.start()
    labels = dbscan_labels(pts, 0.8, 3)
    inside = sift(pts, rng.uniform(-60, 60, (300, 2)), 3.0)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert np.array_equal(labels, DBSCAN(eps=0.8, min_samples=3).fit(pts).labels_)
    assert inside.shape == (5000,) and 0 < inside.sum() < 5000
    assert peak < 40e6, peak


def test_sifting_kernels_written_once_match_an_oracle_and_their_compiled_form():
    """Step 3 (c.3, a.7.1) is one kernel per decision: the radius-or-extent decision
    (:func:`candidates`) and the literal contour (:func:`literal_inside`). Their Python and compiled
    forms agree with a brute-force oracle on random scans, including landmarks with and without an
    extent; a detection is a candidate exactly when some landmark admits it."""
    from radarslam.extent._compiled import literal_inside as literal_compiled
    from radarslam.extent.sifting import literal_inside
    from radarslam.landmarks._compiled import compiled_candidates
    from radarslam.landmarks.sifting import candidates, sift

    rng = np.random.default_rng(3)
    for _ in range(20):
        m, n = rng.integers(1, 40), rng.integers(1, 15)
        pts, cen = rng.uniform(-10, 10, (m, 2)), rng.uniform(-10, 10, (n, 2))
        A = rng.normal(size=(n, 2, 2))
        X = A @ A.transpose(0, 2, 1) + 0.5 * np.eye(2)
        has = rng.random(n) < 0.5
        d = pts[:, None, :] - cen[None, :, :]
        q = np.einsum("mni,nij,mnj->mn", d, np.linalg.inv(X), d)
        lit = literal_inside(pts, cen, X, has, 4.0)
        assert np.array_equal(lit, (q <= 4.0) & has[None, :])
        assert np.array_equal(literal_compiled(pts, cen, X, has, 4.0), lit)
        near = np.einsum("mni,mni->mn", d, d) < 9.0
        oracle = np.where(has[None, :], lit, near).any(axis=1)
        assert np.array_equal(candidates(pts, cen, 9.0, lit, has), oracle)
        assert np.array_equal(compiled_candidates(pts, cen, 9.0, lit, has), oracle)
        assert np.array_equal(sift(pts, cen, 3.0), near.any(axis=1))
    # negative control: with the extent test switched off for every landmark only the radius counts
    assert not candidates(np.array([[100.0, 0.0]]), np.zeros((1, 2)), 9.0, np.ones((1, 1), bool),
                          np.zeros(1, bool))[0]


def test_associations_grouped_by_landmark_once():
    """Step 4's grouping (:func:`by_landmark`), Python and compiled: each landmark's detections in
    ascending candidate order, the unassociated (-1) left out, equal to a list-of-lists oracle."""
    from radarslam.landmarks._compiled import compiled_by_landmark
    from radarslam.landmarks.grouping import by_landmark

    rng = np.random.default_rng(5)
    for n in (0, 1, 7):
        cidx = np.sort(rng.choice(100, size=30, replace=False)).astype(np.int64)
        out = rng.integers(-1, n, size=30).astype(np.int64) if n else np.full(30, -1, dtype=np.int64)
        oracle = [[int(i) for i, j in zip(cidx, out) if j == k] for k in range(n)]
        for kernel in (by_landmark, compiled_by_landmark):
            aoff, arow = kernel(out, cidx, n)
            assert [arow[aoff[k]:aoff[k + 1]].tolist() for k in range(n)] == oracle
            assert arow.size == int(np.sum(out >= 0)) and aoff.shape == (n + 1,)


def test_landmark_records_written_once_match_a_list_oracle():
    """The records' birth, growth and removal (:mod:`radarslam.landmarks.records`), Python and
    compiled: 40 births from a capacity of 4 (growth by doubling keeps every row), then three
    rounds of removal by random masks, each equal to a list-of-rows oracle; the returned rows
    before the move index the oracle's survivors."""
    from radarslam.landmarks._compiled import compiled_add_record, compiled_compact_records
    from radarslam.landmarks.records import add_record, compact_records, new_records

    rng = np.random.default_rng(11)
    for add, compact in ((add_record, compact_records), (compiled_add_record, compiled_compact_records)):
        rec, rows = new_records(4), []
        for n in range(40):
            fx, fy = rng.normal(size=2)
            rec = add(rec, n, 100 + n, 3 * n, fx, fy)
            rows.append((100 + n, 3 * n, 1, 1, fx, fy))
        assert rec.ids.shape[0] == 64                          # 4 -> 8 -> 16 -> 32 -> 64
        n = 40
        for _ in range(3):
            rec.mbits[:n] = rng.integers(0, 1 << 10, n)        # windows move with their rows
            rows = [r[:2] + (int(m),) + r[3:] for r, m in zip(rows, rec.mbits[:n])]
            keep = rng.random(n) < 0.7
            old = compact(rec, keep)
            assert old.tolist() == np.flatnonzero(keep).tolist()
            rows = [r for r, k in zip(rows, keep) if k]
            n = len(rows)
            got = list(zip(rec.ids[:n].tolist(), rec.created[:n].tolist(), rec.mbits[:n].tolist(),
                           rec.rbits[:n].tolist(), rec.first[:n, 0].tolist(), rec.first[:n, 1].tolist()))
            assert got == rows
    # negative control: a mask that keeps nothing leaves no rows
    assert compact_records(new_records(3), np.zeros(3, dtype=bool)).size == 0


def test_growth_by_doubling_is_one_kernel_python_and_compiled():
    """core.arrays.grown, the one growth rule of the records, the engine's arrays and the extent
    buffers: the same array when it has room; else max(n, 2 * rows) rows of its dtype, its rows
    first and zeros after, for 1-D int and 3-D float arrays, Python and compiled alike."""
    from radarslam.core.arrays import grown
    from radarslam.landmarks._compiled import compiled_grown

    ints = np.arange(5, dtype=np.int64)
    cubes = np.arange(3 * 2 * 2, dtype=float).reshape(3, 2, 2)
    for kernel in (grown, compiled_grown):
        assert kernel(ints, 5) is ints and kernel(cubes, 2) is cubes      # room enough: no copy
        g = kernel(ints, 6)
        assert g.dtype == np.int64 and g.shape == (10,)                    # doubled
        assert g[:5].tolist() == ints.tolist() and g[5:].tolist() == [0] * 5
        g = kernel(cubes, 13)
        assert g.shape == (13, 2, 2) and g.dtype == float                  # n beyond twice the rows
        assert np.array_equal(g[:3], cubes) and not g[3:].any()
        assert kernel(np.empty((0, 2)), 1).shape == (1, 2)                 # from nothing


def test_slam_state_records_follow_removals_and_merges():
    """The filter's state holds its landmarks' bookkeeping in the records' arrays: ids,
    creation scans and first estimates stay with their rows of ``x`` through a removal, and the
    extents list moves with them."""
    from radarslam.slam.state import SlamState

    st = SlamState.initial([0.0, 0.0, 0.0], [0.1, 0.1, 0.01])
    for j in range(20):
        st.add_landmark(np.array([5.0 + j, 0.1 * j]), np.diag([0.01, 1e-4]), created=j, extent=f"e{j}")
    firsts = {int(i): st.records.first[j].copy() for j, i in enumerate(st.ids())}
    xs = {int(i): st.position(j) for j, i in enumerate(st.ids())}
    removed = st.remove([0, 7, 19])
    assert [lid for lid, _ in removed] == [0, 7, 19] and [e for _, e in removed] == ["e0", "e7", "e19"]
    assert st.n_landmarks == 17 and st.x.shape == (3 + 34,)
    for j, lm in enumerate(st.landmarks):
        assert lm.extent == f"e{lm.id}" and lm.created == lm.id
        np.testing.assert_array_equal(lm.first, firsts[lm.id])
        np.testing.assert_array_equal(st.position(j), xs[lm.id])
    assert st.rows_by_id()[8] == 6


def test_sensor_view_kernel_matches_geometry_and_its_compiled_form():
    """Step 5's "in range" (:func:`in_view`, c.5), Python and compiled: a brute-force oracle on
    random landmarks, all around (360 deg) and for a 90 deg field of view centred on the heading;
    a landmark straight behind is out of a forward view but in an all-round one."""
    from radarslam.landmarks._compiled import compiled_in_view
    from radarslam.landmarks.confirmation import in_view

    rng = np.random.default_rng(4)
    pose = np.array([1.0, -2.0, 0.7])
    L = pose[:2] + rng.uniform(-40, 40, (60, 2))
    x = np.r_[pose, L.ravel()]
    d = L - pose[:2]
    rng_ok = np.hypot(d[:, 0], d[:, 1]) <= 30.0
    bearing = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - pose[2])))
    for kernel in (in_view, compiled_in_view):
        np.testing.assert_array_equal(kernel(x, 3, 60, 30.0, math.pi), rng_ok)
        np.testing.assert_array_equal(kernel(x, 3, 60, 30.0, math.pi / 4), rng_ok & (np.abs(bearing) <= math.pi / 4))
        behind = np.r_[pose, pose[:2] - 5.0 * np.array([math.cos(0.7), math.sin(0.7)])]
        assert kernel(behind, 3, 1, 30.0, math.pi).tolist() == [True]
        assert kernel(behind, 3, 1, 30.0, math.pi / 4).tolist() == [False]
