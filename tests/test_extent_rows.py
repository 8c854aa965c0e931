"""The extent step over array-held states (radarslam.extent.rows), the one form the fused engine
and the built-in estimators' own methods share (issue "One engine", item 1): against the public
equations (seed eqs. 5, 8-20, the EFA of d.3), Python against compiled to the bit, and the
landmarks it must leave alone."""

from __future__ import annotations

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.extent import rows
from radarslam.extent.ellipse_fit import fit_ellipse
from radarslam.extent.measurement import converted_measurement_covs, select_scan_W
from radarslam.extent.random_matrix import rm_predict, rm_update

from conftest import require

EC = profile_config().extent
R = np.diag([0.1 ** 2, np.radians(1.0) ** 2])


def _kernels(backend):
    if backend == "numba":
        require("numba")
        from radarslam.extent import _compiled

        return _compiled
    return rows


def _record(L, B=0):
    return rows.empty_rows(L, B)


def _setting(backend, seed, L):
    """The kernels, a generator, ``L`` landmark centres and a fresh record of ``L`` rows."""
    rng = np.random.default_rng(seed)
    return _kernels(backend), rng, rng.uniform(-20, 20, (L, 2)), _record(L)


def _scan(rng, L, pose, counts, centres):
    """Detections around ``centres`` (counts per landmark), in the world and the sensor frame, and
    their association rows (CSR)."""
    xy = np.concatenate([centres[j] + rng.normal(0, [1.2, 0.6], (c, 2)) for j, c in enumerate(counts)])
    d = xy - pose[:2]
    polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
    aoff = np.zeros(L + 1, dtype=np.int64)
    aoff[1:] = np.cumsum(counts)
    return xy, polar, aoff, np.arange(xy.shape[0], dtype=np.int64)


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_a_landmark_is_initialised_by_the_fit_once_more_than_n_init_are_held(backend):
    """a.3: detections are buffered while ``n_init`` or fewer are held; then ``X`` is the EFA upper
    bound of all of them (the public fit_ellipse), ``alpha = alpha_0``, ``X_EFA = X``, the buffer
    empties and ``born`` says how many were fitted."""
    k = _kernels(backend)
    rng = np.random.default_rng(4)
    E, held = _record(1), []
    old, ready, born = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.bool_), np.zeros(1, dtype=np.int64)
    pose = np.array([0.0, 0.0, 0.3])
    for scan in range(10):
        xy, polar, aoff, arow = _scan(rng, 1, pose, [3], np.array([[10.0, 4.0]]))
        E = E._replace(buf=rows_grown(E.buf, k.buffer_need(E, ready, 1, old, aoff)))
        k.initialise_rows(E, ready, born, 1, old, aoff, arow, xy, EC.n_init, EC.spread_factor, EC.alpha0)
        held.append(xy)
        if len(held) * 3 <= EC.n_init:
            assert not E.einit[0] and E.nbuf[0] == 3 * len(held) and born[0] == 0
            assert np.array_equal(E.buf[0, :E.nbuf[0]], np.concatenate(held))
            continue
        _, X = fit_ellipse(np.concatenate(held), True, None, EC.spread_factor)
        assert E.einit[0] and born[0] == 3 * len(held) and E.nbuf[0] == 0
        assert np.allclose(E.X[0], X, rtol=1e-12, atol=0) and E.alpha[0] == EC.alpha0
        assert np.array_equal(E.Xefa[0], E.X[0])
        break
    else:
        pytest.fail("never initialised")


