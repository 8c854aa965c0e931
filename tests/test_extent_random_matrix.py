"""Random-matrix extent prediction and update, seed eqs. (8)-(20)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from radarslam.core.errors import InputError
from radarslam.extent import ellipse_to_matrix, fit_ellipse, matrix_to_ellipse, rm_predict, rm_update
from radarslam.extent.random_matrix import _rm_predict, _rm_update


# --------------------------------------------------------------------------- independent reference


def reference_rm_update(X, alpha, p, P, Z, W, gamma=0.25, floor=1e-4):
    """Seed eqs. (10)-(20) typed in directly with scipy.linalg.sqrtm; no library kernels."""
    m = Z.shape[0]
    zbar = Z.mean(axis=0)                                   # (10)
    Zbar = (Z - zbar).T @ (Z - zbar)                        # (11)
    Y = gamma * X + W                                       # (12)
    M = np.outer(zbar - p, zbar - p)                        # (13)
    S = P + Y / m                                           # (14)
    Xh = scipy.linalg.sqrtm(X).real
    A = Xh @ np.linalg.inv(scipy.linalg.sqrtm(S).real)      # (15)
    B = Xh @ np.linalg.inv(scipy.linalg.sqrtm(Y).real)      # (16)
    Mhat = A @ M @ A.T                                      # (17)
    Yhat = B @ Zbar @ B.T                                   # (18)
    alpha_post = alpha + m                                  # (20)
    Xp = (alpha * X + Mhat + Yhat) / alpha_post             # (19)
    Xp = 0.5 * (Xp + Xp.T)
    lam, U = np.linalg.eigh(Xp)
    return (U * np.maximum(lam, floor)) @ U.T, alpha_post


def random_problem(rng: np.random.Generator, m: int):
    X = ellipse_to_matrix(rng.uniform(0.5, 3.0, 2), rng.uniform(0, math.pi))
    alpha = rng.uniform(5, 500)
    p = rng.normal(scale=20, size=2)
    L = rng.normal(size=(2, 2)) * 0.3
    P = L @ L.T + 1e-4 * np.eye(2)
    K = rng.normal(size=(2, 2)) * 0.4
    W = K @ K.T + 1e-3 * np.eye(2)
    Z = p + rng.normal(scale=0.5, size=2) + rng.normal(size=(m, 2)) @ np.linalg.cholesky(X / 4 + W).T
    return X, alpha, p, P, Z, W


@pytest.mark.parametrize("m", [1, 2, 3, 6, 10, 50])
def test_update_matches_independent_evaluation(m):
    rng = np.random.default_rng(100 + m)
    for _ in range(40):
        X, alpha, p, P, Z, W = random_problem(rng, m)
        gamma = rng.choice([0.25, 0.2, 1.0])
        Xr, ar = reference_rm_update(X, alpha, p, P, Z, W, gamma)
        Xu, au = rm_update(X, alpha, p, P, Z, W, gamma=gamma)
        np.testing.assert_allclose(Xu, Xr, rtol=0, atol=1e-10 * np.abs(Xr).max())
        assert au == ar == alpha + m
        assert np.array_equal(Xu, Xu.T)
        Xk, ak = _rm_update(X, alpha, p, P, Z, W, gamma)
        np.testing.assert_array_equal(Xk, Xu)
        assert ak == au


def test_update_with_one_point_has_no_scatter_term():
    """m = 1: Zbar = 0, so X+ = (alpha X + A M A^T) / (alpha + 1) (docs/method.md h.5)."""
    rng = np.random.default_rng(7)
    X, alpha, p, P, Z, W = random_problem(rng, 1)
    Xu, au = rm_update(X, alpha, p, P, Z, W)
    S = P + (0.25 * X + W)
    A = scipy.linalg.sqrtm(X).real @ np.linalg.inv(scipy.linalg.sqrtm(S).real)
    v = Z[0] - p
    np.testing.assert_allclose(Xu, (alpha * X + A @ np.outer(v, v) @ A.T) / (alpha + 1), rtol=1e-10)
    assert au == alpha + 1
    # a detection exactly at the centroid only shrinks X by alpha / (alpha + 1)
    Xc, _ = rm_update(X, alpha, p, P, p[None, :], W)
    np.testing.assert_allclose(Xc, alpha * X / (alpha + 1), rtol=1e-12)


def test_alpha_bookkeeping_and_prediction():
    X = ellipse_to_matrix([2.0, 1.0], 0.3)
    Xp, ap = rm_predict(X, 50.0, 0.16, 100.0)
    factor = math.exp(-0.16 / 100.0)
    assert factor == pytest.approx(0.998401, abs=5e-7)            # docs/method.md a.4
    assert ap == pytest.approx(2.0 + 0.998401 * 48.0, abs=48 * 5e-7)
    assert ap == 2.0 + factor * 48.0
    np.testing.assert_array_equal(Xp, X)                           # seed eq. (8)
    assert Xp is not X
    assert rm_predict(X, 2.0, 0.16, 100.0)[1] == 2.0                # 2 is the fixed point
    assert rm_predict(X, 50.0, 0.0, 100.0)[1] == 50.0               # no time, no decay
    assert rm_predict(X, 50.0, 1e6, 100.0)[1] == pytest.approx(2.0)
    Xk, ak = _rm_predict(X, 50.0, 0.16, 100.0)
    assert Xk is X and ak == ap
    rng = np.random.default_rng(8)
    for m in (1, 4, 9):
        _, alpha_post = rm_update(X, ap, [0, 0], np.eye(2) * 0.01, rng.normal(size=(m, 2)), np.eye(2) * 0.1)
        assert alpha_post == ap + m                                 # seed eq. (20)


def test_update_does_not_modify_inputs():
    rng = np.random.default_rng(9)
    args = random_problem(rng, 5)
    copies = [np.copy(a) for a in args]
    Xu, _ = rm_update(*args)
    _rm_update(*args)
    for a, c in zip(args, copies):
        np.testing.assert_array_equal(a, c)
    assert Xu is not args[0]


def test_update_is_invariant_to_point_order():
    rng = np.random.default_rng(10)
    for _ in range(20):
        X, alpha, p, P, Z, W = random_problem(rng, 8)
        X1, a1 = rm_update(X, alpha, p, P, Z, W)
        X2, a2 = rm_update(X, alpha, p, P, Z[rng.permutation(8)], W)
        np.testing.assert_allclose(X2, X1, rtol=1e-12, atol=1e-14)
        assert a1 == a2


def test_update_is_equivariant_to_rotation_and_translation():
    rng = np.random.default_rng(11)
    for _ in range(30):
        X, alpha, p, P, Z, W = random_problem(rng, int(rng.integers(1, 10)))
        o = rng.uniform(-math.pi, math.pi)
        R = np.array([[math.cos(o), -math.sin(o)], [math.sin(o), math.cos(o)]])
        t = rng.normal(scale=30, size=2)
        X1, a1 = rm_update(X, alpha, p, P, Z, W)
        X2, a2 = rm_update(R @ X @ R.T, alpha, R @ p + t, R @ P @ R.T, Z @ R.T + t, R @ W @ R.T)
        np.testing.assert_allclose(X2, R @ X1 @ R.T, rtol=0, atol=1e-11 * np.abs(X1).max())
        assert a1 == a2


def test_eigenvalue_floor():
    """Collinear detections through the centroid drive the minor axis to 0: the floor holds it."""
    X = np.diag([4.0, 1e-6])
    pts = np.column_stack([np.linspace(-2, 2, 9), np.zeros(9)])
    Xu, _ = rm_update(X, 3.0, [0, 0], np.eye(2) * 1e-6, pts, np.zeros((2, 2)))
    assert np.linalg.eigvalsh(Xu)[0] == pytest.approx(1e-4, rel=1e-9)
    Xf, _ = rm_update(X, 3.0, [0, 0], np.eye(2) * 1e-6, pts, np.zeros((2, 2)), eig_floor=0.01)
    assert np.linalg.eigvalsh(Xf)[0] == pytest.approx(0.01, rel=1e-9)


@settings(derandomize=True, max_examples=200, deadline=None)
@given(
    axes=st.tuples(st.floats(0.01, 10), st.floats(0.01, 10)),
    o=st.floats(-4, 4),
    alpha=st.floats(0.1, 1e4),
    seed=st.integers(0, 2**32 - 1),
    m=st.integers(1, 30),
    spread=st.floats(1e-3, 30),
)
def test_update_keeps_X_symmetric_with_floored_eigenvalues(axes, o, alpha, seed, m, spread):
    rng = np.random.default_rng(seed)
    X = ellipse_to_matrix(axes, o)
    Z = rng.normal(scale=spread, size=(m, 2))
    Xu, au = rm_update(X, alpha, rng.normal(size=2), np.eye(2) * rng.uniform(0, 1), Z,
                       np.diag(rng.uniform(0, 1, 2)))
    assert np.array_equal(Xu, Xu.T)
    assert np.all(np.isfinite(Xu))
    assert np.linalg.eigvalsh(Xu)[0] >= 1e-4 * (1 - 1e-9)
    assert au == alpha + m


# --------------------------------------------------------------------------- statistics


def uniform_in_ellipse(rng: np.random.Generator, n: int, semi_axes, o: float, center=(0.0, 0.0)) -> np.ndarray:
    """Uniform samples inside the ellipse: (rho, t) = (sqrt(U1), 2 pi U2) is uniform on the unit disk."""
    rho = np.sqrt(rng.uniform(size=n))
    t = rng.uniform(0, 2 * math.pi, size=n)
    local = np.column_stack([semi_axes[0] * rho * np.cos(t), semi_axes[1] * rho * np.sin(t)])
    R = np.array([[math.cos(o), -math.sin(o)], [math.sin(o), math.cos(o)]])
    return local @ R.T + np.asarray(center)


def test_uniform_ellipse_sample_covariance_is_X_over_4():
    """docs/method.md d.4: cov = X/4. In the principal frame (u, v), with u = a rho cos t:
    E[u^2] = a^2/4, E[u^4] = a^4 E[rho^4] E[cos^4 t] = a^4 (1/3)(3/8) = a^4/8, so
    sd(u^2) = a^2/4 and the sample variance has relative standard error 1/sqrt(n);
    E[u^2 v^2] = a^2 b^2 (1/3)(1/8) = a^2 b^2 / 24, so the sample covariance has sd ab/sqrt(24 n).
    The test allows 4 standard errors (two-sided probability about 6e-5 each)."""
    n = 20000
    a, b, o = 3.0, 1.2, 0.6
    rng = np.random.default_rng(12)
    Z = uniform_in_ellipse(rng, n, (a, b), o, center=(10.0, -5.0))
    R = np.array([[math.cos(o), -math.sin(o)], [math.sin(o), math.cos(o)]])
    C_local = R.T @ np.cov(Z.T) @ R
    assert C_local[0, 0] == pytest.approx(a * a / 4, rel=4 / math.sqrt(n))
    assert C_local[1, 1] == pytest.approx(b * b / 4, rel=4 / math.sqrt(n))
    assert abs(C_local[0, 1]) <= 4 * a * b / math.sqrt(24 * n)


def run_rm(rng, sampler, n_scans=400, m=10, n_init=21, center=(0.0, 0.0)):
    """The extent life cycle of docs/method.md a.3-a.5 on an exactly known centroid, W ~ 0."""
    center = np.asarray(center, dtype=float)
    fit = fit_ellipse(sampler(rng, n_init))                 # EFA upper-bound initialisation
    assert fit
    X, alpha = fit[1], 50.0
    P = 1e-9 * np.eye(2)
    W = 1e-9 * np.eye(2)
    for _ in range(n_scans):
        X, alpha = rm_predict(X, alpha, 0.16, 100.0)
        X, alpha = rm_update(X, alpha, center, P, sampler(rng, m), W)
    return X, alpha


def test_rm_converges_to_ellipse_extent():
    """400 scans of 10 uniform points. With W ~ 0 and a known centroid, B = 2 I and
    A = 2 sqrt(m) I, so X+ is a weighted mean of 4 x (scatter) whose expectation is X; the final
    estimate pools ~4000 points (relative standard error ~ 1/sqrt(4000) = 1.6 % per variance) plus
    a ~1 % weight on the 21-point initialisation. Tolerance: 5 % relative Frobenius, about
    3 standard errors. (Measured over 300 seeds: mean error 1.5 %, 99th percentile 3.8 %; with
    200 scans the mean is 2.2 % and 2.7 % of seeds exceed 5 %, hence 400.)"""
    axes, o, c = (2.5, 1.0), math.radians(35), (12.0, -3.0)
    X_true = ellipse_to_matrix(axes, o)
    X, alpha = run_rm(np.random.default_rng(13), lambda g, n: uniform_in_ellipse(g, n, axes, o, c), center=c)
    assert np.linalg.norm(X - X_true) / np.linalg.norm(X_true) < 0.05
    # alpha_n = 2 + e (alpha_{n-1} - 2) + m with e = exp(-dt/tau): a geometric approach to
    # alpha* = 2 + m / (1 - e) = 6257, i.e. alpha_n = alpha* + e^n (alpha_0 - alpha*) = 2986 at n = 400
    e = math.exp(-0.16 / 100)
    a_star = 2 + 10 / (1 - e)
    assert alpha == pytest.approx(a_star + e**400 * (50 - a_star), rel=1e-12)
    ax, o_est = matrix_to_ellipse(X)
    np.testing.assert_allclose(ax, axes, rtol=0.05)
    assert abs(o_est - o) < math.radians(3)


def test_rm_converges_to_moment_ellipse_of_rectangle():
    """Uniform over an L x W rectangle: cov = diag(L^2, W^2)/12 = X/4, so X has semi-axes
    (L/sqrt(3), W/sqrt(3)) (docs/method.md d.4, Decision 7 'moment')."""
    L, Wd, o = 4.0, 2.0, math.radians(90)
    R = np.array([[math.cos(o), -math.sin(o)], [math.sin(o), math.cos(o)]])

    def sampler(g, n):
        return np.column_stack([g.uniform(-L / 2, L / 2, n), g.uniform(-Wd / 2, Wd / 2, n)]) @ R.T + (-13.0, 14.0)

    X, _ = run_rm(np.random.default_rng(14), sampler, center=(-13.0, 14.0))
    ax, o_est = matrix_to_ellipse(X)
    np.testing.assert_allclose(ax, [L / math.sqrt(3), Wd / math.sqrt(3)], rtol=0.05)
    assert abs(o_est - o) < math.radians(3)


# --------------------------------------------------------------------------- bad input

GOOD = dict(X=np.eye(2), alpha=50.0, centroid=np.zeros(2), centroid_cov=np.eye(2) * 0.01,
            points=np.ones((4, 2)), W=np.eye(2) * 0.1)


@pytest.mark.parametrize("name, value", [
    ("X", np.array([[1.0, np.nan], [np.nan, 1.0]])),
    ("X", np.array([[1.0, 2.0], [2.0, 1.0]])),
    ("X", np.array([[1.0, 0.2], [0.0, 1.0]])),
    ("X", np.eye(3)),
    ("alpha", 0.0),
    ("alpha", np.nan),
    ("centroid", np.zeros(3)),
    ("centroid", np.array([np.inf, 0.0])),
    ("centroid_cov", -np.eye(2)),
    ("centroid_cov", np.zeros((2, 3))),
    ("points", np.zeros((0, 2))),
    ("points", np.zeros((5, 3))),
    ("points", np.array([[0.0, np.nan]])),
    ("W", np.diag([1.0, -0.5])),
    ("W", np.ones(2)),
])
def test_rm_update_rejects_bad_input(name, value):
    kwargs = dict(GOOD, **{name: value})
    with pytest.raises(InputError, match=name):
        rm_update(**kwargs)


@pytest.mark.parametrize("name, value", [("gamma", 0.0), ("gamma", -1.0), ("eig_floor", -1e-4)])
def test_rm_update_rejects_bad_parameters(name, value):
    with pytest.raises(InputError, match=name):
        rm_update(**GOOD, **{name: value})


@pytest.mark.parametrize("name, value", [
    ("X", np.array([[np.nan, 0.0], [0.0, 1.0]])),
    ("X", np.diag([1.0, -1.0])),
    ("X", np.eye(3)),
    ("alpha", -3.0),
    ("dt", -0.16),
    ("tau", 0.0),
    ("tau", np.inf),
])
def test_rm_predict_rejects_bad_input(name, value):
    kwargs = dict(X=np.eye(2), alpha=50.0, dt=0.16, tau=100.0)
    kwargs[name] = value
    with pytest.raises(InputError, match=name):
        rm_predict(**kwargs)
