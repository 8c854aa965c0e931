"""Ellipse <-> matrix conversions (docs/method.md d.1-d.2) and the 2 x 2 closed-form kernels."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from radarslam.core.errors import InputError
from radarslam.extent import ellipse_to_matrix, li_orientation, matrix_to_ellipse
from radarslam.extent import _sym2

from oracles import floor_eigenvalues, spd_inv_sqrt, spd_sqrt

EPS = np.finfo(float).eps


def rot(o: float) -> np.ndarray:
    return np.array([[math.cos(o), -math.sin(o)], [math.sin(o), math.cos(o)]])


def from_eig(l1: float, l2: float, o: float) -> np.ndarray:
    R = rot(o)
    return R @ np.diag([l1, l2]) @ R.T


def mat(t: tuple[float, float, float]) -> np.ndarray:
    return np.array([[t[0], t[1]], [t[1], t[2]]])


def angle_diff_mod(a: float, b: float, period: float) -> float:
    d = (a - b) % period
    return min(d, period - d)


# --------------------------------------------------------------------------- ellipse <-> matrix


def test_ellipse_to_matrix_matches_rotation_form():
    X = ellipse_to_matrix([3.0, 1.5], 0.7)
    np.testing.assert_allclose(X, from_eig(9.0, 2.25, 0.7), rtol=0, atol=1e-14)
    # written-out entries of docs/method.md d.1
    c, s = math.cos(0.7), math.sin(0.7)
    assert X[0, 0] == pytest.approx(9 * c * c + 2.25 * s * s, abs=1e-14)
    assert X[1, 1] == pytest.approx(9 * s * s + 2.25 * c * c, abs=1e-14)
    assert X[0, 1] == pytest.approx((9 - 2.25) * s * c, abs=1e-14)
    assert X[0, 1] == X[1, 0]


@pytest.mark.parametrize("semi_axes", [(3.0, 1.0), (2.31, 1.15), (0.4, 0.39), (5.0, 1e-3)])
def test_round_trip_over_0_to_180_degrees(semi_axes):
    for deg in np.linspace(0.0, 180.0, 181):
        o = math.radians(deg)
        X = ellipse_to_matrix(semi_axes, o)
        ax, o_back = matrix_to_ellipse(X)
        np.testing.assert_allclose(ax, semi_axes, rtol=1e-9, atol=1e-12)
        assert 0.0 <= o_back < math.pi
        # 180 deg is the same axis as 0 deg
        assert angle_diff_mod(o_back, o, math.pi) < 1e-9 * semi_axes[0] / (semi_axes[0] - semi_axes[1])


def test_minor_first_input_is_reordered():
    X = ellipse_to_matrix([1.0, 3.0], 0.2)  # l1 along 0.2 rad is the minor axis
    ax, o = matrix_to_ellipse(X)
    np.testing.assert_allclose(ax, [3.0, 1.0], rtol=1e-12)
    assert o == pytest.approx(0.2 + math.pi / 2, abs=1e-12)


@pytest.mark.parametrize("radius", [1e-3, 1.0, 2.5, 40.0])
@pytest.mark.parametrize("o", [0.0, 0.3, 1.9, math.pi])
def test_circles_give_equal_axes_and_orientation_zero(radius, o):
    X = ellipse_to_matrix([radius, radius], o)
    ax, o_back = matrix_to_ellipse(X)
    np.testing.assert_allclose(ax, [radius, radius], rtol=1e-12)
    assert o_back == 0.0


def test_degenerate_line_ellipse():
    ax, o = matrix_to_ellipse(ellipse_to_matrix([2.0, 0.0], math.radians(30)))
    np.testing.assert_allclose(ax, [2.0, 0.0], atol=1e-7)
    assert o == pytest.approx(math.radians(30), abs=1e-12)


def _li_matches_eigh(X: np.ndarray) -> None:
    ax_li, o_li = li_orientation(X)
    ax, o = matrix_to_ellipse(X)
    # same ellipse: the reconstructed matrices agree
    np.testing.assert_allclose(ellipse_to_matrix(ax_li, o_li), X, rtol=0, atol=1e-12 * max(1.0, np.abs(X).max()))
    assert 0.0 <= o_li < math.pi / 2
    if ax[0] - ax[1] <= 1e-9 * ax[0]:
        return  # a circle has no orientation to compare
    # same axes: Li's o is the major axis (mod pi) or, with the axes swapped, the minor one
    if ax_li[0] >= ax_li[1]:
        np.testing.assert_allclose(ax_li, ax, rtol=1e-12)
        assert angle_diff_mod(o_li, o, math.pi) < 1e-9
    else:
        np.testing.assert_allclose(ax_li[::-1], ax, rtol=1e-12)
        assert angle_diff_mod(o_li + math.pi / 2, o, math.pi) < 1e-9
    # and modulo pi/2 the two orientations always agree
    assert angle_diff_mod(o_li, o, math.pi / 2) < 1e-9


def test_li_orientation_agrees_with_eigh_over_sweep():
    for deg in np.linspace(0.0, 180.0, 181):
        _li_matches_eigh(ellipse_to_matrix([3.0, 1.2], math.radians(deg)))


def test_li_orientation_agrees_with_eigh_random():
    rng = np.random.default_rng(1)
    for _ in range(300):
        ax = rng.uniform(0.05, 5.0, size=2)
        _li_matches_eigh(ellipse_to_matrix(ax, rng.uniform(-4, 4)))


@pytest.mark.parametrize("x12", [0.0, 1e-17, -1e-17, 1e-13, -1e-13])
@pytest.mark.parametrize("diag", [(4.0, 1.0), (1.0, 4.0), (2.0, 2.0)])
def test_li_orientation_near_zero_x12(x12, diag):
    X = np.array([[diag[0], x12], [x12, diag[1]]])
    _li_matches_eigh(X)
    if x12 == 0.0:
        ax, o = li_orientation(X)
        assert o == 0.0  # the d.2 guard
        np.testing.assert_allclose(ax, np.sqrt(diag), rtol=1e-15)


# --------------------------------------------------------------------------- closed-form kernels


def random_spd(rng: np.random.Generator, kind: str) -> tuple[np.ndarray, float, float]:
    o = rng.uniform(-math.pi, math.pi)
    scale = 10.0 ** rng.uniform(-3, 2)
    if kind == "generic":
        l1, l2 = sorted(scale * rng.uniform(0.01, 1.0, size=2), reverse=True)
    elif kind == "near_singular":
        l1, l2 = scale, scale * 10.0 ** rng.uniform(-10, -6)
    elif kind == "near_circular":
        l1 = scale
        l2 = scale * (1 - 10.0 ** rng.uniform(-12, -6))
    else:  # exactly circular
        l1 = l2 = scale
    return from_eig(l1, l2, o), l1, l2


KINDS = ["generic", "near_singular", "near_circular", "circular"]


@pytest.mark.parametrize("kind", KINDS)
def test_spectral_matches_eigh(kind):
    rng = np.random.default_rng(11)
    for _ in range(200):
        A, _, _ = random_spd(rng, kind)
        l1, l2, p, q = _sym2.spectral(A[0, 0], A[0, 1], A[1, 1])
        lam, U = np.linalg.eigh(A)
        norm = lam[1]
        assert l1 >= l2
        np.testing.assert_allclose([l2, l1], lam, rtol=0, atol=8 * EPS * norm)
        # reconstruct A from the spectral form
        np.testing.assert_allclose(mat(_sym2.from_spectral(l1, l2, p, q)), A, rtol=0, atol=8 * EPS * norm)


def _sqrtm_reliable(l1: float, l2: float) -> bool:
    """Where scipy's Schur-based sqrtm is a fair reference: no eigenvalue clipping (l2 well above
    1e-12) and condition number <= 1e8 (beyond it sqrtm's own error, ~1e-4 relative at 1e10,
    exceeds the eigh-based routine's; those matrices are compared with eigh only)."""
    return l2 > 1e3 * _sym2.EIG_CLIP and l2 >= 1e-8 * l1


def _sqrt_tol(l1: float, l2: float) -> float:
    """Absolute error bound of sqrt(A): eigenvalue error ~ eps * l1, through d sqrt / d l = 1/(2 sqrt l)."""
    return 50 * EPS * (math.sqrt(l1) + l1 / math.sqrt(max(l2, _sym2.EIG_CLIP)))


@pytest.mark.parametrize("kind", KINDS)
def test_sqrt2_matches_scipy_sqrtm_and_eigh(kind):
    rng = np.random.default_rng(12)
    for _ in range(200):
        A, l1, l2 = random_spd(rng, kind)
        S = mat(_sym2.sqrt2(A[0, 0], A[0, 1], A[1, 1]))
        tol = _sqrt_tol(l1, l2)
        np.testing.assert_allclose(S, spd_sqrt(A), rtol=0, atol=tol)
        if _sqrtm_reliable(l1, l2):
            np.testing.assert_allclose(S, scipy.linalg.sqrtm(A).real, rtol=0, atol=tol)
        # S^2 = A, up to rounding and the eigenvalue clip at 1e-12 (h.6)
        np.testing.assert_allclose(S @ S, A, rtol=0, atol=16 * EPS * l1 + _sym2.EIG_CLIP)
        if l2 > _sym2.EIG_CLIP:
            # the textbook closed form (A + s I) / t, s = sqrt(det A), t = sqrt(tr A + 2 s)
            s = math.sqrt(l1 * l2)
            np.testing.assert_allclose(S, (A + s * np.eye(2)) / math.sqrt(np.trace(A) + 2 * s), rtol=0, atol=tol)


@pytest.mark.parametrize("kind", KINDS)
def test_inv_sqrt2_matches_eigh_and_sqrtm(kind):
    rng = np.random.default_rng(13)
    for _ in range(200):
        A, l1, l2 = random_spd(rng, kind)
        T = mat(_sym2.inv_sqrt2(A[0, 0], A[0, 1], A[1, 1]))
        ref = spd_inv_sqrt(A)
        # relative error of the small eigenvalue ~ eps * l1 / l2 propagates at half strength
        tol = 50 * EPS * (l1 / l2) * np.abs(ref).max()
        np.testing.assert_allclose(T, ref, rtol=0, atol=tol)
        if _sqrtm_reliable(l1, l2):
            np.testing.assert_allclose(T, np.linalg.inv(scipy.linalg.sqrtm(A).real), rtol=0, atol=tol)


def test_sqrt_kernels_clip_singular_matrices_like_eigh():
    for A in (np.outer([1.0, 2.0], [1.0, 2.0]), np.zeros((2, 2)), np.diag([3.0, 0.0]),
              np.outer([0.3, -0.1], [0.3, -0.1]) * 1e-13):
        S = mat(_sym2.sqrt2(A[0, 0], A[0, 1], A[1, 1]))
        np.testing.assert_allclose(S, spd_sqrt(A), rtol=0, atol=1e-9)
        T = mat(_sym2.inv_sqrt2(A[0, 0], A[0, 1], A[1, 1]))
        # eigenvalue clip at 1e-12 gives inverse-root eigenvalues up to 1e6
        np.testing.assert_allclose(T, spd_inv_sqrt(A), rtol=1e-6, atol=1e-6)
        assert np.all(np.isfinite(T))


def test_floor2_matches_core_floor_eigenvalues():
    rng = np.random.default_rng(14)
    for kind in KINDS:
        for _ in range(100):
            A, l1, _ = random_spd(rng, kind)
            floor = 10.0 ** rng.uniform(-5, 1)
            F = mat(_sym2.floor2(A[0, 0], A[0, 1], A[1, 1], floor))
            np.testing.assert_allclose(F, floor_eigenvalues(A, floor), rtol=0, atol=16 * EPS * max(l1, floor))
            assert np.linalg.eigvalsh(F)[0] >= floor - 16 * EPS * max(l1, floor)


# --------------------------------------------------------------------------- bad input


@pytest.mark.parametrize("func", [matrix_to_ellipse, li_orientation])
@pytest.mark.parametrize("bad", [
    np.array([[1.0, np.nan], [np.nan, 1.0]]),     # NaN
    np.array([[1.0, 2.0], [2.0, 1.0]]),           # symmetric, eigenvalue -1
    np.array([[1.0, 0.5], [0.0, 1.0]]),           # not symmetric
    np.eye(3),                                    # wrong shape
    np.ones(4),                                   # wrong shape
])
def test_matrix_functions_reject_bad_X(func, bad):
    with pytest.raises(InputError, match="X"):
        func(bad)


@pytest.mark.parametrize("semi_axes, orientation, name", [
    ([1.0, 2.0, 3.0], 0.0, "semi_axes"),
    ([1.0, np.nan], 0.0, "semi_axes"),
    ([-1.0, 2.0], 0.0, "semi_axes"),
    ([1.0, 2.0], np.inf, "orientation"),
    ([1.0, 2.0], "north", "orientation"),
])
def test_ellipse_to_matrix_rejects_bad_input(semi_axes, orientation, name):
    with pytest.raises(InputError, match=name):
        ellipse_to_matrix(semi_axes, orientation)
