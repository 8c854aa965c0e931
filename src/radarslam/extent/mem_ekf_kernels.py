"""The MEM-EKF* shape estimator's arithmetic as kernels (docs/method.md a.10; Yang & Baum 2019).

Plain floats, loops and small arrays: :mod:`radarslam.extent.mem_ekf` calls them as Python (on
lists, where indexing is cheapest), and the fused engine (:mod:`radarslam.slam.fused.extent`)
compiles them as they are (:func:`radarslam.core.jit.compile_kernels`), on arrays. The
arithmetic of a detection, a scan, the detections' noise, the prediction and the initial shape
is written here once.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.extent._sym2 import spectral
from radarslam.extent.ellipse import _axis_angle_mod_pi
from radarslam.extent.measurement import _w_entries

#: Lower bound of the semi-axes (m) after every update ([PROP], docs/method.md a.10): 5 cm, well
#: below any car and a tenth of the range noise; it keeps ``S`` of full rank.
AXIS_FLOOR = 0.05

_PI = math.pi


def shape_entries(a: float, b: float, c: float) -> tuple[float, float, float]:
    """The shape ``(theta, l1, l2)`` of the extent matrix ``[[a, b], [b, c]]`` by the closed 2 x 2
    spectral form (:mod:`._sym2`): ``theta`` in ``[0, pi)`` the major axis' direction (0 for a
    circle), ``l1 >= l2 >= 0`` the square roots of the eigenvalues."""
    lam1, lam2, cos2, sin2 = spectral(a, b, c)
    theta = _axis_angle_mod_pi(0.5 * math.atan2(sin2, cos2)) if lam1 > lam2 else 0.0
    return theta, math.sqrt(max(lam1, 0.0)), math.sqrt(max(lam2, 0.0))


def initial_shape(a: float, b: float, c: float) -> tuple[float, float, float]:
    """The first MEM-EKF* shape of a landmark whose EFA initialisation (a.3) gave ``[[a, b], [b, c]]``:
    :func:`shape_entries` with the semi-axes floored at :data:`AXIS_FLOOR`."""
    th, l1, l2 = shape_entries(a, b, c)
    return th, (l1 if l1 > AXIS_FLOOR else AXIS_FLOOR), (l2 if l2 > AXIS_FLOOR else AXIS_FLOOR)


def mem_ekf_predict_cov(Cp: np.ndarray, dt: float, q_theta: float, q_axis: float) -> np.ndarray:
    """The shape covariance ``(3, 3)`` grown over ``dt``: ``C_p + dt diag(q_theta^2, q_axis^2, q_axis^2)``,
    a new array (the static landmark's random walk, a.10)."""
    out = Cp.copy()
    out[0, 0] += dt * q_theta * q_theta
    qa = dt * q_axis * q_axis
    out[1, 1] += qa
    out[2, 2] += qa
    return out


def detection_cov_entries(theta: float, p00: float, p01: float, p02: float, p11: float, p12: float, p22: float,
                          r00: float, r01: float, r11: float, polar) -> list:
    """Each detection's ``W(i)`` of seed eq. (5) (docs/method.md a.2) as ``(W11, W12, W22)``: ``polar``
    a list of ``[r, phi]`` or an (m, 2) array, ``theta`` the heading, ``p..`` the pose covariance
    and ``r..`` the detection noise R."""
    q22 = p22 + r11
    out = []
    for i in range(len(polar)):
        r = polar[i][0]
        ang = theta + polar[i][1]
        out.append(_w_entries(math.cos(ang), math.sin(ang), r, p00, p01, p02, p11, p12, q22, r00, r01))
    return out


def mem_ekf_scan_entries(th, l1, l2, c11, c12, c13, c22, c23, c33, mx, my, m11, m12, m22, pts, cvs, ch,
                         axis_floor):
    """MEM-EKF* with a scan's detections one after the other (:func:`mem_ekf_detection`): ``pts``
    the detections (a list of ``[x, y]`` or an (m, 2) array, world frame), ``cvs`` their noise
    ``(C_v11, C_v12, C_v22)`` (a list of triples or an (m, 3) array), ``(mx, my)`` the centroid and
    ``m..`` its covariance. Returns the shape and ``C_p`` entries as :func:`mem_ekf_detection`."""
    for i in range(len(pts)):
        th, l1, l2, c11, c12, c13, c22, c23, c33 = mem_ekf_detection(
            th, l1, l2, c11, c12, c13, c22, c23, c33, pts[i][0] - mx, pts[i][1] - my, m11, m12, m22,
            cvs[i][0], cvs[i][1], cvs[i][2], ch, axis_floor)
    return th, l1, l2, c11, c12, c13, c22, c23, c33


def mem_ekf_detection(th, l1, l2, c11, c12, c13, c22, c23, c33, e0, e1, m11, m12, m22, v11, v12, v22,
                      ch, axis_floor):
    """One detection of :func:`mem_ekf_scan_entries` (the steps 1-6 of
    :func:`radarslam.extent.mem_ekf._mem_ekf_update_scan`): the new ``(theta, l1, l2)`` and ``C_p``
    entries ``(c11, c12, c13, c22, c23, c33)``, the given ones when the detection is skipped.
    ``e0, e1`` is the innovation, ``m..`` the centroid covariance, ``v..`` the detection's."""
    cs = math.cos(th)
    sn = math.sin(th)
    cc = cs * cs
    ss = sn * sn
    sc = sn * cs
    q1 = l1 * l1
    q2 = l2 * l2
    # step 1: S S^T + C^II / c_h in the axes' frame
    n11 = q1 + c22 + q2 * c11
    n22 = q2 + c33 + q1 * c11
    n12 = l1 * c12 - l2 * c13
    # step 2: C_y, rotated to the world
    y11 = m11 + v11 + ch * (cc * n11 - 2.0 * sc * n12 + ss * n22)
    y22 = m22 + v22 + ch * (ss * n11 + 2.0 * sc * n12 + cc * n22)
    y12 = m12 + v12 + ch * (sc * (n11 - n22) + (cc - ss) * n12)
    det = y11 * y22 - y12 * y12
    if not det > 0.0:
        return th, l1, l2, c11, c12, c13, c22, c23, c33
    # step 3: (C^Y)^-1 from P = C_y^-1
    i11 = y22 / det
    i22 = y11 / det
    i12 = -y12 / det
    g11 = 0.5 * i11 * i11
    g22 = 0.5 * i22 * i22
    g12 = 0.5 * i12 * i12
    g13 = i11 * i12
    g23 = i12 * i22
    g33 = i11 * i22 + i12 * i12
    # step 4: H (rows Y11, Y22, Y12; columns theta, l1, l2) and C^pY = C_p H^T (t_ij)
    d = ch * (q1 - q2)
    s2 = 2.0 * sc
    c2 = cc - ss
    a1 = 2.0 * ch * l1
    a2 = 2.0 * ch * l2
    h11, h12, h13 = -d * s2, a1 * cc, a2 * ss
    h21, h22, h23 = d * s2, a1 * ss, a2 * cc
    h31, h32, h33 = d * c2, 0.5 * a1 * s2, -0.5 * a2 * s2
    t11 = c11 * h11 + c12 * h12 + c13 * h13
    t12 = c11 * h21 + c12 * h22 + c13 * h23
    t13 = c11 * h31 + c12 * h32 + c13 * h33
    t21 = c12 * h11 + c22 * h12 + c23 * h13
    t22 = c12 * h21 + c22 * h22 + c23 * h23
    t23 = c12 * h31 + c22 * h32 + c23 * h33
    t31 = c13 * h11 + c23 * h12 + c33 * h13
    t32 = c13 * h21 + c23 * h22 + c33 * h23
    t33 = c13 * h31 + c23 * h32 + c33 * h33
    # step 5: K = C^pY (C^Y)^-1, the mean and the covariance
    k11 = t11 * g11 + t12 * g12 + t13 * g13
    k12 = t11 * g12 + t12 * g22 + t13 * g23
    k13 = t11 * g13 + t12 * g23 + t13 * g33
    k21 = t21 * g11 + t22 * g12 + t23 * g13
    k22 = t21 * g12 + t22 * g22 + t23 * g23
    k23 = t21 * g13 + t22 * g23 + t23 * g33
    k31 = t31 * g11 + t32 * g12 + t33 * g13
    k32 = t31 * g12 + t32 * g22 + t33 * g23
    k33 = t31 * g13 + t32 * g23 + t33 * g33
    n_c11 = c11 - (k11 * t11 + k12 * t12 + k13 * t13)
    n_c12 = c12 - (k11 * t21 + k12 * t22 + k13 * t23)
    n_c13 = c13 - (k11 * t31 + k12 * t32 + k13 * t33)
    n_c22 = c22 - (k21 * t21 + k22 * t22 + k23 * t23)
    n_c23 = c23 - (k21 * t31 + k22 * t32 + k23 * t33)
    n_c33 = c33 - (k31 * t31 + k32 * t32 + k33 * t33)
    # step 6: keep C_p positive definite (leading minors), else skip this detection
    minor2 = n_c11 * n_c22 - n_c12 * n_c12
    det3 = (n_c11 * (n_c22 * n_c33 - n_c23 * n_c23) - n_c12 * (n_c12 * n_c33 - n_c23 * n_c13)
            + n_c13 * (n_c12 * n_c23 - n_c22 * n_c13))
    if not (n_c11 > 0.0 and minor2 > 0.0 and det3 > 0.0):
        return th, l1, l2, c11, c12, c13, c22, c23, c33
    r1 = e0 * e0 - y11
    r2 = e1 * e1 - y22
    r3 = e0 * e1 - y12
    th += k11 * r1 + k12 * r2 + k13 * r3
    l1 += k21 * r1 + k22 * r2 + k23 * r3
    l2 += k31 * r1 + k32 * r2 + k33 * r3
    th %= _PI                      # [0, pi); a tiny negative theta rounds up to pi
    if th >= _PI:
        th = 0.0
    l1 = l1 if l1 > axis_floor else axis_floor
    l2 = l2 if l2 > axis_floor else axis_floor
    return th, l1, l2, n_c11, n_c12, n_c13, n_c22, n_c23, n_c33


#: The kernels, for :func:`radarslam.core.jit.compile_kernels` (with those they call).
KERNELS = (spectral, _axis_angle_mod_pi, _w_entries, shape_entries, initial_shape, mem_ekf_predict_cov,
           detection_cov_entries, mem_ekf_detection, mem_ekf_scan_entries)
