"""The numba backend against the Python reference on whole car-park runs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from radarslam.config import profile_config
from radarslam.simulation.trial import run_trial

from conftest import require


def test_numba_backend_agrees_with_python_backend():
    """Same associations on every scan; poses and maps agree to rounding (not bit for bit)."""
    require("numba")
    base = profile_config()
    base = replace(base, filter=replace(base.filter, backend="python"))
    fast = replace(base, filter=replace(base.filter, backend="numba"))
    for seed in (1, 2, 3):
        for ext in (False, True):
            a, b = run_trial(base, seed, use_extent=ext), run_trial(fast, seed, use_extent=ext)
            assert np.array_equal(a.record.n_associated, b.record.n_associated)
            assert np.array_equal(a.record.n_landmarks, b.record.n_landmarks)
            assert np.allclose(a.record.poses, b.record.poses, atol=1e-9, rtol=0)
            assert np.allclose(a.record.pose_covs, b.record.pose_covs, atol=1e-12, rtol=1e-9)
            assert np.allclose(a.record.maps[-1].positions, b.record.maps[-1].positions, atol=1e-9)
            for key in ("rma", "efa"):  # the compiled extent step (one call per scan) against the reference
                x, y = getattr(a.record.maps[-1], key), getattr(b.record.maps[-1], key)
                assert np.array_equal(np.isnan(x), np.isnan(y))
                assert np.allclose(x[~np.isnan(x)], y[~np.isnan(y)], atol=1e-9)


# ------------------------------------------------------------------ the compiled per-scan steps, one by one
def test_compiled_dbscan_of_large_scans_equals_sklearn_dbscan():
    """Above PAIRWISE_MAX points the neighbourhoods come from a grid of cells: the same labels as
    scikit-learn's DBSCAN on clustered clutter, on a 0.5 m lattice whose neighbours sit exactly at
    eps, on a wall of points along one axis, on a scan wider than MAX_CELLS cells (larger cells) and
    on duplicates; and the grid's neighbourhoods equal every pair's on the same points, at eps 0 too."""
    require("numba")
    from sklearn.cluster import DBSCAN

    from radarslam.landmarks._compiled import MAX_CELLS, PAIRWISE_MAX, _pairwise, dbscan_labels, neighbourhoods

    r = np.random.default_rng(5)
    m = 4 * PAIRWISE_MAX
    blobs = r.uniform(-40, 40, (6, 2))[r.integers(0, 6, m)] + r.normal(0, 1.5, (m, 2))
    lattice = np.column_stack([np.repeat(np.arange(32.0), 32), np.tile(np.arange(32.0), 32)]) * 0.5
    wall = np.column_stack([np.full(m, 3.0) + r.normal(0, 0.05, m), np.linspace(0, 200, m)])
    wide = np.concatenate([blobs, [[1e7, 0.0], [1e7 + 0.3, 0.0]]])
    dup = np.repeat(r.uniform(0, 10, (m // 4, 2)), 4, axis=0)
    cases = [(blobs, 1.0, 4), (lattice, 0.5, 5), (wall, 0.8, 3), (wide, 1.0, 2), (dup, 1e-12, 3)]
    assert np.ptp(wide, axis=0).max() / 1.0 > MAX_CELLS
    for pts, eps, min_samples in cases:
        assert pts.shape[0] > PAIRWISE_MAX
        want = DBSCAN(eps=eps, min_samples=min_samples).fit(pts).labels_
        assert np.array_equal(dbscan_labels(pts, eps, min_samples), want)
        assert want.max() >= 0                              # clusters, not all noise
        for e in (eps, 0.0):                                # eps 0 (scikit-learn refuses it): duplicates only
            grid, pair = neighbourhoods(pts, e), _pairwise(pts, e)
            assert np.array_equal(grid[0], pair[0]) and np.array_equal(grid[1], pair[1])


def test_compiled_dbscan_equals_sklearn_dbscan():
    """Labels and cluster centres of the compiled clustering equal scikit-learn's DBSCAN and the
    reference's centres (smallest range, first on ties), on random scans and on a 0.2 m grid
    (distance ties)."""
    require("numba")
    from sklearn.cluster import DBSCAN

    from radarslam.landmarks._compiled import dbscan_centres, dbscan_labels

    r = np.random.default_rng(11)
    n_clusters = 0
    for trial in range(400):
        min_samples = int(r.integers(1, 6))
        pts = r.uniform(0, 15, (int(r.integers(0, 40)), 2))
        if trial % 3 == 0:
            pts = np.round(pts / 0.2) * 0.2 + 0.1
        ours = dbscan_labels(pts, 2.5, min_samples)
        if pts.shape[0] == 0:
            assert ours.size == 0
            continue
        assert np.array_equal(ours, DBSCAN(eps=2.5, min_samples=min_samples).fit(pts).labels_)
        ranges = np.round(r.uniform(1, 5, pts.shape[0]), 1)  # ties in range are common
        centres = dbscan_centres(ranges, ours)
        for lab, c in enumerate(centres.tolist()):
            rows = np.flatnonzero(ours == lab)
            assert c == rows[np.argmin(ranges[rows])]
        n_clusters += centres.size
    assert n_clusters > 300  # the comparison saw clusters, not only noise


def test_compiled_measurement_contour_equals_reference():
    """The fused compiled gate test gives the reference's (m, N) matrix on random scans, poses and
    maps, with about half the pairs inside so that both outcomes are exercised."""
    require("numba")
    from radarslam.extent._compiled import measurement_contour as compiled
    from radarslam.extent.estimator import _reference_contour

    r = np.random.default_rng(12)
    inside = total = 0
    for _ in range(200):
        m, n = int(r.integers(1, 30)), int(r.integers(1, 12))
        pose = np.array([r.normal(), r.normal(), r.uniform(-np.pi, np.pi)])
        A = r.normal(size=(3, 3)) * 0.1
        pose_cov = A @ A.T + 1e-4 * np.eye(3)
        polar = np.column_stack([r.uniform(1, 20, m), r.uniform(-np.pi, np.pi, m)])
        a = pose[2] + polar[:, 1]
        pts = pose[:2] + polar[:, :1] * np.column_stack([np.cos(a), np.sin(a)])
        cents = pts[r.integers(0, m, n)] + r.normal(0, 2.0, (n, 2))
        B = r.normal(size=(n, 2, 2))
        spreads = B @ B.transpose(0, 2, 1) + 0.1 * np.eye(2)
        C = r.normal(size=(n, 2, 2)) * 0.2
        covs = C @ C.transpose(0, 2, 1)
        R = np.diag([0.01, 1e-4])
        ref = _reference_contour(pts, polar, pose, pose_cov, R, cents, spreads, covs, 9.21)
        assert np.array_equal(compiled(pts, polar, pose[2], pose_cov, R, cents, spreads, covs, 9.21), ref)
        inside, total = inside + ref.sum(), total + ref.size
    assert 0.05 < inside / total < 0.95


def test_batched_extent_step_equals_per_landmark_steps():
    """The extent step over every landmark of a scan at once (extent.rows, compiled under numba)
    gives each landmark's step taken alone (Python): the same RMA extent and alpha to 1e-12 and
    the same EFA, through buffering, initialisation, landmarks without detections and scans with
    dt = 0."""
    require("numba")
    from radarslam.extent import _compiled, rows
    from radarslam.extent.estimator import RmaEfaEstimator

    cfg = profile_config()
    ref, fast = (RmaEfaEstimator(cfg.extent, cfg.extent.R(cfg.filter.R), b) for b in ("python", "numba"))
    assert fast._kernels.rma_efa_rows is _compiled.rma_efa_rows and ref._kernels.rma_efa_rows is rows.rma_efa_rows
    r = np.random.default_rng(13)
    L = 9
    states = {e: [e.new() for _ in range(L)] for e in (ref, fast)}
    centres = r.uniform(-15, 15, (L, 2))
    updated = 0
    for k in range(1, 41):
        pose = np.array([r.normal(), r.normal(), r.uniform(0, 2 * np.pi)])
        pose_cov = np.diag([0.01, 0.01, 1e-4])
        counts = r.integers(0, 7, L) * (r.random(L) < 0.8)
        pts = np.concatenate([centres[j] + r.normal(0, [1.5, 0.7], (c, 2)) for j, c in enumerate(counts)])
        d = pts - pose[:2]
        polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
        ends = np.cumsum(counts)
        assoc = [list(range(e - c, e)) for e, c in zip(ends.tolist(), counts.tolist())]
        cents = centres + r.normal(0, 0.05, (L, 2))
        covs = np.tile(np.diag([0.02, 0.03]), (L, 1, 1))
        dt = 0.0 if k % 7 == 0 else 0.1
        for j, st in enumerate(states[ref]):          # landmark by landmark
            a = assoc[j]
            ref.step(st, polar[a], pts[a], cents[j], covs[j], pose, pose_cov, dt, k)
        fast.step_all(states[fast], polar, pts, assoc, cents, covs, pose, pose_cov, dt, k)
        for a, b in zip(states[ref], states[fast]):
            assert a.initialized == b.initialized
            if a.initialized:
                updated += 1
                assert np.allclose(a.X, b.X, rtol=1e-12, atol=1e-14) and abs(a.alpha - b.alpha) < 1e-9
                assert np.allclose(a.X_efa, b.X_efa, rtol=1e-12, atol=1e-14)
    assert updated > 200


def test_merge_candidates_dense_path_equals_kd_tree_path(monkeypatch):
    """The all-pairs search of small maps lists the kd-tree's pairs in the same order (integer
    positions give equal distances, so the tie order is checked too)."""
    from radarslam.landmarks import merging

    r = np.random.default_rng(14)
    for t in range(300):
        pos = r.uniform(0, 20, (int(r.integers(0, 60)), 2))
        if t % 2:
            pos = np.round(pos)
        tol = 1.0 if t % 3 else np.inf
        dense = merging.merge_candidates(pos, 2.0, tol)
        monkeypatch.setattr(merging, "DENSE_MAX", -1)
        tree = merging.merge_candidates(pos, 2.0, tol)
        monkeypatch.undo()
        assert dense == tree


def test_compiled_joseph_update_equals_numpy_form():
    """The loop form of the Joseph update (and of its n x n pass) against the numpy kernel of
    slam/ekf.py on random SPD states, n from 5 to 203: the same x, P and NIS to rounding, P exactly
    symmetric."""
    require("numba")
    from radarslam.slam import ekf
    from radarslam.slam._numba import _K

    compiled = _K["joseph_update_inplace"]
    assert compiled.py_func.__name__ == "joseph_update_loops"
    r = np.random.default_rng(15)
    for N in (1, 2, 7, 20, 100):
        n = 3 + 2 * N
        for _ in range(10):
            x = np.concatenate([[r.normal(), r.normal(), r.uniform(0, 2 * np.pi)], r.uniform(-20, 20, 2 * N)])
            A = r.normal(size=(n, n)) * 0.1
            P = A @ A.T + 0.01 * np.eye(n)
            Hs, idx = ekf.sparse_jacobian(x, int(r.integers(0, N)))
            R = np.diag([0.01, 1e-4])
            e = r.normal(0, [0.3, 0.02])
            x1, P1, x2, P2 = x.copy(), P.copy(), x.copy(), P.copy()
            q1 = ekf.joseph_update_inplace(x1, P1, e, Hs, idx, R)
            q2 = compiled(x2, P2, e, Hs, idx, R)
            assert abs(q1 - q2) <= 1e-12 * max(1.0, abs(q1))
            assert np.allclose(x1, x2, rtol=0, atol=1e-13) and np.allclose(P1, P2, rtol=0, atol=1e-13)
            assert np.array_equal(P2, P2.T) and not np.array_equal(P2, P)


def test_nearest_landmark_selection_equals_stable_argsort():
    """The compiled associator's top-k selection is the head of a stable argsort, ties included."""
    require("numba")
    from radarslam.slam._numba import _smallest

    r = np.random.default_rng(16)
    for t in range(3000):
        N = int(r.integers(1, 60))
        k = min(int(r.integers(1, 8)), N)
        d = r.integers(0, 10, N).astype(float) if t % 2 else r.random(N)
        assert np.array_equal(_smallest(d, N, k), np.argsort(d, kind="mergesort")[:k])