def rows_grown(buf, n):
    from radarslam.core.arrays import grown_inner

    return grown_inner(buf, n)


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_the_scan_step_is_the_public_equations_landmark_by_landmark(backend):
    """a.4-a.5 and Decision 5 for each ``ready`` landmark: rm_predict, the max-trace W of seed
    eq. (5) (select_scan_W), rm_update and fit_ellipse, to 1e-12; a landmark without detections
    is only predicted; one not ready is left alone (negative control: it would have moved)."""
    L = 6
    k, rng, centres, E = _setting(backend, 9, L)
    for j in range(L):
        E.X[j] = np.diag(rng.uniform(0.5, 3.0, 2))
        E.Xefa[j] = np.eye(2)
    E.alpha[:] = rng.uniform(5, 40, L)
    E.einit[:] = True
    E.einit[4] = False                      # not ready: nothing may change
    counts = np.array([4, 0, 6, 3, 5, 7])  # landmark 1 without detections
    pose = np.array([1.0, -2.0, 0.7])
    pose_cov = np.array([[0.02, 0.003, 0.001], [0.003, 0.03, -0.002], [0.001, -0.002, 0.001]])
    cents = centres + rng.normal(0, 0.1, (L, 2))
    ccovs = np.tile(np.array([[0.04, 0.01], [0.01, 0.05]]), (L, 1, 1))
    xy, polar, aoff, arow = _scan(rng, L, pose, counts, centres)
    before = E._replace(X=E.X.copy(), alpha=E.alpha.copy(), Xefa=E.Xefa.copy())
    dt = 0.1
    k.rma_efa_rows(E, E.einit.copy(), L, np.arange(L), aoff, arow, polar, xy, cents, ccovs, pose, pose_cov, R,
                   np.zeros((0, 2, 2)), False, dt, EC.tau_s, EC.spread_factor, EC.eig_floor_m2, True, True)
    for j in range(L):
        sl = slice(aoff[j], aoff[j + 1])
        if j == 4:
            assert np.array_equal(E.X[j], before.X[j]) and E.alpha[j] == before.alpha[j]
            continue
        Xp, ap = rm_predict(before.X[j], before.alpha[j], dt, EC.tau_s)
        if counts[j] == 0:
            assert np.array_equal(E.X[j], before.X[j]) and np.isclose(E.alpha[j], ap, rtol=1e-14)
            assert np.array_equal(E.Xefa[j], before.Xefa[j])
            continue
        W = select_scan_W(converted_measurement_covs(pose, pose_cov, polar[sl], R), "max_trace")
        X, a = rm_update(Xp, ap, cents[j], ccovs[j], xy[sl], W, EC.spread_factor, EC.eig_floor_m2)
        assert np.allclose(E.X[j], X, rtol=1e-12, atol=1e-14) and np.isclose(E.alpha[j], a, rtol=1e-12)
        assert not np.allclose(E.X[j], before.X[j])
        _, Xefa = fit_ellipse(xy[sl], True, None, EC.spread_factor)
        assert np.allclose(E.Xefa[j], Xefa, rtol=1e-12, atol=1e-14)


def test_a_given_scan_W_replaces_the_max_trace_one():
    """``w_given``: the update uses ``W[j]`` (the estimator's other ``w_mode`` choices), not the
    max-trace ``W(i)``; with the max-trace one given the result is the kernel's own to the bit."""
    rng = np.random.default_rng(2)
    pose, pose_cov = np.array([0.0, 0.0, 0.2]), np.diag([0.01, 0.02, 0.001])
    xy, polar, aoff, arow = _scan(rng, 1, pose, [5], np.array([[12.0, 3.0]]))
    runs = {}
    Wmax = select_scan_W(converted_measurement_covs(pose, pose_cov, polar, R), "max_trace")
    for name, W, given in (("own", np.zeros((0, 2, 2)), False), ("max", Wmax[None], True),
                           ("mean", select_scan_W(converted_measurement_covs(pose, pose_cov, polar, R), "mean")[None],
                            True)):
        E = _record(1)
        E.einit[0], E.X[0], E.alpha[0] = True, np.diag([2.0, 1.0]), 10.0
        rows.rma_efa_rows(E, E.einit.copy(), 1, np.zeros(1, dtype=np.int64), aoff, arow, polar, xy, xy[:1] * 0 + 12.0,
                          np.tile(0.01 * np.eye(2), (1, 1, 1)), pose, pose_cov, R, W, given, 0.0, EC.tau_s,
                          EC.spread_factor, EC.eig_floor_m2, True, True)
        runs[name] = E.X[0].copy()
    assert np.array_equal(runs["own"], runs["max"])
    assert not np.allclose(runs["own"], runs["mean"])


