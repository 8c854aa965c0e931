"""EKF-SLAM maths: Jacobians by central differences, the linear-KF oracle, PSD properties."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from radarslam.core.angles import wrap_pi
from radarslam.models.motion import UnicycleModel
from radarslam.models.radar import inverse_jacobians, polar_to_xy, range_azimuth, range_azimuth_jacobians
from radarslam.slam import ekf, layout

from oracles import is_psd

STEP = 1e-6
JAC_TOL = 1e-6  # central differences: truncation ~ STEP^2 * f''' and rounding ~ eps / STEP ~ 1e-10


def numjac(f, x0: np.ndarray, wrap_rows=()) -> np.ndarray:
    """Central-difference Jacobian; rows in ``wrap_rows`` are angle differences wrapped to (-pi, pi]."""
    x0 = np.asarray(x0, float)
    cols = []
    for i in range(x0.size):
        d = np.zeros_like(x0)
        d[i] = STEP
        diff = np.asarray(f(x0 + d)) - np.asarray(f(x0 - d))
        for r in wrap_rows:
            diff[r] = wrap_pi(diff[r])
        cols.append(diff / (2 * STEP))
    return np.column_stack(cols)


POSES = [np.array([1.0, -2.0, 0.3]), np.array([0.0, 0.0, math.pi - 1e-4]), np.array([3.0, 4.0, 2 * math.pi - 1e-3])]


@pytest.mark.parametrize("pose", POSES)
@pytest.mark.parametrize("u", [np.array([4.0, 0.32]), np.array([2.5, -0.8]), np.array([0.0, 0.0])])
def test_unicycle_jacobians(pose, u):
    m = UnicycleModel()
    dt = 0.16
    Fx, Fu = m.jacobians(pose, u, dt)
    assert np.allclose(Fx, numjac(lambda p: m.step(p, u, dt), pose, wrap_rows=(2,)), atol=JAC_TOL)
    assert np.allclose(Fu, numjac(lambda uu: m.step(pose, uu, dt), u, wrap_rows=(2,)), atol=JAC_TOL)


# Landmarks placed so the bearing atan2(dy, dx) - theta sits near +-pi, where wrapping bites.
@pytest.mark.parametrize("pose,p", [
    (np.array([0.0, 0.0, 0.2]), np.array([5.0, 3.0])),
    (np.array([0.0, 0.0, 0.0]), np.array([-7.0, 1e-5])),     # bearing just below +pi
    (np.array([0.0, 0.0, 0.0]), np.array([-7.0, -1e-5])),    # bearing just above -pi
    (np.array([1.0, 1.0, math.pi]), np.array([9.0, 1.0 + 1e-5])),  # theta = pi, landmark ahead-behind
    (np.array([2.0, -1.0, 6.2]), np.array([-3.0, -1.2])),
])
def test_range_azimuth_jacobians_near_pi(pose, p):
    Hx, Hp = range_azimuth_jacobians(pose, p)
    assert np.allclose(Hx, numjac(lambda q: range_azimuth(q, p), pose, wrap_rows=(1,)), atol=JAC_TOL)
    assert np.allclose(Hp, numjac(lambda q: range_azimuth(pose, q), p, wrap_rows=(1,)), atol=JAC_TOL)
    # The state-level sparse Jacobian is the same matrix.
    x = np.concatenate([pose, [10.0, 10.0], p])
    h, Hs, idx = ekf.landmark_measurement(x, 1)
    assert np.allclose(h, range_azimuth(pose, p)) and list(idx) == [0, 1, 2, 5, 6]
    assert np.allclose(Hs, np.hstack([Hx, Hp]))
    assert abs(h[1]) <= math.pi


@pytest.mark.parametrize("pose,s", [
    (np.array([1.0, 2.0, 0.4]), np.array([8.0, 0.3])),
    (np.array([0.0, 0.0, math.pi]), np.array([12.0, math.pi - 1e-4])),
    (np.array([0.0, 0.0, 0.0]), np.array([5.0, -math.pi + 1e-4])),
])
def test_polar_to_xy_jacobians(pose, s):
    """Seed eqs. (6)-(7) / APSIPA App. C against central differences of eq. (3)."""
    Gx, Gs = inverse_jacobians(pose, s)
    f = lambda q, ss: polar_to_xy(q, ss[None, :])[0]  # noqa: E731
    assert np.allclose(Gx, numjac(lambda q: f(q, s), pose), atol=JAC_TOL)
    assert np.allclose(Gs, numjac(lambda ss: f(pose, ss), s), atol=JAC_TOL)


def test_augment_covariance_is_linearised_transform(rng):
    n = 7
    A = rng.standard_normal((n, n))
    P = A @ A.T + n * np.eye(n)
    x = np.concatenate([[1.0, 2.0, 0.5], rng.standard_normal(n - 3)])
    R = np.diag([0.25, math.radians(1) ** 2])
    s = np.array([10.0, -0.7])
    xa, Pa = ekf.augment(x, P, s, R)
    Gx, Gs = inverse_jacobians(x[:3], s)
    J1 = np.vstack([np.eye(n), np.hstack([Gx, np.zeros((2, n - 3))])])
    J2 = np.vstack([np.zeros((n, 2)), Gs])
    assert np.allclose(Pa, J1 @ P @ J1.T + J2 @ R @ J2.T, atol=1e-12)
    assert np.allclose(xa[n:], polar_to_xy(x[:3], s[None])[0])
    assert np.allclose(xa[:n], x) and np.array_equal(Pa[:n, :n], P)


def test_remove_landmark_drops_rows_and_columns(rng):
    x = np.arange(9.0)
    P = np.arange(81.0).reshape(9, 9)
    xr, Pr = ekf.remove_landmarks(x, P, [1])
    keep = [0, 1, 2, 3, 4, 7, 8]
    assert np.array_equal(xr, x[keep]) and np.array_equal(Pr, P[np.ix_(keep, keep)])


class LinearModel:
    """A linear motion model x' = F x + G u, to compare the EKF prediction with a plain KF."""

    name = "linear"

    def __init__(self, F, G):
        self.F, self.G = F, G

    def step(self, pose, u, dt):
        return self.F @ pose + self.G @ u

    def jacobians(self, pose, u, dt):
        return self.F, self.G


