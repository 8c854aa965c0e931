"""Gaussian Wasserstein distance (docs/method.md e)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from radarslam.core.errors import InputError
from radarslam.extent import ellipse_to_matrix
from radarslam.metrics.gwd import _gwd, _gwds, gaussian_wasserstein_distance, gaussian_wasserstein_distances

# Rounding in d^2 = ... - 2 sqrt(...) is of order eps * (tr S1 + tr S2); for equal ellipses the
# distance is the square root of that: ~1.5e-8 * sqrt(tr S). Tests of d ~ 0 allow 1e-7 * sqrt(tr S).
ZERO_TOL = 1e-7


def reference_gwd(m1, S1, m2, S2) -> float:
    """docs/method.md e with scipy.linalg.sqrtm, independent of the library's closed form."""
    r1 = scipy.linalg.sqrtm(S1).real
    cross = scipy.linalg.sqrtm(r1 @ S2 @ r1).real
    d2 = np.sum((np.asarray(m1) - m2) ** 2) + np.trace(S1 + S2 - 2 * cross)
    return math.sqrt(max(d2, 0.0))


def random_ellipse(rng: np.random.Generator):
    center = rng.normal(scale=10, size=2)
    X = ellipse_to_matrix(rng.uniform(0.1, 5.0, 2), rng.uniform(0, math.pi))
    return center, X


def test_identical_ellipses_give_zero():
    rng = np.random.default_rng(30)
    for _ in range(100):
        c, X = random_ellipse(rng)
        assert 0.0 <= gaussian_wasserstein_distance(c, X, c, X) <= ZERO_TOL * math.sqrt(np.trace(X))
    c = np.array([1.0, 2.0])
    for X in (np.diag([4.0, 1.0]), np.eye(2), np.zeros((2, 2))):
        assert gaussian_wasserstein_distance(c, X, c, X) == 0.0


def test_pure_translation_gives_centre_distance():
    rng = np.random.default_rng(31)
    for _ in range(100):
        c, X = random_ellipse(rng)
        shift = rng.normal(scale=3, size=2)
        d = gaussian_wasserstein_distance(c, X, c + shift, X)
        assert d == pytest.approx(np.linalg.norm(shift), rel=1e-9)


def test_coaxial_closed_form():
    rng = np.random.default_rng(32)
    for _ in range(100):
        o = rng.uniform(0, math.pi)
        ax1, ax2 = rng.uniform(0.1, 5, 2), rng.uniform(0.1, 5, 2)
        m1, m2 = rng.normal(size=2), rng.normal(size=2)
        d = gaussian_wasserstein_distance(m1, ellipse_to_matrix(ax1, o), m2, ellipse_to_matrix(ax2, o))
        expected = math.sqrt(np.sum((m1 - m2) ** 2) + (ax1[0] - ax2[0]) ** 2 + (ax1[1] - ax2[1]) ** 2)
        assert d == pytest.approx(expected, rel=1e-9, abs=ZERO_TOL * 5)


def test_paper_magnitude_example():
    """docs/method.md h.9: a converged (L/sqrt3, W/sqrt3) estimate against a 'full' (L, W) 4 x 2 car."""
    d = gaussian_wasserstein_distance([0, 0], ellipse_to_matrix([4 / math.sqrt(3), 2 / math.sqrt(3)], 0),
                                      [0, 0], ellipse_to_matrix([4, 2], 0))
    assert d == pytest.approx(math.hypot(4 - 4 / math.sqrt(3), 2 - 2 / math.sqrt(3)), rel=1e-12)
    assert d == pytest.approx(1.9, abs=0.01)


def test_matches_sqrtm_reference_on_random_inputs():
    rng = np.random.default_rng(33)
    for _ in range(500):
        (m1, X1), (m2, X2) = random_ellipse(rng), random_ellipse(rng)
        assert gaussian_wasserstein_distance(m1, X1, m2, X2) == pytest.approx(reference_gwd(m1, X1, m2, X2), abs=1e-9)


def test_matches_reference_on_singular_and_circular_extents():
    rng = np.random.default_rng(34)
    for _ in range(100):
        m1, m2 = rng.normal(size=2), rng.normal(size=2)
        o1, o2 = rng.uniform(0, math.pi, 2)
        X1 = ellipse_to_matrix([rng.uniform(0.5, 3), 0.0], o1)   # a segment
        X2 = ellipse_to_matrix([1.5, 1.5], o2)                    # a circle
        # eigh-based root for the singular X1 (sqrtm warns on singular input)
        lam, U = np.linalg.eigh(X1)
        r1 = (U * np.sqrt(np.maximum(lam, 0))) @ U.T
        lam2, U2 = np.linalg.eigh(r1 @ X2 @ r1)
        tr_cross = np.sum(np.sqrt(np.maximum(lam2, 0)))
        ref = math.sqrt(np.sum((m1 - m2) ** 2) + np.trace(X1) + np.trace(X2) - 2 * tr_cross)
        assert gaussian_wasserstein_distance(m1, X1, m2, X2) == pytest.approx(ref, abs=1e-7)