def test_python_and_compiled_agree_to_the_bit_over_many_scans():
    """40 scans of 9 landmarks through initialise_rows and rma_efa_rows, Python and compiled: the
    same states to the bit (the same kernels, summed in the same order)."""
    k = _kernels("numba")
    rng = np.random.default_rng(21)
    L = 9
    centres = rng.uniform(-15, 15, (L, 2))
    recs = {"python": _record(L), "numba": _record(L)}
    old = np.arange(L, dtype=np.int64)
    for scan in range(40):
        pose = np.array([rng.normal(), rng.normal(), rng.uniform(0, 2 * np.pi)])
        counts = rng.integers(0, 6, L) * (rng.random(L) < 0.8)
        xy, polar, aoff, arow = _scan(rng, L, pose, counts, centres)
        cents = centres + rng.normal(0, 0.05, (L, 2))
        ccovs = np.tile(np.diag([0.02, 0.03]), (L, 1, 1))
        dt = 0.0 if scan % 7 == 0 else 0.1
        for name, kern in (("python", rows), ("numba", k)):
            E = recs[name]
            ready, born = E.einit.copy(), np.zeros(L, dtype=np.int64)
            E = recs[name] = E._replace(buf=rows_grown(E.buf, kern.buffer_need(E, ready, L, old, aoff)))
            kern.initialise_rows(E, ready, born, L, old, aoff, arow, xy, EC.n_init, EC.spread_factor, EC.alpha0)
            kern.rma_efa_rows(E, ready, L, old, aoff, arow, polar, xy, cents, ccovs, pose, np.diag([0.01, 0.01, 1e-4]),
                              R, np.zeros((0, 2, 2)), False, dt, EC.tau_s, EC.spread_factor, EC.eig_floor_m2, True,
                              True)
    a, b = recs["python"], recs["numba"]
    assert a.einit.sum() >= 7
    for f in ("einit", "X", "alpha", "Xefa", "nbuf"):
        assert np.array_equal(getattr(a, f), getattr(b, f)), f


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_the_mem_ekf_scan_is_the_public_update_landmark_by_landmark(backend):
    """a.10 for each ``ready`` landmark: mem_ekf_predict then mem_ekf_update_scan with each
    detection's W(i) of the sensor and the pose (``no-centroid``), to 1e-12; X the new shape's
    matrix; a landmark not ready is left alone."""
    from radarslam.extent.mem_ekf import mem_ekf_predict, mem_ekf_update_scan, shape_matrix

    L = 4
    k, rng, centres, E = _setting(backend, 17, L)
    for j in range(L):
        E.shape[j] = [rng.uniform(0, np.pi), rng.uniform(1.5, 2.5), rng.uniform(0.6, 1.0)]
        E.Cs[j] = np.diag([0.05, 0.1, 0.1])
        E.X[j] = shape_matrix(E.shape[j])
    E.einit[:] = True
    E.einit[2] = False
    before = E._replace(shape=E.shape.copy(), Cs=E.Cs.copy(), X=E.X.copy())
    pose = np.array([0.5, 1.0, -0.4])
    pose_cov = np.diag([0.02, 0.02, 0.001])
    xy, polar, aoff, arow = _scan(rng, L, pose, [5, 3, 4, 6], centres)
    cents, ccovs = centres + 0.05, np.tile(0.02 * np.eye(2), (L, 1, 1))
    k.mem_ekf_rows(E, E.einit.copy(), L, np.arange(L), aoff, arow, polar, xy, cents, ccovs, pose, pose_cov, R,
                   np.zeros((0, 2, 2)), False, 0.1, 0.02, 0.05, rows.MEM_NO_CENTROID, EC.spread_factor, True, True)
    for j in range(L):
        if j == 2:
            assert np.array_equal(E.shape[j], before.shape[j]) and np.array_equal(E.Cs[j], before.Cs[j])
            continue
        sl = slice(aoff[j], aoff[j + 1])
        p, Cp = mem_ekf_predict(before.shape[j], before.Cs[j], 0.1, 0.02, 0.05)
        W = converted_measurement_covs(pose, pose_cov, polar[sl], R)       # each detection's own W(i)
        p, Cp = mem_ekf_update_scan(p, Cp, cents[j], np.zeros((2, 2)), xy[sl], W, EC.spread_factor)
        assert np.allclose(E.shape[j], p, rtol=1e-12, atol=1e-13) and np.allclose(E.Cs[j], Cp, rtol=1e-10, atol=1e-14)
        assert np.allclose(E.X[j], shape_matrix(p), rtol=1e-12, atol=1e-13)
        assert not np.allclose(E.shape[j], before.shape[j])


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_the_arc_widths_are_each_landmarks_arc_diameter(backend):
    """a.9: each landmark's width of the scan is arc_diameter of its detections, the beam width
    its nearest range times the beam step; NaN without detections or across a gap."""
    from radarslam.extent import visible_arc

    if backend == "numba":
        require("numba")
        from radarslam.extent._compiled import arc_widths_rows as widths
    else:
        widths = visible_arc.arc_widths_rows
    step = np.radians(0.5)
    polar = np.array([[10.0, 0.10], [9.8, 0.10 + step], [9.9, 0.10 + 2 * step],      # a trunk: three beams
                      [20.0, -0.3], [20.1, -0.3 + 4 * step],                          # a gap of four beams
                      [5.0, 0.5]])                                                     # one beam
    aoff = np.array([0, 3, 5, 5, 6])
    d, beam = np.empty(4), np.empty(4)
    widths(polar, 4, np.arange(4), aoff, np.arange(6), step, d, beam)
    assert d[0] == visible_arc.arc_diameter(polar[:3], step) and beam[0] == 9.8 * step
    assert np.isnan(d[1]) and np.isnan(d[2])
    assert d[3] == visible_arc.arc_diameter(polar[5:], step) and d[3] > 0


