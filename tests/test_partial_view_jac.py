"""The visible arc's analytic derivatives over the log-matrix shape (docs/method.md a.12.9,
radarslam.extent.partial_view_jac) and the arc quadrature's accuracy (a.12.2 "Quadrature")."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from radarslam.extent import partial_view as pv
from radarslam.extent.partial_view_jac import arc_xi_rows, arc_xi_rows_on
from radarslam.extent.view_estimator import exp_sym2

#: The reference quadrature: 512 Gauss-Legendre nodes per piece (scripts/partial_view_quadrature.py
#: checks it against scipy's adaptive quad to 4e-15).
REF = np.polynomial.legendre.leggauss(512)


def _xi(log_l1: float, log_l2: float, o: float) -> np.ndarray:
    """The log-matrix shape with semi-axes ``exp(log_l1)``, ``exp(log_l2)``, ``l1`` along ``o``."""
    c, s = math.cos(o), math.sin(o)
    a1, a2 = 2.0 * log_l1, 2.0 * log_l2
    return np.array([c * c * a1 + s * s * a2, c * s * (a1 - a2), s * s * a1 + c * c * a2])


def _view(xi: np.ndarray, qn: float, phi: float) -> tuple[float, float]:
    """``d`` with ``|q| = qn`` in the direction ``phi`` of the principal frame of ``expm(xi)``."""
    co, so, l1, l2 = pv.principal_frame(*exp_sym2(*xi))
    e = np.array([l1 * qn * math.cos(phi), l2 * qn * math.sin(phi)])
    return co * e[0] - so * e[1], so * e[0] + co * e[1]


def _rows(xi, d, nodes=None) -> tuple[np.ndarray, np.ndarray, bool]:
    h, H = np.empty(5), np.empty((5, 3))
    X = exp_sym2(*xi)
    if nodes is None:
        clamped = arc_xi_rows(d[0], d[1], *X, h, H)
    else:
        clamped = arc_xi_rows_on(d[0], d[1], *X, h, H, *nodes)
    return h, H, bool(clamped)


def _value(xi, d) -> np.ndarray:
    """``(g, vech S)`` of the value path (``arc_moments``, the central-difference form's)."""
    r = pv.arc_moments(d[0], d[1], *exp_sym2(*xi))
    return np.array([r[0], r[1], r[6], r[7], r[8]])


def _central(f, xi, step) -> np.ndarray:
    J = np.empty((5, 3))
    for k in range(3):
        e = np.zeros(3)
        e[k] = step
        J[:, k] = (f(xi + e) - f(xi - e)) / (2.0 * step)
    return J


def _richardson(f, xi, step) -> np.ndarray:
    """Fourth-order differences: ``(4 D(step / 2) - D(step)) / 3``."""
    return (4.0 * _central(f, xi, 0.5 * step) - _central(f, xi, step)) / 3.0


def _units(xi) -> np.ndarray:
    """Rows' units: the longer semi-axis (m) for ``g``, its square for ``S``."""
    L = pv.principal_frame(*exp_sym2(*xi))[2]
    return np.array([L, L, L * L, L * L, L * L])[:, None]


shapes = st.tuples(st.floats(-0.5, 1.0), st.floats(0.0, math.log(10.0)), st.floats(0.0, math.pi),
                   st.booleans())
views = st.tuples(st.sampled_from([1.01, 1.1, 1.5, 3.0, 10.0, 1e3]), st.floats(-math.pi, math.pi))


def _case(shape, view):
    log_l1, ratio, o, circle = shape
    xi = _xi(log_l1, log_l1 - (0.0 if circle else ratio), o)
    return xi, _view(xi, *view)


@settings(max_examples=80, deadline=None)
@given(shapes, views)
def test_analytic_derivatives_match_a_fourth_order_difference_oracle(shape, view):
    """With the 512-node reference quadrature on both sides, (22)-(26) equal a Richardson
    difference (step 1e-3, truncation ~1e-12) to 1e-8 of the rows' units, circles included."""
    xi, d = _case(shape, view)
    H = _rows(xi, d, REF)[1]
    oracle = _richardson(lambda x: _rows(x, d, REF)[0], xi, 1e-3)
    assert np.max(np.abs(H - oracle) / _units(xi)) < 1e-8


@settings(max_examples=80, deadline=None)
@given(shapes, views)
def test_analytic_derivatives_match_central_differences_of_the_value_path(shape, view):
    """The shipped kernel (N_NODES) against central differences (step 1e-5) of ``arc_moments``:
    to 1e-6 of the rows' units (differences' error ~1e-10, both quadratures' ~1e-7 at 10:1), and
    its values equal ``arc_moments`` to 1e-8."""
    xi, d = _case(shape, view)
    h, H, clamped = _rows(xi, d)
    assert not clamped
    assert np.max(np.abs(h - _value(xi, d)) / _units(xi)[:, 0]) < 1e-8
    assert np.max(np.abs(H - _central(lambda x: _value(x, d), xi, 1e-5)) / _units(xi)) < 1e-6


@pytest.mark.parametrize("qn", [0.01, 0.3, 0.999])
def test_clamped_views_differentiate_the_clamped_model(qn):
    """Inside the floor of eq. (14) the arc turns with the direction of q and b stays: the
    analytic derivative is the clamped model's own (central differences of it agree)."""
    xi = _xi(0.8, 0.1, 0.7)
    d = _view(xi, qn, 2.0)
    h, H, clamped = _rows(xi, d)
    assert clamped
    assert np.max(np.abs(H - _central(lambda x: _value(x, d), xi, 1e-6)) / _units(xi)) < 1e-6


def test_circle_derivative_closed_form():
    """A circle of radius rho seen from D: growing it (xi0 = xi2 = 2 ln rho up together by t)
    scales rho by exp(t / 2); g = rho sin(b) / b along d with b = acos(rho / D) (a.12.2)."""
    rho, D = 1.5, 4.0
    xi = np.array([2 * math.log(rho), 0.0, 2 * math.log(rho)])
    d = (D, 0.0)
    H = _rows(xi, d)[1]
    b = math.acos(rho / D)
    dg_drho = math.sin(b) / b - rho * (math.cos(b) / b - math.sin(b) / b ** 2) / (D * math.sin(b))
    assert abs((H[0, 0] + H[0, 2]) - 0.5 * rho * dg_drho) < 1e-10
    assert abs(H[1, 0] + H[1, 2]) < 1e-12


# ---------------------------------------------------------------- the quadrature (a.12.2)
def _views_like_the_car_park(rng, n):
    """Semi-axes 0.6-2.6 m with aspect ratios 1-5 (the car park's shape updates: median 2.05,
    largest 4.1 on seed 777, scripts/partial_view_quadrature.py) from |q| = 1.001 to 1e6."""
    out = []
    for _ in range(n):
        l1 = rng.uniform(1.0, 2.6)
        xi = _xi(math.log(l1), math.log(l1 / rng.uniform(1.0, 5.0)), rng.uniform(0, math.pi))
        for qn in (1.001, 1.05, 1.5, 4.0, 10.0, 30.0, 1e6):
            out.append((xi, _view(xi, qn, rng.uniform(-math.pi, math.pi))))
    return out


def _worst(cases, nodes):
    """Largest error against :data:`REF` of the values (``arc_sums_on``) and of the analytic path's
    values and derivatives, in the rows' units."""
    worst = np.zeros(2)
    for xi, d in cases:
        co, so, l1, l2 = pv.principal_frame(*exp_sym2(*xi))
        e1, e2, m = pv._scaled_frame(d[0], d[1], co, so)
        phi, b = pv.arc_geometry(e1, e2, m, l1, l2)[:2]
        a = np.array(pv.arc_sums_on(phi, b, l1, l2, *nodes)[:6])
        r = np.array(pv.arc_sums_on(phi, b, l1, l2, *REF)[:6])
        ca, cr = a[1:3] / a[0], r[1:3] / r[0]
        worst[0] = max(worst[0], np.max(np.abs(ca - cr) * np.array([l1, l2])) / l1,
                       np.max(np.abs(a[3:] / a[0] - r[3:] / r[0])))
        h, H, _ = _rows(xi, d, nodes)
        hr, Hr, _ = _rows(xi, d, REF)
        u = _units(xi)
        worst[1] = max(worst[1], np.max(np.abs(h - hr) / u[:, 0]), np.max(np.abs(H - Hr) / u))
    return worst


def test_quadrature_error_bound_on_the_car_parks_shapes():
    """N_NODES per piece: the mean and spread within 1e-7 of the longer semi-axis (its square) of
    the 512-node reference, their shape derivatives (a.12.9) within 1e-6, on car-park shapes
    (aspect <= 5) and on 10:1 ellipses at near-tangent and vertex-split views; 12 and 16 nodes
    fail the first bound (negative controls: 20 is the smallest count that meets it)."""
    rng = np.random.default_rng(7)
    shipped = (pv.GL_NODES, pv.GL_WEIGHTS)
    bound = np.array([1e-7, 1e-6])
    park = _views_like_the_car_park(rng, 40)
    assert np.all(_worst(park, shipped) < bound)
    hard = []
    for _ in range(30):
        xi = _xi(math.log(2.5), math.log(0.25), rng.uniform(0, math.pi))
        for qn in (1.001, 1.01, 1.1, 2.0, 10.0):
            b = math.acos(1.0 / qn)
            hard.append((xi, _view(xi, qn, rng.uniform(-math.pi, math.pi))))
            hard.append((xi, _view(xi, qn, b + rng.choice([-1e-4, 1e-4]))))     # vertex at an end of the arc
    assert np.all(_worst(hard, shipped) < bound)
    for n in (12, 16):                                                            # negative controls
        assert _worst(park, np.polynomial.legendre.leggauss(n))[0] > bound[0]


def test_compiled_kernels_equal_the_python_ones():
    """extent/_compiled.py and slam/_view_compiled.py compile arc_xi_rows as it is."""
    from conftest import require

    require("numba")
    from radarslam.extent import _compiled

    rng = np.random.default_rng(5)
    for _ in range(30):
        xi = _xi(rng.uniform(-0.5, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(0, math.pi))
        d = rng.uniform(-8, 8, 2)
        h, H, cl = _rows(xi, d)
        hc, Hc = np.empty(5), np.empty((5, 3))
        clc = _compiled._PV["arc_xi_rows"](d[0], d[1], *exp_sym2(*xi), hc, Hc)
        assert cl == clc and np.allclose(h, hc, rtol=1e-12, atol=1e-14) and np.allclose(H, Hc, rtol=1e-11, atol=1e-13)


def test_one_pass_mean_jacobian_equals_the_value_path():
    """With 9 entries of h, arc_xi_rows adds G = dg/dd (a.12.3 eq. (13)) from its end terms: the
    same G as arc_moments (and the same g and S) to rounding, in view, clamped (sensor inside the
    outline) and at a circle; a 5-entry h is left as it was (G is not written past it)."""
    rng = np.random.default_rng(11)
    cases = [(_xi(0.7, -0.4, 0.3), (0.05, -0.02)), (_xi(0.3, 0.3, 0.0), (4.0, 1.0))]      # clamped, circle
    for _ in range(60):
        xi = _xi(rng.uniform(-0.5, 1.0), rng.uniform(-1.0, 1.0), rng.uniform(0, math.pi))
        cases.append((xi, _view(xi, rng.uniform(1.01, 30.0), rng.uniform(-math.pi, math.pi))))
    worst = 0.0
    for xi, d in cases:
        h, H = np.empty(9), np.empty((5, 3))
        arc_xi_rows(d[0], d[1], *exp_sym2(*xi), h, H)
        r = pv.arc_moments(d[0], d[1], *exp_sym2(*xi))
        ref = np.array([r[0], r[1], r[6], r[7], r[8], r[2], r[3], r[4], r[5]])
        worst = max(worst, float(np.max(np.abs(h - ref))))
        h5, H5 = _rows(xi, d)[:2]
        assert np.array_equal(h5, h[:5]) and np.array_equal(H5, H)
    assert worst < 1e-12
    # negative control: the G of another view direction differs
    h, H = np.empty(9), np.empty((5, 3))
    arc_xi_rows(3.0, 1.0, *exp_sym2(*_xi(0.7, -0.4, 0.3)), h, H)
    r = pv.arc_moments(1.0, 3.0, *exp_sym2(*_xi(0.7, -0.4, 0.3)))
    assert np.max(np.abs(h[5:] - np.array(r[2:6]))) > 1e-3