def test_vectorised_equals_scalar():
    rng = np.random.default_rng(35)
    n = 50
    pairs = [(random_ellipse(rng), random_ellipse(rng)) for _ in range(n)]
    c1 = np.array([p[0][0] for p in pairs])
    X1 = np.array([p[0][1] for p in pairs])
    c2 = np.array([p[1][0] for p in pairs])
    X2 = np.array([p[1][1] for p in pairs])
    X2[0] = X1[0]
    c2[0] = c1[0]
    d = gaussian_wasserstein_distances(c1, X1, c2, X2)
    assert d.shape == (n,)
    for i in range(n):
        assert d[i] == pytest.approx(gaussian_wasserstein_distance(c1[i], X1[i], c2[i], X2[i]), rel=1e-12, abs=1e-12)
        assert _gwd(c1[i], X1[i], c2[i], X2[i]) == gaussian_wasserstein_distance(c1[i], X1[i], c2[i], X2[i])
    np.testing.assert_array_equal(_gwds(c1, X1, c2, X2), d)
    assert gaussian_wasserstein_distances(np.empty((0, 2)), np.empty((0, 2, 2)),
                                          np.empty((0, 2)), np.empty((0, 2, 2))).shape == (0,)


ellipses = st.tuples(
    st.floats(-20, 20), st.floats(-20, 20),      # centre
    st.floats(0.0, 8.0), st.floats(0.0, 8.0),    # semi-axes
    st.floats(0.0, math.pi),                      # orientation
)


def _unpack(e):
    return np.array(e[:2]), ellipse_to_matrix(e[2:4], e[4])


@settings(derandomize=True, max_examples=200, deadline=None)
@given(ellipses, ellipses, ellipses)
def test_gwd_is_a_metric(e1, e2, e3):
    (m1, X1), (m2, X2), (m3, X3) = _unpack(e1), _unpack(e2), _unpack(e3)
    d12 = gaussian_wasserstein_distance(m1, X1, m2, X2)
    d21 = gaussian_wasserstein_distance(m2, X2, m1, X1)
    d13 = gaussian_wasserstein_distance(m1, X1, m3, X3)
    d23 = gaussian_wasserstein_distance(m2, X2, m3, X3)
    assert d12 >= 0.0
    # triangle inequality, up to the rounding floor ZERO_TOL * sqrt(tr S) of each term
    slack = 3 * ZERO_TOL * math.sqrt(1 + np.trace(X1) + np.trace(X2) + np.trace(X3))
    assert d12 == d21  # the closed form is evaluated symmetrically, so exactly
    assert d13 <= d12 + d23 + slack
    assert d12 <= d13 + d23 + slack


@pytest.mark.parametrize("name, value", [
    ("center1", np.zeros(3)),
    ("center1", np.array([np.nan, 0.0])),
    ("X1", np.array([[1.0, np.nan], [np.nan, 1.0]])),
    ("X1", np.array([[1.0, 2.0], [2.0, 1.0]])),
    ("X1", np.eye(3)),
    ("center2", [[0.0, 0.0]]),
    ("X2", np.diag([1.0, -1.0])),
    ("X2", np.array([[1.0, 0.0], [0.5, 1.0]])),
])
def test_bad_input_raises(name, value):
    kwargs = dict(center1=np.zeros(2), X1=np.eye(2), center2=np.ones(2), X2=np.eye(2))
    kwargs[name] = value
    with pytest.raises(InputError, match=name):
        gaussian_wasserstein_distance(**kwargs)


@pytest.mark.parametrize("name, value", [
    ("centers1", np.zeros((2, 3))),
    ("X1s", np.zeros((3, 2, 2))),                       # length mismatch
    ("X1s", np.array([np.diag([1.0, -1.0])] * 2)),
    ("centers2", np.zeros((3, 2))),
    ("X2s", np.array([[[1.0, np.nan], [np.nan, 1.0]]] * 2)),
    ("X2s", np.array([[[1.0, 0.4], [0.0, 1.0]]] * 2)),
])
def test_vectorised_bad_input_raises(name, value):
    kwargs = dict(centers1=np.zeros((2, 2)), X1s=np.array([np.eye(2)] * 2),
                  centers2=np.ones((2, 2)), X2s=np.array([np.eye(2)] * 2))
    kwargs[name] = value
    with pytest.raises(InputError, match=name):
        gaussian_wasserstein_distances(**kwargs)