def test_the_partial_view_shape_is_updated_once_per_scan_under_the_python_backend():
    """Regression: under the Python backend the partial-view estimator's scan step ran its shape
    update twice (once through step(), once more in step_all); the numba backend once."""
    from radarslam.extent.view_estimator import PartialViewEstimator

    cfg = profile_config()
    est = PartialViewEstimator(cfg.extent, cfg.extent.R(cfg.filter.R), "python")
    rng = np.random.default_rng(5)
    L = 3
    pose = np.array([0.0, 0.0, 0.0])
    centres = np.array([[8.0, 3.0], [12.0, -4.0], [15.0, 6.0]])
    xy, polar, aoff, arow = _scan(rng, L, pose, [5, 4, 6], centres)
    states = [est.new() for _ in range(L)]
    assoc = [list(range(aoff[j], aoff[j + 1])) for j in range(L)]
    est.step_all(states, polar, xy, assoc, centres, np.tile(0.01 * np.eye(2), (L, 1, 1)), pose,
                 np.diag([0.01, 0.01, 1e-4]), 0.1, 1)
    assert [s.n_view for s in states] == [1, 1, 1]


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_a_merge_keeps_takes_or_pools_as_merge_outcome_says(backend):
    """c.9 [PROP]: an initialised survivor keeps its extent; an uninitialised one takes the other's
    (RMA/EFA and MEM-EKF* shape); two uninitialised ones pool their buffers, the survivor's first;
    with ``view`` the partial-view shape updated by more scans is kept, without it never."""
    from radarslam.extent.buffering import KEEP, POOL, TAKE

    k = _kernels(backend)

    def pair(init0, init1, n0, n1):
        E = _record(2, n0 + n1)
        for j, (init, n) in enumerate(((init0, n0), (init1, n1))):
            E.einit[j], E.alpha[j], E.nbuf[j] = init, 10.0 + j, 0 if init else n
            E.X[j], E.Xefa[j] = (j + 1) * np.eye(2), (j + 2) * np.eye(2)
            E.shape[j], E.Cs[j] = [j, 1.0 + j, 0.5], (j + 1) * np.eye(3)
            E.buf[j, :n] = 100 * j + np.arange(2 * n).reshape(n, 2)
            E.xi[j], E.Pxi[j], E.nview[j] = [j, 0.0, j], (j + 1) * np.eye(3), 3 * j
        return E

    E = pair(True, True, 0, 0)
    assert k.merge_rows(E, 0, 1, False) == KEEP
    assert E.alpha[0] == 10.0 and np.array_equal(E.X[0], np.eye(2)) and E.nview[0] == 0
    E = pair(False, True, 3, 0)
    assert k.merge_rows(E, 0, 1, True) == TAKE
    assert E.einit[0] and E.alpha[0] == 11.0 and E.nbuf[0] == 0
    assert np.array_equal(E.X[0], 2 * np.eye(2)) and np.array_equal(E.Xefa[0], 3 * np.eye(2))
    assert np.array_equal(E.shape[0], [1, 2.0, 0.5]) and np.array_equal(E.Cs[0], 2 * np.eye(3))
    assert E.nview[0] == 3 and np.array_equal(E.xi[0], [1, 0.0, 1])            # the view shape seen more
    E = pair(False, False, 2, 3)
    mine = E.buf[0, :2].copy()
    assert k.merge_rows(E, 0, 1, False) == POOL
    assert E.nbuf[0] == 5 and np.array_equal(E.buf[0, :2], mine) and np.array_equal(E.buf[0, 2:5], E.buf[1, :3])
    assert not E.einit[0] and E.nview[0] == 0                                   # no view: its shape stays


