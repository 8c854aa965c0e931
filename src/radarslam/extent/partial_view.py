"""The partial-view measurement model of an elliptical landmark (docs/method.md a.12 [PROP]).

A radar sees only the part of an object's outline that faces it, so the mean of a landmark's
detections is not its centroid: it lies between the centroid and the sensor. For a landmark with
centroid ``p`` and extent ``X`` (the ellipse ``(y - p)^T X^-1 (y - p) = 1``, :mod:`.ellipse`) seen
from the sensor position ``s``, with detections uniform by arc length on the visible arc, this
module gives the mean offset ``g = E[y] - p``, its Jacobian ``G = dg/dd`` with ``d = s - p``, the
covariance ``S = Cov[y]`` of the detection sources (no sensor noise), the tangent points, and the
derivatives of ``g`` with respect to the ellipse's orientation and log semi-axes.

Everything is computed in the ellipse's principal frame, ``X = R(o) diag(l1^2, l2^2) R(o)^T``,
where the outline is ``y = p + R(o) diag(l1, l2) v(tau)``, ``v = (cos tau, sin tau)``, and the
integrals over the visible arc ``tau in (phi - b, phi + b)`` use fixed Gauss-Legendre nodes
(:data:`N_NODES` per piece, two pieces split at the vertex of the long axis when it is in view).

The functions without a leading ``visible_arc`` are kernels: plain floats in, a tuple of floats
out, in the subset of Python that numba compiles (:mod:`radarslam.extent._compiled` compiles them
with :func:`radarslam.core.jit.compile_kernels`). They do no validation and return finite numbers
for any finite input. :func:`visible_arc_moments` and :func:`visible_arc_shape_jacobian` are the
validated numpy wrappers.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.validation import as_array, as_scalar
from radarslam.extent._sym2 import spectral

#: Gauss-Legendre nodes per piece of the visible arc (two pieces); docs/method.md a.12.2 "Quadrature":
#: the smallest count within 1e-7 of the longer semi-axis (values) and 1e-6 (shape derivatives, a.12.9)
#: of a 512-node reference on shapes of aspect ratio up to 5 (tests/test_partial_view_jac.py).
N_NODES = 20
_GL_X, _GL_W = np.polynomial.legendre.leggauss(N_NODES)
#: Nodes and weights on [-1, 1], module constants (numba freezes them at compilation).
GL_NODES = np.ascontiguousarray(_GL_X)
GL_WEIGHTS = np.ascontiguousarray(_GL_W)

#: Floor of ``|q|`` (docs/method.md a.12 eq. (14)): below it the sensor is treated as at the floor.
R_MIN = 1.001
#: Relative and absolute floors of the eigenvalues of ``X`` (m^2), docs/method.md a.12 eq. (15).
EIG_REL = 1e-10
EIG_ABS = 1e-20


def principal_frame(X11: float, X12: float, X22: float) -> tuple[float, float, float, float]:
    """``(cos o, sin o, l1, l2)`` of ``X = R(o) diag(l1^2, l2^2) R(o)^T`` with ``l1 >= l2`` and the
    eigenvalues floored at ``max(EIG_REL l1^2, EIG_ABS)`` (docs/method.md a.12 eq. (15)); ``o = 0``
    for a multiple of the identity."""
    e1, e2, c2, s2 = spectral(X11, X12, X22)
    if not e1 > EIG_ABS:
        e1 = EIG_ABS
    lo = EIG_REL * e1
    if lo < EIG_ABS:
        lo = EIG_ABS
    if not e2 > lo:
        e2 = lo
    co = math.sqrt(max(0.5 * (1.0 + c2), 0.0))
    so = math.sqrt(max(0.5 * (1.0 - c2), 0.0))
    if s2 < 0.0:
        so = -so
    return co, so, math.sqrt(e1), math.sqrt(e2)


def arc_geometry(e1: float, e2: float, scale: float, l1: float,
                 l2: float) -> tuple[float, float, float, float, float, float, float, float, bool]:
    """Visible arc of the principal-frame ellipse ``diag(l1^2, l2^2)`` from ``d' = scale (e1, e2)``.

    ``(e1, e2)`` is the principal-frame sensor offset divided by ``scale > 0`` (so that huge
    inputs never overflow), or ``(0, 0)`` with ``scale = 1``. Returns ``(phi, b, qn0, qn1, fx, fy,
    rx, ry, clamped)``: the arc ``(phi - b, phi + b)`` (docs/method.md a.12 eqs. (3)-(4)),
    ``qn = q / scale`` and the gradients ``dphi/dq = (fx, fy)`` and ``db/dq = (rx, ry)`` with the
    clamping rule of eq. (14).
    """
    qn0 = e1 / l1
    qn1 = e2 / l2
    rn = math.hypot(qn0, qn1)
    if rn == 0.0:                      # d = 0: look along the +l1 axis (docs/method.md a.12 eq. (16))
        rn = 1.0
        qn0 = 1.0
        qn1 = 0.0
        inv = math.inf
    elif scale < 1.0:                  # 1 / |q| never overflows: 5e-155 <= rn <= 2e10 by eq. (15)
        r = rn * scale
        inv = math.inf if r < R_MIN else 1.0 / r
    else:
        inv = (1.0 / rn) / scale
    h0 = qn0 / rn
    h1 = qn1 / rn
    phi = math.atan2(h1, h0)
    if inv > 1.0 / R_MIN:              # eq. (14): clamp to the floor, zero radial derivative
        return phi, math.acos(1.0 / R_MIN), qn0, qn1, -h1 / R_MIN, h0 / R_MIN, 0.0, 0.0, True
    b = math.acos(inv)
    dbdr = inv * inv / math.sqrt((1.0 - inv) * (1.0 + inv))   # eq. (10), 1 / (r sqrt(r^2 - 1))
    return phi, b, qn0, qn1, -h1 * inv, h0 * inv, dbdr * h0, dbdr * h1, False


def arc_pieces(phi: float, b: float, l1: float, l2: float):
    """The two quadrature pieces of the arc ``(phi - b, phi + b)`` (docs/method.md a.12.2 eq. (7)):
    ``(f0, e0, g0, f1, e1, g1)``, piece ``k`` from ``fk`` to ``ek``, graded towards ``fk`` when
    ``gk``. Split at the point ``f`` of the arc nearest the vertex of the longer axis, where the
    weight is sharpest: at the vertex when it is in view (both pieces graded towards it), else at
    ``phi`` with only the piece ending at ``f`` (an end of the arc) graded. A kernel."""
    vert = 0.0 if l1 >= l2 else 0.5 * math.pi
    dv = vert - phi
    dv = math.atan2(math.sin(dv), math.cos(dv))          # to (-pi, pi]
    if dv > 0.5 * math.pi:                               # the vertex nearer phi (they are pi apart)
        dv -= math.pi
    elif dv < -0.5 * math.pi:
        dv += math.pi
    if abs(dv) < b:
        return phi + dv, phi - b, True, phi + dv, phi + b, True
    sg = 1.0 if dv > 0.0 else -1.0
    return phi + sg * b, phi, True, phi, phi - sg * b, False


def arc_node(f: float, span: float, graded: bool, x: float, wt: float) -> tuple[float, float]:
    """``(tau, weight)`` of the Gauss-Legendre node ``x in [-1, 1]`` with weight ``wt`` on the piece
    from ``f`` over ``span`` (eq. (7): ``tau = f + span u^2`` when graded, ``u = (1 + x) / 2``). A kernel."""
    u = 0.5 * (1.0 + x)
    if graded:
        return f + span * u * u, abs(span) * u * wt          # dtau = 2 |span| u du, du = dx / 2
    return f + span * u, 0.5 * abs(span) * wt


def arc_sums_on(phi: float, b: float, l1: float, l2: float, nodes: np.ndarray, weights: np.ndarray):
    """:func:`arc_sums` with the Gauss-Legendre ``nodes`` and ``weights`` on [-1, 1] per piece
    (the accuracy tests and scripts/partial_view_quadrature.py pass other orders). A kernel."""
    f0, e0, g0, f1, e1, g1 = arc_pieces(phi, b, l1, l2)
    D = N0 = N1 = M00 = M01 = M11 = A1 = B10 = B11 = 0.0
    a1 = l1 * l1
    a2 = l2 * l2
    for piece in range(2):
        f = f0 if piece == 0 else f1
        span = (e0 if piece == 0 else e1) - f
        graded = g0 if piece == 0 else g1
        for k in range(nodes.shape[0]):
            t, hw = arc_node(f, span, graded, nodes[k], weights[k])
            c = math.cos(t)
            s = math.sin(t)
            w = math.sqrt(a1 * s * s + a2 * c * c)
            ww = hw * w
            D += ww
            N0 += ww * c
            N1 += ww * s
            M00 += ww * c * c
            M01 += ww * c * s
            M11 += ww * s * s
            w1 = hw * a1 * s * s / w
            A1 += w1
            B10 += w1 * c
            B11 += w1 * s
    return D, N0, N1, M00, M01, M11, A1, B10, B11


def arc_sums(phi: float, b: float, l1: float, l2: float) -> tuple[float, float, float, float, float, float,
                                                                   float, float, float]:
    """Quadrature of the arc integrals of docs/method.md a.12 eqs. (5)-(6) and (12).

    Returns ``(D, N0, N1, M00, M01, M11, A1, B10, B11)``: ``D = int w``, ``N = int v w``,
    ``M = int v v^T w``, ``A1 = int w_1`` and ``B1 = int v w_1`` with ``w_1 = l1^2 sin^2 / w``, over
    ``tau in (phi - b, phi + b)``, on the two pieces of :func:`arc_pieces` with :data:`N_NODES`
    Gauss-Legendre nodes each.
    """
    return arc_sums_on(phi, b, l1, l2, GL_NODES, GL_WEIGHTS)


def arc_frame_moments(e1: float, e2: float, scale: float, l1: float, l2: float):
    """Principal-frame moments: ``(c0, c1, C00, C01, C10, C11, V00, V01, V11, k10, k11, qn0, qn1,
    clamped)`` with the normalised mean ``c`` (eq. (6)), ``C = dc/dq`` (eqs. (8)-(11)), the
    normalised covariance ``V = M / D - c c^T`` and ``k1 = dc/dlog l1`` at fixed ``q`` (eq. (12))."""
    phi, b, qn0, qn1, fx, fy, rx, ry, clamped = arc_geometry(e1, e2, scale, l1, l2)
    D, N0, N1, M00, M01, M11, A1, B10, B11 = arc_sums(phi, b, l1, l2)
    c0 = N0 / D
    c1 = N1 / D
    V00 = max(M00 / D - c0 * c0, 0.0)
    V11 = max(M11 / D - c1 * c1, 0.0)
    V01 = M01 / D - c0 * c1
    # eq. (8): endpoint terms of Leibniz' rule
    ta = phi + b
    te = phi - b
    ca = math.cos(ta)
    sa = math.sin(ta)
    ce = math.cos(te)
    se = math.sin(te)
    wa = math.sqrt(l1 * l1 * sa * sa + l2 * l2 * ca * ca) / D
    we = math.sqrt(l1 * l1 * se * se + l2 * l2 * ce * ce) / D
    pa0 = wa * (ca - c0)
    pa1 = wa * (sa - c1)
    pe0 = we * (ce - c0)
    pe1 = we * (se - c1)
    dphi0 = pa0 - pe0
    dphi1 = pa1 - pe1
    db0 = pa0 + pe0
    db1 = pa1 + pe1
    # eq. (11): chain rule through phi(q) and b(|q|)
    C00 = dphi0 * fx + db0 * rx
    C01 = dphi0 * fy + db0 * ry
    C10 = dphi1 * fx + db1 * rx
    C11 = dphi1 * fy + db1 * ry
    k10 = (B10 - c0 * A1) / D
    k11 = (B11 - c1 * A1) / D
    return c0, c1, C00, C01, C10, C11, V00, V01, V11, k10, k11, qn0, qn1, clamped


def _scaled_frame(dx: float, dy: float, co: float, so: float) -> tuple[float, float, float]:
    """``(e1, e2, scale)``: ``R(o)^T d / scale`` with ``scale = max(|dx|, |dy|)`` (1 for ``d = 0``)."""
    m = max(abs(dx), abs(dy))
    if m == 0.0:
        return 0.0, 0.0, 1.0
    ux = dx / m
    uy = dy / m
    return co * ux + so * uy, -so * ux + co * uy, m


def arc_moments(dx: float, dy: float, X11: float, X12: float, X22: float):
    """Mean offset, its Jacobian and the source covariance of the visible arc (docs/method.md a.12).

    Parameters
    ----------
    dx, dy : float
        ``d = s - p``, sensor position minus landmark centroid (m).
    X11, X12, X22 : float
        Entries of the extent matrix ``X`` (m^2); eigenvalues floored by eq. (15).

    Returns
    -------
    tuple of float
        ``(g0, g1, G00, G01, G10, G11, S00, S01, S11, clamped)``: ``g = E[y] - p`` (m, eq. (6)),
        ``G = dg/dd`` (eq. (13)), so ``dE/ds = G`` and ``dE/dp = I - G``, the source covariance
        ``S = Cov[y]`` (m^2, eq. (6)) and whether ``|q|`` was clamped to :data:`R_MIN` (eq. (14)).
    """
    co, so, l1, l2 = principal_frame(X11, X12, X22)
    e1, e2, m = _scaled_frame(dx, dy, co, so)
    c0, c1, C00, C01, C10, C11, V00, V01, V11, _, _, _, _, clamped = arc_frame_moments(e1, e2, m, l1, l2)
    # principal frame: g' = Lam c, G' = Lam C Lam^-1, S' = Lam V Lam (eqs. (6), (13))
    h0 = l1 * c0
    h1 = l2 * c1
    H00 = C00
    H01 = C01 * l1 / l2
    H10 = C10 * l2 / l1
    H11 = C11
    T00 = l1 * l1 * V00
    T01 = l1 * l2 * V01
    T11 = l2 * l2 * V11
    # back to the world frame: g = R g', G = R G' R^T, S = R S' R^T
    g0 = co * h0 - so * h1
    g1 = so * h0 + co * h1
    G00, G01, G10, G11 = _rotate2(co, so, H00, H01, H10, H11)
    S00, S01, _, S11 = _rotate2(co, so, T00, T01, T01, T11)
    return g0, g1, G00, G01, G10, G11, S00, S01, S11, clamped


def _rotate2(co: float, so: float, m00: float, m01: float, m10: float, m11: float):
    """The entries ``(00, 01, 10, 11)`` of ``R M R^T`` for ``R = R(o)`` with ``cos o = co``,
    ``sin o = so``. A kernel."""
    a00 = co * m00 - so * m10
    a01 = co * m01 - so * m11
    a10 = so * m00 + co * m10
    a11 = so * m01 + co * m11
    return a00 * co - a01 * so, a00 * so + a01 * co, a10 * co - a11 * so, a10 * so + a11 * co


def tangent_points(dx: float, dy: float, X11: float, X12: float, X22: float):
    """``(t0x, t0y, t1x, t1y, b, clamped)``: the ends ``y - p`` (m) of the visible arc, i.e. the
    tangent points from the sensor (``phi - b`` first, then ``phi + b``, counter-clockwise), and
    the half-angle ``b`` (rad) of the arc in the principal-frame parameter (eq. (4))."""
    co, so, l1, l2 = principal_frame(X11, X12, X22)
    e1, e2, m = _scaled_frame(dx, dy, co, so)
    phi, b, _, _, _, _, _, _, clamped = arc_geometry(e1, e2, m, l1, l2)
    x0 = l1 * math.cos(phi - b)
    y0 = l2 * math.sin(phi - b)
    x1 = l1 * math.cos(phi + b)
    y1 = l2 * math.sin(phi + b)
    return co * x0 - so * y0, so * x0 + co * y0, co * x1 - so * y1, so * x1 + co * y1, b, clamped


def arc_mean_shape_jacobian(dx: float, dy: float, o: float, l1: float, l2: float):
    """Derivatives of the mean offset ``g`` with respect to the ellipse's shape (eq. (17)).

    Parameters
    ----------
    dx, dy : float
        ``d = s - p`` (m).
    o : float
        Orientation of the ``l1`` axis (rad), as in :func:`.ellipse.ellipse_to_matrix`.
    l1, l2 : float
        Semi-axes (m), either may be the larger; floored at ``sqrt(EIG_ABS)`` and ``sqrt(EIG_REL)``
        times the larger.

    Returns
    -------
    tuple of float
        ``(dg0/do, dg1/do, dg0/dlog l1, dg1/dlog l1, dg0/dlog l2, dg1/dlog l2, clamped)``, analytic.
    """
    a1 = max(abs(l1), math.sqrt(EIG_ABS))
    a2 = max(abs(l2), math.sqrt(EIG_ABS))
    big = max(a1, a2)
    lo = big * math.sqrt(EIG_REL)
    a1 = max(a1, lo)
    a2 = max(a2, lo)
    co = math.cos(o)
    so = math.sin(o)
    e1, e2, m = _scaled_frame(dx, dy, co, so)
    c0, c1, C00, C01, C10, C11, _, _, _, k10, k11, qn0, qn1, clamped = arc_frame_moments(e1, e2, m, a1, a2)
    A = _shape_columns(c0, c1, C00, C01, C10, C11, k10, k11, qn0, qn1, e1, e2, m, a1, a2)
    # columns are principal-frame vectors R^T dg; rotate back: dg = R (.)
    out0 = co * A[0] - so * A[1]
    out1 = so * A[0] + co * A[1]
    out2 = co * A[2] - so * A[3]
    out3 = so * A[2] + co * A[3]
    out4 = co * A[4] - so * A[5]
    out5 = so * A[4] + co * A[5]
    return out0, out1, out2, out3, out4, out5, clamped


def _shape_columns(c0, c1, C00, C01, C10, C11, k10, k11, qn0, qn1, e1, e2, m, l1, l2):
    """Principal-frame ``R^T dg/do``, ``R^T dg/dlog l1``, ``R^T dg/dlog l2`` (eq. (17)), as six floats.

    ``C q`` terms are formed as ``(C qn) m`` so that huge ``d`` never overflows."""
    # d/do: R' Lam c + R Lam C dq/do, dq/do = Lam^-1 (e2, -e1) m  (R^T R' = J)
    u0 = e2 / l1
    u1 = -e1 / l2
    j0 = -l2 * c1 + l1 * ((C00 * u0 + C01 * u1) * m)
    j1 = l1 * c0 + l2 * ((C10 * u0 + C11 * u1) * m)
    # d/dlog l1: Lam (E1 c + k1 - C E1 q); w_2 = w - w_1 gives k2 = -k1
    p0 = l1 * (c0 + k10 - (C00 * qn0) * m)
    p1 = l2 * (k11 - (C10 * qn0) * m)
    s0 = l1 * (-k10 - (C01 * qn1) * m)
    s1 = l2 * (c1 - k11 - (C11 * qn1) * m)
    return j0, j1, p0, p1, s0, s1


def _validated(p, X, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``p (2,)``, ``X (2, 2)`` symmetric positive definite and ``s (2,)``, finite, or InputError."""
    p = as_array("p", p, (2,))
    s = as_array("s", s, (2,))
    X = as_array("X", X, (2, 2))
    scale = max(1.0, float(np.max(np.abs(X))))
    if abs(X[0, 1] - X[1, 0]) > 1e-9 * scale:
        raise InputError(f"X: expected a symmetric matrix, got X[0, 1] = {X[0, 1]!r}, X[1, 0] = {X[1, 0]!r}")
    lam = np.linalg.eigvalsh(0.5 * (X + X.T))
    if not lam[0] > 0.0:
        raise InputError(f"X: expected a positive definite matrix, got smallest eigenvalue {lam[0]:.3g}")
    return p, X, s