def test_ekf_equals_kalman_filter_on_linear_model(rng):
    """Prediction + sparse Joseph update equal the textbook KF when f and h are linear."""
    n = 9
    F = np.eye(3) + 0.05 * rng.standard_normal((3, 3))
    F[2] = [0.0, 0.0, 1.0]  # keep the 'heading' row trivial so its [0, 2 pi) wrap is inactive
    G = rng.standard_normal((3, 2))
    model = LinearModel(F, G)
    U = np.diag([0.1, 0.02])
    Q = np.diag([0.01, 0.01, 0.001])
    R = np.diag([0.3, 0.05])
    Fb = np.eye(n)
    Fb[:3, :3] = F
    Gb = np.vstack([G, np.zeros((n - 3, 2))])
    Qb = np.zeros((n, n))
    Qb[:3, :3] = Q
    x = np.concatenate([[1.0, -1.0, 3.0], rng.standard_normal(n - 3)])
    P = np.eye(n) * 0.5
    xk, Pk = x.copy(), P.copy()
    for step in range(25):
        u = rng.standard_normal(2) * 0.1
        x, P = ekf.predict(x, P, u, 0.1, model, U, Q)
        xk = Fb @ xk + Gb @ u
        Pk = Fb @ Pk @ Fb.T + Gb @ U @ Gb.T + Qb
        j = step % 3
        idx = np.array([0, 1, 2, 3 + 2 * j, 4 + 2 * j])
        Hs = rng.standard_normal((2, 5)) * 0.3
        Hs[:, 2] *= 0.01
        H = np.zeros((2, n))
        H[:, idx] = Hs
        z = H @ xk + rng.standard_normal(2) * 0.1
        e = z - H @ x
        x, P = ekf.update(x, P, e, Hs, idx, R)
        S = H @ Pk @ H.T + R
        K = Pk @ H.T @ np.linalg.inv(S)
        xk = xk + K @ (z - H @ xk)
        Pk = (np.eye(n) - K @ H) @ Pk
        assert np.allclose(x, xk, atol=1e-10) and np.allclose(P, Pk, atol=1e-10)


def test_log_distance_is_negative_log_gaussian(rng):
    from scipy.stats import multivariate_normal

    for _ in range(20):
        A = rng.standard_normal((2, 2))
        S = A @ A.T + 0.1 * np.eye(2)
        e = rng.standard_normal(2)
        assert math.isclose(ekf.log_distance(e, S), -multivariate_normal(np.zeros(2), S).logpdf(e), rel_tol=1e-10)