@pytest.mark.parametrize("backend", ["python", "numba"])
def test_the_sliding_efa_fits_the_last_window_of_detections(backend):
    """``extent.efa_mode = "sliding"`` (kept in the estimator, after the row kernels): once the
    extent is initialised, the EFA baseline is the fit of the last ``efa_window`` detections the
    landmark was given, those buffered before the initialisation included."""
    from dataclasses import replace

    from radarslam.extent.estimator import RmaEfaEstimator

    if backend == "numba":
        require("numba")
    cfg = profile_config()
    ec = replace(cfg.extent, efa_mode="sliding", efa_window=12)
    est = RmaEfaEstimator(ec, ec.R(cfg.filter.R), backend)
    st, seen = est.new(), []
    rng = np.random.default_rng(8)
    pose, pose_cov = np.array([0.0, 0.0, 0.1]), np.diag([0.01, 0.01, 1e-4])
    centre = np.array([[14.0, 5.0]])
    for k in range(1, 16):
        xy, polar, _, _ = _scan(rng, 1, pose, [4], centre)
        est.step(st, polar, xy, centre[0], 0.02 * np.eye(2), pose, pose_cov, 0.1, k)
        seen.append(xy)
    assert st.initialized and st.initialized_at < 15
    _, X = fit_ellipse(np.concatenate(seen)[-12:], True, None, ec.spread_factor)
    assert np.allclose(st.X_efa, X, rtol=1e-12, atol=0)
    _, X_scan = fit_ellipse(seen[-1], True, None, ec.spread_factor)          # not the last scan's alone
    assert not np.allclose(st.X_efa, X_scan)