def visible_arc_moments(p, X, s) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """Expected mean and spread of the detections of an ellipse seen from ``s`` (docs/method.md a.12).

    Parameters
    ----------
    p : array_like, shape (2,)
        Landmark centroid (m).
    X : array_like, shape (2, 2)
        Extent matrix (m^2), symmetric positive definite: the outline is ``(y - p)^T X^-1 (y - p) = 1``.
    s : array_like, shape (2,)
        Sensor position (m).

    Returns
    -------
    mean : ndarray, shape (2,)
        ``E[y] = p + g(s - p)`` (m), eq. (6).
    cov : ndarray, shape (2, 2)
        ``Cov[y]`` of the detection sources on the visible arc (m^2), without sensor noise.
    J_s : ndarray, shape (2, 2)
        ``dE[y]/ds = G`` (eq. (13)).
    J_p : ndarray, shape (2, 2)
        ``dE[y]/dp = I - G``.
    clamped : bool
        True when ``|q| < R_MIN`` (sensor on, inside or within the floor of the outline, eq. (14)).

    Raises
    ------
    InputError
        For a wrong shape, a non-finite entry, or an ``X`` that is not symmetric positive definite.
    """
    p, X, s = _validated(p, X, s)
    d = s - p
    g0, g1, G00, G01, G10, G11, S00, S01, S11, clamped = arc_moments(
        float(d[0]), float(d[1]), float(X[0, 0]), 0.5 * float(X[0, 1] + X[1, 0]), float(X[1, 1]))
    G = np.array(((G00, G01), (G10, G11)))
    return (p + np.array((g0, g1)), np.array(((S00, S01), (S01, S11))), G, np.eye(2) - G, bool(clamped))