def _spd(seed: int, n: int) -> np.ndarray:
    r = np.random.default_rng(seed)
    A = r.standard_normal((n, n))
    return A @ A.T / n + 1e-3 * np.eye(n)


@settings(max_examples=60)
@given(seed=st.integers(0, 2**31 - 1), n_lm=st.integers(1, 6),
       ops=st.lists(st.sampled_from(["predict", "update", "augment", "remove"]), min_size=1, max_size=25))
def test_covariance_stays_symmetric_psd(seed, n_lm, ops):
    """Random sequences of EKF operations keep P symmetric PSD, and updates never add uncertainty."""
    r = np.random.default_rng(seed)
    n = 3 + 2 * n_lm
    x = np.concatenate([[0.0, 0.0, 0.1], r.uniform(-20, 20, n - 3)])
    P = _spd(seed, n) * 0.1
    model = UnicycleModel()
    U = np.diag([0.02**2, math.radians(0.008) ** 2])
    Q = np.diag([1.5e-3, 1.5e-3, 5e-5])
    R = np.diag([0.25, math.radians(1) ** 2])
    for op in ops:
        nl = layout.n_landmarks(x.shape[0])
        if op == "predict":
            x, P = ekf.predict(x, P, np.array([4.0, 0.32]), 0.16, model, U, Q)
        elif op == "update" and nl:
            j = int(r.integers(nl))
            h, Hs, idx = ekf.landmark_measurement(x, j)
            if h[0] < 1e-3:
                continue
            z = h + r.normal(0, [0.5, 0.02])
            tr = np.trace(P)
            x, P = ekf.update(x, P, ekf.innovation(z, h), Hs, idx, R)
            assert np.trace(P) <= tr + 1e-9
        elif op == "augment":
            x, P = ekf.augment(x, P, np.array([r.uniform(1, 20), r.uniform(-math.pi, math.pi)]), R)
        elif op == "remove" and nl > 1:
            x, P = ekf.remove_landmarks(x, P, [int(r.integers(nl))])
        assert np.allclose(P, P.T, atol=1e-12)
        assert is_psd(P, tol=1e-9)
        assert 0.0 <= x[2] < 2 * math.pi


@pytest.mark.parametrize("with_extent", [False, True])
def test_score_landmarks_equals_per_landmark_functions(with_extent):
    """The fast association kernel equals landmark_measurement + innovation_cov + log_distance."""
    r = np.random.default_rng(17)
    R = np.diag([0.25, math.radians(1) ** 2])
    for trial in range(200):
        n_lm = int(r.integers(1, 8))
        n = 3 + 2 * n_lm
        x = np.concatenate([[r.uniform(-5, 5), r.uniform(-5, 5), r.uniform(0, 2 * math.pi)], r.uniform(-20, 20, n - 3)])
        A = r.standard_normal((n, n))
        P = A @ A.T / n + 0.01 * np.eye(n)
        js = sorted(r.choice(n_lm, size=min(3, n_lm), replace=False).tolist())
        z = np.array([r.uniform(1, 20), r.uniform(-math.pi, math.pi)])
        if trial % 5 == 0:  # azimuth residuals near +-pi
            h, _, _ = ekf.landmark_measurement(x, js[0])
            z = np.array([h[0], wrap_pi(h[1] + math.pi - 1e-6)])
        gX = None
        if with_extent:
            Xs = [None if k % 2 else np.diag(r.uniform(0.1, 2.0, 2)) for k in range(len(js))]
            gX = [None if X is None else (0.25 * X).tolist() for X in Xs]
        ref = []
        for k, j in enumerate(js):
            h, Hs, idx = ekf.landmark_measurement(x, j)
            Rj = R if gX is None or gX[k] is None else R + Hs[:, 3:] @ np.array(gX[k]) @ Hs[:, 3:].T
            ref.append(ekf.log_distance(ekf.innovation(z, h), ekf.innovation_cov(P, Hs, idx, Rj)))
        j, D, e = ekf.score_landmarks(x, P, z, js, R, gX)
        assert j == js[int(np.argmin(ref))]
        assert math.isclose(D, min(ref), rel_tol=1e-9, abs_tol=1e-9)
        h, _, _ = ekf.landmark_measurement(x, j)
        assert np.allclose(e, ekf.innovation(z, h), atol=1e-12)
    assert ekf.score_landmarks(x, P, z, [], R)[0] == -1
