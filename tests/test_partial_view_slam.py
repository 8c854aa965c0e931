"""The partial-view model inside SLAM (docs/method.md a.12.4-a.12.8): Jacobians against central
differences, the full-view limit against the existing kernels, the shape estimator on a static
ellipse seen from a moving sensor (with the RMA as negative control), the view-corrected centroid,
the components' selection, and a slow statistical test on a training seed."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.simulation.trial import run_trial
from radarslam.extent.ellipse import ellipse_to_matrix
from radarslam.extent.view_estimator import PartialViewEstimator, log_matrix_to_X, X_to_log_matrix
from radarslam.metrics.gwd import gaussian_wasserstein_distance as gwd
from radarslam.slam import _fused, ekf
from radarslam.slam.filter import EkfSlam
from radarslam.slam.partial_view import (PartialViewBatch, log_distances, polar_terms, sensor_xy_terms, view_terms,
                                         view_corrected_centroid)

from conftest import require, scaled

RNG = np.random.default_rng(20261124)


def _state(n=3):
    x = np.concatenate([[1.0, -2.0, 0.7], RNG.uniform(-15, 15, 2 * n)])
    A = RNG.standard_normal((x.size, x.size))
    return x, 0.05 * (A @ A.T) + 0.01 * np.eye(x.size)


def _shapes(n=3):
    return np.array([ellipse_to_matrix(np.array([RNG.uniform(1.5, 3), RNG.uniform(0.6, 1.4)]), RNG.uniform(0, math.pi))
                     for _ in range(n)])


def _fd(f, x, idx, eps=1e-6):
    cols = []
    for i in idx:
        d = np.zeros_like(x)
        d[i] = eps
        cols.append((f(x + d) - f(x - d)) / (2 * eps))
    return np.stack(cols, axis=-1)


def test_sensor_xy_jacobian_matches_central_differences():
    """h = Rot(-theta)(mu - t), mu = p + g(t - p, X): Hs over (x, y, theta, p_x, p_y) (a.12.5)."""
    x, _ = _state()
    X = _shapes()
    for j in range(3):
        def h(xx, j=j):
            mu, B, _ = view_terms(xx, X)
            return sensor_xy_terms(xx, mu[j:j + 1], B[j:j + 1])[0][0]
        mu, B, _ = view_terms(x, X)
        _, Hs = sensor_xy_terms(x, mu, B)
        num = _fd(h, x, [0, 1, 2, 3 + 2 * j, 4 + 2 * j])
        assert np.allclose(Hs[j], num, atol=1e-6), (Hs[j], num)


def test_polar_jacobian_matches_central_differences_also_near_pi():
    """The polar form (range, bearing) with the bearing near +-pi, where atan2 wraps."""
    x, _ = _state()
    X = _shapes()
    x[3:5] = x[:2] + np.array([-12.0, 1e-3])         # landmark 0 straight behind: bearing near pi - theta
    x[2] = 0.0
    for j in range(3):
        def h(xx, j=j):
            mu, B, S = view_terms(xx, X)
            out = polar_terms(xx, mu, B, S, np.eye(2), np.zeros((2, 2)))[0][j]
            return np.array([out[0], math.remainder(out[1] - ref[1], 2 * math.pi)])
        mu, B, S = view_terms(x, X)
        ref = polar_terms(x, mu, B, S, np.eye(2), np.zeros((2, 2)))[0][j]
        Hs = polar_terms(x, mu, B, S, np.eye(2), np.zeros((2, 2)))[1][j]
        num = _fd(h, x, [0, 1, 2, 3 + 2 * j, 4 + 2 * j])
        assert np.allclose(Hs, num, atol=1e-6), (j, Hs, num)


def test_full_view_limit_equals_the_existing_kernels():
    """With mu = p and B = I the partial-view measurements are a.7.3's and c.4's: the sensor-frame
    h and Hs of ekf.sensor_xy_measurement, and the log distance of ekf.score_landmarks with
    R_j = R + Hp gamma X Hp^T."""
    x, P = _state()
    p = x[3:].reshape(-1, 2)
    B = np.repeat(np.eye(2)[None], 3, axis=0)
    h, Hs = sensor_xy_terms(x, p, B)
    for j in range(3):
        h_ref, Hs_ref, _ = ekf.sensor_xy_measurement(x, j)
        assert np.allclose(h[j], h_ref, atol=1e-12) and np.allclose(Hs[j], Hs_ref, atol=1e-12)
    gX = _shapes() / 4
    R = np.diag([0.25, math.radians(1.0) ** 2])
    hp, Hp, Rj, ok = polar_terms(x, p, B, gX, R, np.zeros((2, 2)))
    idx = np.array([[0, 1, 2, 3 + 2 * j, 4 + 2 * j] for j in range(3)])
    Pb = P[idx[:, :, None], idx[:, None, :]]
    z = np.array([[9.0, 0.3], [14.0, -1.2]])
    D = log_distances(z, hp, Hp, Pb, Rj)
    for c in range(2):
        for j in range(3):
            _, D_ref, _ = ekf.score_landmarks(x, P, z[c], [j], R, [gX[j].tolist()])
            assert D[c, j] == pytest.approx(D_ref, rel=1e-10, abs=1e-10)


def test_view_corrected_centroid_inverts_the_arc_mean():
    X = ellipse_to_matrix(np.array([2.3, 1.0]), 0.4)
    p, t = np.array([5.0, 3.0]), np.array([-6.0, 1.0])
    mu, _, _ = view_terms(np.array([*t, 0.0, *p]), X[None])
    assert np.linalg.norm(mu[0] - p) > 0.5                     # the mean is well off the centroid
    assert np.allclose(view_corrected_centroid(mu[0], t, X), p, atol=1e-6)


def test_log_matrix_round_trip():
    for _ in range(20):
        X = ellipse_to_matrix(np.array([RNG.uniform(0.2, 4), RNG.uniform(0.1, 2)]), RNG.uniform(0, math.pi))
        assert np.allclose(log_matrix_to_X(X_to_log_matrix(X)), X, rtol=1e-10, atol=1e-12)


def _visible_arc_points(p, X, s, n, rng, noise):
    """``n`` detections uniform by arc length on the part of the outline facing ``s`` (an oracle
    written apart from the kernels: a dense outline and the outward-normal test), plus noise."""
    w, V = np.linalg.eigh(X)
    t = np.linspace(0, 2 * math.pi, 20000, endpoint=False)
    y = p + (V @ (np.sqrt(w)[:, None] * np.stack([np.cos(t), np.sin(t)]))).T
    normal = (np.linalg.solve(X, (y - p).T)).T
    vis = np.einsum("ni,ni->n", normal, s - y) > 0
    seg = np.linalg.norm(np.roll(y, -1, axis=0) - y, axis=1) * vis
    pick = rng.choice(y.shape[0], size=n, p=seg / seg.sum())
    return y[pick] + noise * rng.standard_normal((n, 2))


def _estimator(**extent):
    cfg = profile_config()
    ext = replace(cfg.extent, use_in_slam=True, view_model="partial", spread_model="visible-faces", **extent)
    return PartialViewEstimator(ext, np.diag([0.05 ** 2, math.radians(0.2) ** 2]), "python")


def test_shape_estimator_converges_on_a_static_ellipse_and_the_rma_stays_biased():
    """A car-sized ellipse seen from a sensor driving round it (30 scans of 12 detections on the
    visible arc): the partial-view shape converges within 0.15 m GWD; the RMA, which reads the
    spread about the centroid, stays off by more than 0.25 m and 3x that (negative control)."""
    rng = np.random.default_rng(7)
    X_true = ellipse_to_matrix(np.array([2.4, 1.1]), 0.6)
    p = np.array([0.0, 0.0])
    est = _estimator()
    st = est.new()
    cov = 0.01 * np.eye(2)
    for k in range(60):
        a = 2 * math.pi * k / 60
        s = 9.0 * np.array([math.cos(a), math.sin(a)])
        pose = np.array([*s, a + math.pi / 2])
        pts = _visible_arc_points(p, X_true, s, 12, rng, 0.05)
        d = pts - s
        polar = np.column_stack([np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2]])
        est.step(st, polar, pts, p, cov, pose, 1e-4 * np.eye(3), 0.1, k + 1)
    err_view = gwd(p, est.matrix(st), p, X_true)
    assert err_view < 0.15
    assert st.X is not None and gwd(p, st.X, p, X_true) > max(0.25, 3 * err_view)


def test_components_are_selected_by_the_view_model():
    """visible-faces with use_in_slam: the partial-view estimator and associator, which the fused
    engine covers (tests/test_fused_view.py); the surface model keeps the full view."""
    d = to_dict(profile_config())
    d["extent"].update(spread_model="visible-faces", use_in_slam=True)
    d["landmarks"]["associator"] = "batch"
    slam = EkfSlam(from_dict(d))
    assert isinstance(slam.extent, PartialViewEstimator) and isinstance(slam.associator, PartialViewBatch)
    d["extent"]["view_model"] = "full"
    assert EkfSlam(from_dict(d)).view is None
    d["extent"].update(view_model="auto", spread_model="surface")
    slam = EkfSlam(from_dict(d))
    assert slam.view is None


def test_a_partial_view_associator_called_on_its_own_refuses():
    """The partial view's association has one implementation, the engine's (slam/fused/view.py): its
    associator classes only name the scheme, and a direct call refuses in one line instead of running
    the full view's kernel of its base class. Negative control: the full view's batch associator,
    called the same way, runs its kernel and associates."""
    from radarslam.core.errors import InputError
    from radarslam.slam.association import BatchAssociator, Spreads
    from radarslam.slam.state import SlamState

    st = SlamState.initial(np.zeros(3), np.array([0.1, 0.1, 0.01]))
    st.add_landmark(np.array([5.0, 0.0]), 0.01 * np.eye(2), 0)
    polar = np.array([[5.0, 0.0]])
    args = (st, polar, np.array([0]), 0.01 * np.eye(2), Spreads(np.zeros((1, 2, 2)), np.zeros(1, dtype=bool)))
    with pytest.raises(InputError, match=r"^PartialViewBatch\.associate: the partial view's association runs in the "
                                         r"filter .*got a direct call$"):
        PartialViewBatch(10.0, 5, 5).associate(*args)
    out, nis = BatchAssociator(10.0, 5, 5).associate(*args)
    assert out.tolist() == [0] and nis.shape == (1,)


def _vf_config():
    d = to_dict(profile_config())
    d["radar"]["spread_model"] = "visible-faces"
    d["extent"].update(spread_model="visible-faces", use_in_slam=True, pre_init_spread="prior")
    d["landmarks"].update(init="cluster", associator="batch")
    return from_dict(d)


@pytest.mark.slow
def test_partial_view_beats_the_full_view_under_visible_faces_on_a_training_seed():
    """Training seed 777, the consistent pipeline under visible-faces: the partial-view model's
    average position RMSE over trials is below 0.8x the full view's (the negative control) and its
    time-averaged pose NEES below 15 (the full view's is ~50)."""
    require("numba")
    n = scaled(24, minimum=6)
    cfg = _vf_config()
    full = replace(cfg, extent=replace(cfg.extent, view_model="full"))
    pos = {"partial": [], "full": []}
    nees = []
    for trial in range(1, n + 1):
        for name, c in (("partial", cfg), ("full", full)):
            r = run_trial(c, 777 * 1000 + trial, use_extent=True)
            pos[name].append(r.metrics["position_avg_rmse_m"])
            if name == "partial":
                nees.append(np.mean(r.metrics["nees"]))
    assert np.mean(pos["partial"]) < 0.8 * np.mean(pos["full"]), pos
    assert np.mean(nees) < 15.0, nees


def test_reproduce_partial_view_study_writes_the_models_side_by_side(tmp_path):
    """`radarslam reproduce --study partial-view` at 2 trials: one Monte Carlo directory (with its
    report) per spread model, and the summary with the three models and the full-view controls."""
    require("numba")
    from radarslam.cli.main import main

    out = tmp_path / "study"
    assert main(["reproduce", "--study", "partial-view", "--trials", "2", "--jobs", "1", "--quiet",
                 "--out", str(out)]) == 0
    text = (out / "partial_view_study.md").read_text()
    assert (out / "partial_view_study.png").stat().st_size > 10_000
    for model in ("surface", "visible-faces", "scatter-centres"):
        assert f"## {model} (2 trials)" in text
        assert (out / model / "report" / "report.md").is_file()
    assert text.count("Consistent, full view") == 2               # the controls on the two partial-view models
    import json
    s = json.loads((out / "partial_view_study.json").read_text())["summary"]
    for model, m in s.items():
        for row in m["rows"].values():
            assert np.isfinite(row["position_m"]["estimate"]) and np.isfinite(row["nees_time_avg"])
    assert main(["reproduce", "--study", "partial-view", "--trials", "2", "--variant", "x=y.toml",
                 "--out", str(tmp_path / "bad")]) == 1


@pytest.mark.parametrize("step", [0.0, 1e-4])
def test_compiled_shape_update_equals_the_python_kernel(step):
    """extent/_compiled.py compiles view_estimator.view_update as it is: the same update to 1e-10
    on random shapes, views and scans (5 rows and 2 rows), with the analytic Jacobian (step 0,
    a.12.9) and with central differences."""
    require("numba")
    from radarslam.extent._compiled import view_update as compiled
    from radarslam.extent.view_estimator import view_update

    rng = np.random.default_rng(3)
    for _ in range(20):
        xi = np.array([rng.uniform(-1, 2), rng.uniform(-0.5, 0.5), rng.uniform(-1, 2)])
        P = np.diag(rng.uniform(0.1, 1.0, 3))
        d = rng.uniform(-12, 12, 2)
        y = np.concatenate([rng.normal(0, 1, 2), [rng.uniform(0.5, 3), rng.normal(0, 0.3), rng.uniform(0.2, 2)]])
        for m in (2, 8):
            Ws, Pc = 0.01 * np.eye(2), 0.1 * np.eye(2)
            a = view_update(xi, P, d[0], d[1], y, m, Ws, Pc, 0.09, 0.3, False, step)
            b = compiled(xi, P, d[0], d[1], y, m, Ws, Pc, 0.09, 0.3, False, step)
            assert a[2] == b[2]
            assert np.allclose(a[0], b[0], rtol=1e-10, atol=1e-10) and np.allclose(a[1], b[1], rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("step", [0.0, 1e-4])
def test_model_errors_add_the_shape_uncertainty(step):
    """model_errors: Q_v alone without shape covariances; with them, Q_v + J P_xi J^T, where J
    (analytic for step 0, a.12.9, else central differences) matches a finite-difference check of
    the mean offset along one direction of xi, and the added term is PSD and grows with P_xi."""
    from radarslam.slam.association import Spreads
    from radarslam.slam.partial_view import _exp_sym2_many, model_errors

    x = np.array([0.0, 0.0, 0.3, 8.0, 2.0, -6.0, 5.0])
    xi = np.array([[1.2, 0.3, -0.2], [0.5, -0.1, 0.4]])
    shapes = _exp_sym2_many(xi)
    Qv = 0.09 * np.eye(2)
    base = Spreads(np.zeros((2, 2, 2)), np.zeros(2, bool), shapes, Qv)
    assert np.allclose(model_errors(x, base, np.arange(2), step), Qv)
    P = np.stack([0.2 * np.eye(3), 0.05 * np.eye(3)])
    full = Spreads(np.zeros((2, 2, 2)), np.zeros(2, bool), shapes, Qv, xi, P)
    Q = model_errors(x, full, np.arange(2), step)
    extra = Q - Qv
    assert np.all(np.linalg.eigvalsh(extra) >= -1e-12) and np.trace(extra[0]) > 1e-3
    # J along u: (g(xi + h u) - g(xi - h u)) / 2h, independently of model_errors' loop
    from radarslam.extent.partial_view import visible_arc_moments
    u = np.array([0.3, -0.5, 0.8])
    h = 1e-5
    gp = visible_arc_moments(x[3:5], _exp_sym2_many(xi[:1] + h * u)[0], x[:2])[0]
    gm = visible_arc_moments(x[3:5], _exp_sym2_many(xi[:1] - h * u)[0], x[:2])[0]
    Ju = (gp - gm) / (2 * h)
    one = Spreads(np.zeros((2, 2, 2)), np.zeros(2, bool), shapes, np.zeros((2, 2)), xi,
                  np.stack([np.outer(u, u), np.zeros((3, 3))]))
    assert np.allclose(model_errors(x, one, np.array([0]), step)[0], np.outer(Ju, Ju), rtol=1e-5, atol=1e-9)
    bigger = Spreads(np.zeros((2, 2, 2)), np.zeros(2, bool), shapes, Qv, xi, 4 * P)
    assert np.all(np.linalg.eigvalsh(model_errors(x, bigger, np.arange(2), step) - Q) >= -1e-12)


def test_one_pass_terms_equal_the_two_passes():
    """view_model_terms with the analytic J (one quadrature pass per landmark, a.12.9) gives the
    mu, B, S of view_terms and the model errors of model_errors (shape_error_rows' own pass) to
    rounding; with central differences it is those two calls."""
    from radarslam.slam.association import Spreads
    from radarslam.slam.partial_view import _exp_sym2_many, model_errors, view_model_terms

    rng = np.random.default_rng(4)
    N = 6
    x = np.concatenate([[0.5, -1.0, 0.3], rng.uniform(-15, 15, 2 * N)])
    xi = np.column_stack([rng.uniform(-0.5, 1.5, N), rng.uniform(-0.5, 0.5, N), rng.uniform(-0.5, 1.5, N)])
    A = rng.normal(size=(N, 3, 3)) * 0.2
    covs = A @ A.transpose(0, 2, 1)
    sp = Spreads(None, None, _exp_sym2_many(xi), 0.04 * np.eye(2), xi, covs)
    js = np.array([4, 0, 2])
    for step in (0.0, 1e-4):
        mu, B, S, Q = view_model_terms(x, sp, js, step)
        mu2, B2, S2 = view_terms(x, sp.shapes, js)
        Q2 = model_errors(x, sp, js, step)
        for a, b in ((mu, mu2), (B, B2), (S, S2), (Q, Q2)):
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12)
    assert np.max(np.abs(Q2 - 0.04 * np.eye(2))) > 1e-3          # the shape's part is there