def visible_arc_shape_jacobian(p, semi_axes, orientation: float, s) -> tuple[np.ndarray, bool]:
    """``dE[y] / d(o, log l1, log l2)`` as a (2, 3) array (eq. (17)) and the clamping flag.

    ``semi_axes = (l1, l2)`` (m, positive) with ``l1`` along ``orientation`` (rad), as in
    :func:`.ellipse.ellipse_to_matrix`; ``p`` and ``s`` as in :func:`visible_arc_moments`.
    """
    p = as_array("p", p, (2,))
    s = as_array("s", s, (2,))
    ax = as_array("semi_axes", semi_axes, (2,))
    if not np.all(ax > 0):
        raise InputError(f"semi_axes: expected lengths > 0, got {ax.tolist()}")
    o = as_scalar("orientation", orientation)
    d = s - p
    *cols, clamped = arc_mean_shape_jacobian(float(d[0]), float(d[1]), o, float(ax[0]), float(ax[1]))
    return np.array(cols).reshape(3, 2).T, bool(clamped)


KERNELS = (_rotate2, principal_frame, arc_geometry, arc_pieces, arc_node, arc_sums_on, arc_sums, arc_frame_moments,
           _scaled_frame, arc_moments,
           tangent_points, arc_mean_shape_jacobian, _shape_columns, spectral)
