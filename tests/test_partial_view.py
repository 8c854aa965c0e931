"""The partial-view measurement model (docs/method.md a.12) against a sampled oracle, finite
differences, closed-form limits and degenerate inputs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from radarslam.core.errors import InputError
from radarslam.extent import partial_view as pv
from radarslam.extent.ellipse import ellipse_to_matrix


def rot(o: float) -> np.ndarray:
    return np.array([[math.cos(o), -math.sin(o)], [math.sin(o), math.cos(o)]])


def sqrtm_spd(X: np.ndarray) -> np.ndarray:
    lam, U = np.linalg.eigh(X)
    return U @ np.diag(np.sqrt(lam)) @ U.T


def sensor_at(p, X, direction: float, qnorm: float) -> np.ndarray:
    """The sensor position whose q = L^-1 (s - p) has length qnorm and world angle ``direction``."""
    return np.asarray(p) + sqrtm_spd(X) @ (qnorm * np.array([math.cos(direction), math.sin(direction)]))


def moments(p, X, s):
    d = np.asarray(s, float) - p
    return pv.arc_moments(d[0], d[1], X[0, 0], X[0, 1], X[1, 1])


def sampled_oracle(rng, p, X, s, n=200_000):
    """n points uniform by arc length on the whole outline; those whose outward normal faces s."""
    L = sqrtm_spd(X)
    t = np.linspace(0.0, 2 * math.pi, 400_001)
    speed = np.linalg.norm(L @ np.vstack([-np.sin(t), np.cos(t)]), axis=0)
    arc = np.concatenate([[0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * np.diff(t))])
    ts = np.interp(rng.uniform(0.0, arc[-1], n), arc, t)
    y = p + (L @ np.vstack([np.cos(ts), np.sin(ts)])).T
    normal = np.linalg.solve(X, (y - p).T).T
    return y[np.einsum("ij,ij->i", normal, s - y) > 0.0]


CASES = [(seed, qn) for seed in range(4) for qn in (30.0, 2.5, 1.05)] + [(7, 1.01), (8, 1.1), (9, 1e4)]


@pytest.mark.parametrize("seed, qnorm", CASES)
def test_mean_and_covariance_match_a_sampled_oracle(seed, qnorm):
    """Within 5 standard errors of the sample mean and covariance (computed from the samples)."""
    rng = np.random.default_rng(100 + seed)
    X = ellipse_to_matrix(rng.uniform(0.3, 5.0, 2), rng.uniform(-math.pi, math.pi))
    p = rng.uniform(-20, 20, 2)
    s = sensor_at(p, X, rng.uniform(-math.pi, math.pi), qnorm)
    y = sampled_oracle(rng, p, X, s)
    n = len(y)
    assert n > 1000
    mean, cov, J_s, J_p, clamped = pv.visible_arc_moments(p, X, s)
    assert not clamped
    ym = y.mean(axis=0)
    sem = np.sqrt(np.diag(np.cov(y.T)) / n)
    assert np.all(np.abs(mean - ym) <= 5 * sem + 1e-9), (mean - ym, sem)
    z = y - ym
    prods = np.stack([z[:, 0] * z[:, 0], z[:, 0] * z[:, 1], z[:, 1] * z[:, 1]], axis=1)
    se_cov = prods.std(axis=0) / math.sqrt(n)
    ours = np.array([cov[0, 0], cov[0, 1], cov[1, 1]])
    assert np.all(np.abs(ours - prods.mean(axis=0)) <= 5 * se_cov + 1e-9), (ours - prods.mean(axis=0), se_cov)
    np.testing.assert_allclose(J_p, np.eye(2) - J_s, atol=1e-15)


def numeric_G(d, X, h=1e-6):
    G = np.zeros((2, 2))
    for j in range(2):
        e = np.zeros(2)
        e[j] = h * max(1.0, abs(d[j]))
        a = pv.arc_moments(*(d + e), X[0, 0], X[0, 1], X[1, 1])
        b = pv.arc_moments(*(d - e), X[0, 0], X[0, 1], X[1, 1])
        G[:, j] = (np.array(a[:2]) - np.array(b[:2])) / (2 * e[j])
    return G


@pytest.mark.parametrize("seed", range(12))
def test_jacobian_G_matches_central_differences(seed):
    rng = np.random.default_rng(seed)
    o = rng.uniform(-math.pi, math.pi)
    X = ellipse_to_matrix(rng.uniform(0.3, 5.0, 2), o)
    qn = [1.02, 1.3, 3.0, 50.0][seed % 4]
    d = sensor_at(np.zeros(2), X, rng.uniform(-math.pi, math.pi), qn)
    out = pv.arc_moments(*d, X[0, 0], X[0, 1], X[1, 1])
    G = np.array(out[2:6]).reshape(2, 2)
    np.testing.assert_allclose(G, numeric_G(d, X), atol=2e-7 * max(1.0, np.abs(G).max()))


@pytest.mark.parametrize("side", [1e-9, -1e-9, 0.0])
def test_jacobian_across_the_atan2_cut(side):
    """Sensor direction at +-pi of the principal frame: the difference steps straddle the cut."""
    o = 0.4
    X = ellipse_to_matrix([2.0, 0.7], o)
    d = rot(o) @ np.array([-5.0, side])
    out = pv.arc_moments(*d, X[0, 0], X[0, 1], X[1, 1])
    G = np.array(out[2:6]).reshape(2, 2)
    np.testing.assert_allclose(G, numeric_G(d, X), atol=1e-7)


@pytest.mark.parametrize("seed", range(6))
def test_shape_jacobian_matches_central_differences(seed):
    rng = np.random.default_rng(50 + seed)
    o, l1, l2 = rng.uniform(-3, 3), *rng.uniform(0.3, 5.0, 2)
    d = sensor_at(np.zeros(2), ellipse_to_matrix([l1, l2], o), rng.uniform(-math.pi, math.pi),
                  [1.05, 2.0, 20.0][seed % 3])
    J = np.array(pv.arc_mean_shape_jacobian(d[0], d[1], o, l1, l2)[:6]).reshape(3, 2).T

    def g(x):
        X = ellipse_to_matrix([math.exp(x[1]), math.exp(x[2])], x[0])
        return np.array(pv.arc_moments(d[0], d[1], X[0, 0], X[0, 1], X[1, 1])[:2])

    x0, h, Jn = np.array([o, math.log(l1), math.log(l2)]), 1e-6, np.zeros((2, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        Jn[:, j] = (g(x0 + e) - g(x0 - e)) / (2 * h)
    np.testing.assert_allclose(J, Jn, atol=2e-7 * max(1.0, np.abs(J).max()))
    Jw, clamped = pv.visible_arc_shape_jacobian([1.0, 2.0], [l1, l2], o, np.array([1.0, 2.0]) + d)
    np.testing.assert_allclose(Jw, J, atol=1e-12)
    assert not clamped


@pytest.mark.parametrize("rho, D", [(1.0, 1.5), (0.5, 10.0), (2.0, 2.05), (0.3, 300.0)])
def test_circle_closed_form(rho, D):
    """Circle of radius rho at distance D: b = arccos(rho / D), offset rho sin(b) / b towards the
    sensor, variances rho^2 (1/2 + sin 2b / 4b - sin^2 b / b^2) along and rho^2 (1/2 - sin 2b / 4b)
    across the line of sight."""
    a = 0.9
    s = D * np.array([math.cos(a), math.sin(a)])
    mean, cov, _, _, clamped = pv.visible_arc_moments([0.0, 0.0], rho ** 2 * np.eye(2), s)
    b = math.acos(rho / D)
    np.testing.assert_allclose(mean, rho * math.sin(b) / b * s / D, rtol=1e-12, atol=1e-14)
    u = s / D
    v = np.array([-u[1], u[0]])
    along = rho ** 2 * (0.5 + math.sin(2 * b) / (4 * b) - (math.sin(b) / b) ** 2)
    across = rho ** 2 * (0.5 - math.sin(2 * b) / (4 * b))
    np.testing.assert_allclose([u @ cov @ u, v @ cov @ v, u @ cov @ v], [along, across, 0.0],
                               rtol=1e-10, atol=1e-13 * rho ** 2)
    t0x, t0y, t1x, t1y, bb, _ = pv.tangent_points(*s, rho ** 2, 0.0, rho ** 2)
    assert bb == pytest.approx(b, rel=1e-13)
    for t in ((t0x, t0y), (t1x, t1y)):          # on the circle, and the sight line is tangent there
        assert np.hypot(*t) == pytest.approx(rho, rel=1e-12)
        assert np.dot(t, s - np.array(t)) == pytest.approx(0.0, abs=1e-12 * D * rho)
    assert not clamped


def test_long_range_tends_to_the_half_outline_mean():
    """r -> infinity: the visible arc is the half outline facing the sensor (b -> pi/2)."""
    o, l1, l2, a = 0.3, 3.0, 1.0, 2.0
    X = ellipse_to_matrix([l1, l2], o)
    x, w = np.polynomial.legendre.leggauss(1000)     # converged: 200, 500 and 1000 nodes agree to 2e-14 (4000: 1.4e-13 off, 4 s)
    phi = math.atan2(math.sin(a - o) / l2, math.cos(a - o) / l1)        # principal-frame direction of q
    t = phi + 0.5 * math.pi * x
    ww = w * np.hypot(l1 * np.sin(t), l2 * np.cos(t))
    half = rot(o) @ (np.array([l1 * (ww * np.cos(t)).sum(), l2 * (ww * np.sin(t)).sum()]) / ww.sum())
    for D, tol in ((1e3, 2e-3), (1e6, 2e-6), (1e12, 1e-11), (1e300, 1e-11)):
        out = moments(np.zeros(2), X, D * np.array([math.cos(a), math.sin(a)]))
        np.testing.assert_allclose(out[:2], half, atol=tol * l1)
        assert abs(out[2]) <= 10 / D * l1 and np.all(np.isfinite(out[:9]))


def grid_of_degenerate_inputs():
    Xs = [np.eye(2), ellipse_to_matrix([4.0, 1e-7], 0.3), np.zeros((2, 2)), ellipse_to_matrix([1e-30, 1e-31], 1.0),
          ellipse_to_matrix([1e150, 1.0], -0.5), np.array([[1.0, 2.0], [2.0, 1.0]])]     # last: indefinite
    for X in Xs:
        for d in ([0.0, 0.0], [1e-300, 0.0], [0.5, 0.0], [1.0, 0.0], [1.0 + 1e-12, 0.0], [0.0, -1.0],
                  [1e6, -2e6], [1e300, 1e300], [-1.7e308, 1.7e308], [5e-324, -5e-324]):
            yield np.array(d, float), X


def test_never_nan_or_inf():
    for d, X in grid_of_degenerate_inputs():
        for out in (pv.arc_moments(d[0], d[1], X[0, 0], X[0, 1], X[1, 1]),
                    pv.tangent_points(d[0], d[1], X[0, 0], X[0, 1], X[1, 1]),
                    pv.arc_mean_shape_jacobian(d[0], d[1], 0.7, math.sqrt(abs(X[0, 0])), math.sqrt(abs(X[1, 1])))):
            assert np.all(np.isfinite(np.array(out[:-1], float))), (d, X, out)


def test_clamping_inside_and_on_the_outline():
    """|q| < R_MIN: flagged, the arc of the floor, zero radial derivative (G d = 0), continuous at the floor."""
    X = ellipse_to_matrix([2.0, 1.0], 0.6)
    a = 2.2
    floor = moments(np.zeros(2), X, sensor_at(np.zeros(2), X, a, pv.R_MIN * (1 + 1e-12)))
    for qn in (0.0, 1e-9, 0.5, 1.0, pv.R_MIN * (1 - 1e-12)):
        d = sensor_at(np.zeros(2), X, a, qn)
        out = moments(np.zeros(2), X, d)
        assert out[9] is True
        G = np.array(out[2:6]).reshape(2, 2)
        np.testing.assert_allclose(G @ d, 0.0, atol=1e-12)
        if qn > 0:
            np.testing.assert_allclose(out[:2], floor[:2], atol=1e-9)
            np.testing.assert_allclose(out[6:9], floor[6:9], atol=1e-9)
    assert floor[9] is False
    # d = 0 looks along the +l1 axis of the principal frame
    out = moments(np.zeros(2), X, np.zeros(2))
    g_dir = np.array(out[:2]) / np.linalg.norm(out[:2])
    assert abs(g_dir @ rot(0.6)[:, 0]) == pytest.approx(1.0, abs=1e-9)


@settings(derandomize=True, max_examples=200, deadline=None)
@given(axes=st.tuples(st.floats(0.05, 20), st.floats(0.05, 20)), o=st.floats(-4, 4),
       a=st.floats(-4, 4), qn=st.floats(1e-6, 1e4))
def test_mean_is_on_the_sensor_side_inside_the_ellipse(axes, o, a, qn):
    """Every visible point has u . q > 1, so c . q_hat >= 1 / max(|q|, R_MIN) and |c| <= 1; S is PSD."""
    X = ellipse_to_matrix(axes, o)
    d = sensor_at(np.zeros(2), X, a, qn)
    out = moments(np.zeros(2), X, d)
    Linv = np.linalg.inv(sqrtm_spd(X))
    c = Linv @ np.array(out[:2])
    qhat = np.array([math.cos(a), math.sin(a)])
    assert c @ qhat >= 1.0 / max(qn, pv.R_MIN) - 1e-9
    assert c @ c <= 1.0 + 1e-9
    assert np.linalg.eigvalsh(np.array([[out[6], out[7]], [out[7], out[8]]]))[0] >= -1e-12 * max(axes) ** 2
    assert out[9] == (qn < pv.R_MIN * (1 - 1e-9)) or abs(qn - pv.R_MIN) < 1e-6


def test_compiled_kernels_equal_the_python_ones():
    from conftest import require

    require("numba")
    from radarslam.extent import _compiled

    rng = np.random.default_rng(3)
    for _ in range(50):
        X = ellipse_to_matrix(rng.uniform(0.3, 5.0, 2), rng.uniform(-3, 3))
        d = rng.normal(scale=rng.choice([0.5, 3.0, 100.0]), size=2)
        for name, args in (("arc_moments", (*d, X[0, 0], X[0, 1], X[1, 1])),
                           ("tangent_points", (*d, X[0, 0], X[0, 1], X[1, 1])),
                           ("arc_mean_shape_jacobian", (*d, 0.3, 2.0, 0.6))):
            a = np.array(getattr(pv, name)(*args), float)
            b = np.array(getattr(_compiled, name)(*args), float)
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("p, X, s, match", [
    ([0.0], np.eye(2), [1.0, 0.0], "p: expected shape"),
    ([0.0, 0.0], np.eye(3), [1.0, 0.0], "X: expected shape"),
    ([0.0, 0.0], np.eye(2), [np.nan, 0.0], "s: expected finite"),
    ([0.0, 0.0], [[1.0, 0.5], [0.0, 1.0]], [1.0, 0.0], "X: expected a symmetric"),
    ([0.0, 0.0], np.diag([1.0, 0.0]), [1.0, 0.0], "X: expected a positive definite"),
    ([0.0, 0.0], np.diag([1.0, -1.0]), [1.0, 0.0], "X: expected a positive definite"),
])
def test_input_errors_name_the_argument(p, X, s, match):
    with pytest.raises(InputError, match=match):
        pv.visible_arc_moments(p, X, s)
