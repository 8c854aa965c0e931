"""The visible arc's mean and spread with their analytic derivatives over the log-matrix shape
(docs/method.md a.12.9 [PROP]).

The partial-view shape estimator (a.12.7) and the model error of the shape's uncertainty (a.12.5)
need ``dg/dxi`` and ``dS/dxi`` for the shape ``X = expm(A)``, ``xi = (A11, A12, A22)``. This
module gives them with the values in one quadrature pass over the arc (:func:`arc_xi_rows`),
instead of six more evaluations of :func:`~radarslam.extent.partial_view.arc_moments` per
central-difference Jacobian. The outline is ``p + F v(tau)`` for any ``F`` with ``F F^T = X``;
the perturbation ``dF = dX F^-T / 2`` (regular at a circle, unlike one through the orientation)
moves the arc's ends (Leibniz' rule, a.12.3 eq. (8)) and its arc-length weight, whose derivative
brings in the ``1/w``-weighted sums of :func:`arc_inverse_sums`; ``dX`` is the Daleckii-Krein
derivative of the symmetric matrix exponential.

Kernels: plain floats and small arrays in the subset of Python that numba compiles
(:mod:`radarslam.extent._compiled` and :mod:`radarslam.slam._view_compiled` compile them with
:func:`radarslam.core.jit.compile_kernels`).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.extent.partial_view import (GL_NODES, GL_WEIGHTS, _rotate2, _scaled_frame, arc_geometry, arc_node,
                                           arc_pieces, principal_frame)


def arc_inverse_sums(phi: float, b: float, l1: float, l2: float, nodes: np.ndarray, weights: np.ndarray):
    """``T_ab = int cos^a sin^b / w`` over ``tau in (phi - b, phi + b)`` for ``a + b`` = 2, 3, 4
    (a.12.9 eq. (20)), on the pieces of :func:`~radarslam.extent.partial_view.arc_pieces` with
    the Gauss-Legendre ``nodes`` and ``weights`` each: ``(T20, T11, T02, T30, T21, T12, T03, T40,
    T31, T22, T13, T04)``. A kernel."""
    f0, e0, g0, f1, e1, g1 = arc_pieces(phi, b, l1, l2)
    a1 = l1 * l1
    a2 = l2 * l2
    T20 = T11 = T02 = T30 = T21 = T12 = T03 = T40 = T31 = T22 = T13 = T04 = 0.0
    for piece in range(2):
        f = f0 if piece == 0 else f1
        span = (e0 if piece == 0 else e1) - f
        graded = g0 if piece == 0 else g1
        for k in range(nodes.shape[0]):
            t, hw = arc_node(f, span, graded, nodes[k], weights[k])
            c = math.cos(t)
            s = math.sin(t)
            iw = hw / math.sqrt(a1 * s * s + a2 * c * c)
            cc = iw * c * c
            cs = iw * c * s
            ss = iw * s * s
            T20 += cc
            T11 += cs
            T02 += ss
            T30 += cc * c
            T21 += cc * s
            T12 += ss * c
            T03 += ss * s
            T40 += cc * c * c
            T31 += cc * c * s
            T22 += cc * s * s
            T13 += ss * s * c
            T04 += ss * s * s
    return T20, T11, T02, T30, T21, T12, T03, T40, T31, T22, T13, T04


def _direction(k: int, co: float, so: float, l1: float, l2: float, gam: float):
    """``E = R^T dF`` (a.12.9 eq. (22)) of the shape direction ``xi_k``: ``(E00, E01, E10, E11)``.
    A kernel."""
    if k == 0:
        P00, P01, P11 = co * co, -co * so, so * so
    elif k == 1:
        P00, P01, P11 = 2.0 * co * so, co * co - so * so, -2.0 * co * so
    else:
        P00, P01, P11 = so * so, co * so, co * co
    return 0.5 * l1 * P00, 0.5 * gam * P01 / l2, 0.5 * gam * P01 / l1, 0.5 * l2 * P11


def _mean_jacobian(co: float, so: float, l1: float, l2: float, pa0: float, pa1: float, pe0: float, pe1: float,
                   fx: float, fy: float, rx: float, ry: float, h: np.ndarray) -> None:
    """``h[5:9] = G = dg/dd`` (a.12.3 eqs. (8)-(13)) from the end terms ``pa = w_a (v_a - c)`` and
    ``pe = w_e (v_e - c)`` of Leibniz' rule and the gradients ``dphi/dq = (fx, fy)``,
    ``db/dq = (rx, ry)`` of :func:`~radarslam.extent.partial_view.arc_geometry`, as
    :func:`~radarslam.extent.partial_view.arc_moments` forms it. A kernel."""
    dphi0 = pa0 - pe0
    dphi1 = pa1 - pe1
    db0 = pa0 + pe0
    db1 = pa1 + pe1
    C00 = dphi0 * fx + db0 * rx                          # eq. (11): C = dc/dq
    C01 = dphi0 * fy + db0 * ry
    C10 = dphi1 * fx + db1 * rx
    C11 = dphi1 * fy + db1 * ry
    G00, G01, G10, G11 = _rotate2(co, so, C00, C01 * l1 / l2, C10 * l2 / l1, C11)   # eq. (13): R Lam C Lam^-1 R^T
    h[5] = G00
    h[6] = G01
    h[7] = G10
    h[8] = G11


def arc_xi_rows(dx: float, dy: float, X11: float, X12: float, X22: float, h: np.ndarray, H: np.ndarray) -> bool:
    """The visible arc's mean offset ``g`` and spread ``S`` (a.12.2 eq. (6)) of the shape ``X``
    (entries ``X11, X12, X22``) seen along ``d = (dx, dy)``, and their derivatives over the
    log-matrix shape ``xi`` of ``X = expm(A)`` (a.12.9): ``h[:5] = (g0, g1, S00, S01, S11)`` and
    ``H[:5, :3] = dh/dxi``, in place; when ``h`` has 9 entries, also the mean's Jacobian
    ``G = dg/dd`` (a.12.3 eq. (13)) in ``h[5:9] = (G00, G01, G10, G11)``, from the arc's end
    terms the pass has (a.12.9 "SLAM's terms from the same pass"). Returns the clamp flag of
    a.12.3 eq. (14) (the derivatives are then the clamped model's). A kernel."""
    return arc_xi_rows_on(dx, dy, X11, X12, X22, h, H, GL_NODES, GL_WEIGHTS)


def arc_xi_rows_on(dx: float, dy: float, X11: float, X12: float, X22: float, h: np.ndarray, H: np.ndarray,
                   nodes: np.ndarray, weights: np.ndarray) -> bool:
    """:func:`arc_xi_rows` with the Gauss-Legendre ``nodes`` and ``weights`` per piece (the
    accuracy tests pass other orders). A kernel."""
    co, so, l1, l2 = principal_frame(X11, X12, X22)
    e1, e2, m = _scaled_frame(dx, dy, co, so)
    phi, b, qn0, qn1, fx, fy, rx, ry, clamped = arc_geometry(e1, e2, m, l1, l2)
    T20, T11, T02, T30, T21, T12, T03, T40, T31, T22, T13, T04 = arc_inverse_sums(phi, b, l1, l2, nodes, weights)
    a1 = l1 * l1
    a2 = l2 * l2
    D = a1 * T02 + a2 * T20                                   # eq. (21): w = (l1^2 s^2 + l2^2 c^2) / w
    c0 = (a1 * T12 + a2 * T30) / D
    c1 = (a1 * T03 + a2 * T21) / D
    V00 = max((a1 * T22 + a2 * T40) / D - c0 * c0, 0.0)
    V01 = (a1 * T13 + a2 * T31) / D - c0 * c1
    V11 = max((a1 * T04 + a2 * T22) / D - c1 * c1, 0.0)
    g0, g1 = l1 * c0, l2 * c1
    h[0] = co * g0 - so * g1
    h[1] = so * g0 + co * g1
    S00, S01, _, S11 = _rotate2(co, so, a1 * V00, l1 * l2 * V01, l1 * l2 * V01, a2 * V11)
    h[2], h[3], h[4] = S00, S01, S11
    # the arc's ends (eq. (8)): v and w there, relative to the mean
    ca, sa = math.cos(phi + b), math.sin(phi + b)
    ce, se = math.cos(phi - b), math.sin(phi - b)
    wa = math.sqrt(a1 * sa * sa + a2 * ca * ca) / D
    we = math.sqrt(a1 * se * se + a2 * ce * ce) / D
    ua0, ua1, ue0, ue1 = ca - c0, sa - c1, ce - c0, se - c1
    if h.shape[0] >= 9:
        _mean_jacobian(co, so, l1, l2, wa * ua0, wa * ua1, we * ue0, we * ue1, fx, fy, rx, ry, h)
    rn = math.hypot(qn0, qn1)
    hq0 = qn0 / rn
    hq1 = qn1 / rn
    dl = math.log(l1 / l2)
    gam = l1 * l2 * (math.sinh(dl) / dl if dl > 1e-12 else 1.0)      # eq. (23): Daleckii-Krein
    for k in range(3):
        E00, E01, E10, E11 = _direction(k, co, so, l1, l2, gam)
        # eq. (24): dq = -Lam^-1 E q turns phi by -hp^T Lam^-1 E hq (also when clamped, eq. (14)) and
        # moves b by -db/dr hq^T Lam^-1 E q; the ends' weights al, ae
        u0 = (E00 * hq0 + E01 * hq1) / l1
        u1 = (E10 * hq0 + E11 * hq1) / l2
        dphi = hq1 * u0 - hq0 * u1
        db = -(((rx * u0 + ry * u1) * rn) * m)                 # |q| = rn m, never overflowing
        al = wa * (dphi + db)
        ae = we * (dphi - db)
        # eq. (25): the weight's change dw = (es s^2 + ex s c + ec c^2) / w
        es = l1 * E00
        ex = -(l1 * E01 + l2 * E10)
        ec = l2 * E11
        Z0 = es * T02 + ex * T11 + ec * T20
        Z10 = es * T12 + ex * T21 + ec * T30
        Z11 = es * T03 + ex * T12 + ec * T21
        Z200 = es * T22 + ex * T31 + ec * T40
        Z201 = es * T13 + ex * T22 + ec * T31
        Z211 = es * T04 + ex * T13 + ec * T22
        dc0 = al * ua0 - ae * ue0 + (Z10 - c0 * Z0) / D
        dc1 = al * ua1 - ae * ue1 + (Z11 - c1 * Z0) / D
        dV00 = (al * (ua0 * ua0 - V00) - ae * (ue0 * ue0 - V00)
                + (Z200 - 2.0 * c0 * Z10 + c0 * c0 * Z0 - V00 * Z0) / D)
        dV01 = (al * (ua0 * ua1 - V01) - ae * (ue0 * ue1 - V01)
                + (Z201 - c0 * Z11 - c1 * Z10 + c0 * c1 * Z0 - V01 * Z0) / D)
        dV11 = (al * (ua1 * ua1 - V11) - ae * (ue1 * ue1 - V11)
                + (Z211 - 2.0 * c1 * Z11 + c1 * c1 * Z0 - V11 * Z0) / D)
        # eq. (26): dg' = E c + Lam dc, dS' = K + K^T + Lam dV Lam with K = E V Lam
        p0 = E00 * c0 + E01 * c1 + l1 * dc0
        p1 = E10 * c0 + E11 * c1 + l2 * dc1
        K00 = (E00 * V00 + E01 * V01) * l1
        K01 = (E00 * V01 + E01 * V11) * l2
        K10 = (E10 * V00 + E11 * V01) * l1
        K11 = (E10 * V01 + E11 * V11) * l2
        s01 = K01 + K10 + l1 * l2 * dV01
        H[0, k] = co * p0 - so * p1
        H[1, k] = so * p0 + co * p1
        d00, d01, _, d11 = _rotate2(co, so, 2.0 * K00 + a1 * dV00, s01, s01, 2.0 * K11 + a2 * dV11)
        H[2, k] = d00
        H[3, k] = d01
        H[4, k] = d11
    return clamped


#: The kernels of this module (compiled with the arc kernels).
KERNELS = (arc_inverse_sums, _direction, _mean_jacobian, arc_xi_rows_on, arc_xi_rows)
