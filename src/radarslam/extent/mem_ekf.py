"""MEM-EKF* shape estimation of an elliptical landmark (Yang & Baum 2019; docs/method.md a.10 [PROP]).

S. Yang and M. Baum, "Tracking the orientation and axes lengths of an elliptical extended object",
IEEE Trans. Signal Processing 67(18), 2019, model a detection as

    y = m + S(p) h + v,    S(p) = R(theta) diag(l1, l2),    h ~ N(0, c_h I),    v ~ N(0, C_v),

with the centroid ``m``, the shape ``p = [theta, l1, l2]`` (orientation of the ``l1`` axis and the
two semi-axes), the multiplicative noise ``h`` (``c_h = 1/4`` for detections uniform over the
ellipse's surface, docs/method.md d.4) and the sensor noise ``v``. Every detection updates the
shape by a Kalman update with the pseudo-measurement ``Y = [e1^2, e2^2, e1 e2]`` of the innovation
``e = y - m``, with the analytic moments of the "*" version (first and second order in ``p``).

In radarslam the centroid is a state of the EKF-SLAM filter, which updates it with the detections
(docs/method.md a.2, c.4). So, as the random-matrix extent (:mod:`.random_matrix`), this module
estimates only the shape ``p`` and its 3 x 3 covariance ``C_p``; the centroid ``m`` and its 2 x 2
covariance ``C_m`` are inputs and MEM-EKF*'s own kinematic update is not applied. The kernels
take ``C_m`` and each detection's ``C_v``, entering the predicted covariance of a detection as

    C_y = C_m + c_h S S^T + C^II + C_v;

the estimator passes what ``extent.mem_ekf_noise`` says: by default (``"sensor"``) ``C_m = 0`` and
``C_v`` the sensor noise alone, because the centroid's and the pose's errors are shared by all the
detections of a scan and counting them per detection shrinks the axes (docs/method.md a.10).

Conventions: the orientation is kept in ``[0, pi)`` (``theta`` and ``theta + pi`` are the same
ellipse: ``S`` only changes sign and ``h`` is symmetric, so every moment below is unchanged); the
semi-axes are floored at :data:`AXIS_FLOOR` after each detection; ``l1`` may become the minor
axis (the shape is not re-sorted, which would permute ``C_p``); :func:`shape_matrix` gives the
extent matrix in the random-matrix convention either way.

The kernels are written on plain floats (the 2 x 2 and 3 x 3 algebra expanded), as
:func:`~.random_matrix._rm_update`: a numpy call costs about 1 us, more than a detection's whole
update here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.validation import as_array, as_points, as_scalar, as_spd
from radarslam.extent.ellipse import _ellipse_to_matrix
from radarslam.extent.estimator import RmaEfaEstimator, RmaEfaState
from radarslam.extent.mem_ekf_kernels import (
    AXIS_FLOOR,
    mem_ekf_predict_cov,
    mem_ekf_scan_entries,
    shape_entries,
)
from radarslam.extent.random_matrix import GAMMA_Z
from radarslam.extent.rows import MEM_NOISE


# --------------------------------------------------------------------------- shape <-> matrix
def shape_matrix(p: np.ndarray) -> np.ndarray:
    """The extent matrix ``X = R(theta) diag(l1^2, l2^2) R(theta)^T`` of a shape (docs/method.md d.1).

    The same convention as the random-matrix extent: the ellipse ``{x : x^T X^-1 x = 1}`` is the
    object outline, and detections uniform over it have covariance ``X / 4``.

    Parameters
    ----------
    p : array_like, shape (3,)
        ``[theta (rad), l1 (m), l2 (m)]``; semi-axes ``>= 0``.

    Returns
    -------
    X : ndarray, shape (2, 2)
        Symmetric PSD (m^2).

    Raises
    ------
    InputError
        For a wrong shape, a non-finite value or a negative semi-axis.
    """
    p = as_array("p", p, (3,))
    if p[1] < 0 or p[2] < 0:
        raise InputError(f"p: expected semi-axes >= 0, got {p[1:].tolist()}")
    return _shape_matrix(p)


def _shape_matrix(p: np.ndarray) -> np.ndarray:
    """Kernel of :func:`shape_matrix`; a new (2, 2) array."""
    th, l1, l2 = p.tolist()
    return _ellipse_to_matrix(l1, l2, th)


def shape_from_matrix(X: np.ndarray) -> np.ndarray:
    """The shape ``[theta, l1, l2]`` of an extent matrix, the inverse of :func:`shape_matrix`.

    Parameters
    ----------
    X : array_like, shape (2, 2)
        Symmetric PSD extent matrix (m^2).

    Returns
    -------
    p : ndarray, shape (3,)
        ``theta`` in ``[0, pi)``, the direction of the major axis (0 for a circle), and the
        semi-axes ``l1 >= l2 >= 0`` (square roots of the eigenvalues).

    Raises
    ------
    InputError
        When ``X`` is not a finite symmetric PSD (2, 2) matrix.
    """
    return _shape_from_matrix(as_spd("X", X, 2))


def _shape_from_matrix(X: np.ndarray) -> np.ndarray:
    """Kernel of :func:`shape_from_matrix` (:func:`~.mem_ekf_kernels.shape_entries`)."""
    (a, b), (_, c) = X.tolist()
    return np.array(shape_entries(a, b, c))


# --------------------------------------------------------------------------- the MEM-EKF* kernel
def shape_jacobians(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``J1, J2 (2, 3)``: the Jacobians of the rows of ``S(p)`` with respect to ``p`` (Yang & Baum 2019).

    Row ``i`` of ``S = R(theta) diag(l1, l2)`` is ``S_i = [S_i1, S_i2]``; ``J_i = d S_i^T / d p``.
    The kernel uses them expanded (docs/method.md a.10); this function is their reference form.
    """
    th, l1, l2 = as_array("p", p, (3,)).tolist()
    c, s = math.cos(th), math.sin(th)
    J1 = np.array(((-l1 * s, c, 0.0), (-l2 * c, 0.0, -s)))
    J2 = np.array(((l1 * c, s, 0.0), (-l2 * s, 0.0, c)))
    return J1, J2


def pseudo_measurement_jacobian(p: np.ndarray, c_h: float = GAMMA_Z) -> np.ndarray:
    """``H (3, 3)``: the Jacobian of ``E[Y] = c_h [X11, X22, X12]`` with respect to ``p``.

    The matrix ``M`` of Yang & Baum 2019, rows ``2 S_1 C_h J_1``, ``2 S_2 C_h J_2`` and
    ``S_1 C_h J_2 + S_2 C_h J_1`` with ``C_h = c_h I``; ``C^pY = C_p H^T``. Expanded
    (docs/method.md a.10), with ``d = l1^2 - l2^2``:

        H = c_h [[-d sin 2theta, 2 l1 cos^2 theta, 2 l2 sin^2 theta],
                 [ d sin 2theta, 2 l1 sin^2 theta, 2 l2 cos^2 theta],
                 [ d cos 2theta,   l1 sin 2theta,   -l2 sin 2theta]].
    """
    th, l1, l2 = as_array("p", p, (3,)).tolist()
    c_h = as_scalar("c_h", c_h, low=0.0, low_open=True)
    c, s = math.cos(th), math.sin(th)
    d = l1 * l1 - l2 * l2
    s2, c2 = 2.0 * s * c, c * c - s * s
    return c_h * np.array(((-d * s2, 2.0 * l1 * c * c, 2.0 * l2 * s * s),
                           (d * s2, 2.0 * l1 * s * s, 2.0 * l2 * c * c),
                           (d * c2, l1 * s2, -l2 * s2)))


def mem_ekf_update(p: np.ndarray, Cp: np.ndarray, centroid: np.ndarray, centroid_cov: np.ndarray,
                   y: np.ndarray, Cv: np.ndarray, c_h: float = GAMMA_Z,
                   axis_floor: float = AXIS_FLOOR) -> tuple[np.ndarray, np.ndarray]:
    """MEM-EKF* shape update with one detection (Yang & Baum 2019; docs/method.md a.10).

    Parameters
    ----------
    p : array_like, shape (3,)
        Predicted shape ``[theta (rad), l1 (m), l2 (m)]``.
    Cp : array_like, shape (3, 3)
        Its covariance, symmetric positive definite.
    centroid : array_like, shape (2,)
        Landmark centroid ``m`` (m), world frame; not updated here.
    centroid_cov : array_like, shape (2, 2)
        Its covariance ``C_m`` (m^2), symmetric PSD.
    y : array_like, shape (2,)
        The detection, converted to the world frame (m).
    Cv : array_like, shape (2, 2)
        Its noise covariance (m^2; seed eq. (5)), symmetric PSD.
    c_h : float, optional
        Variance ``c_h > 0`` of each component of ``h``: 1/4 for a spread over the ellipse's
        surface, 1/2 on its contour (docs/method.md a.10).
    axis_floor : float, optional
        Lower bound of the updated semi-axes (m), ``>= 0``.

    Returns
    -------
    p : ndarray, shape (3,)
        Updated shape, ``theta`` in ``[0, pi)``, semi-axes ``>= axis_floor``.
    Cp : ndarray, shape (3, 3)
        Updated covariance, symmetric by construction; the prior when the update would make it
        indefinite (docs/method.md a.10).

    Raises
    ------
    InputError
        Naming the offending argument.
    """
    y = as_array("y", y, (2,))
    return mem_ekf_update_scan(p, Cp, centroid, centroid_cov, y[None, :], Cv, c_h, axis_floor)


def mem_ekf_update_scan(p: np.ndarray, Cp: np.ndarray, centroid: np.ndarray, centroid_cov: np.ndarray,
                        points: np.ndarray, Cv: np.ndarray, c_h: float = GAMMA_Z,
                        axis_floor: float = AXIS_FLOOR) -> tuple[np.ndarray, np.ndarray]:
    """:func:`mem_ekf_update` for a scan's detections, one after the other (as MEM-EKF* does).

    ``points (m, 2)`` (``m`` may be 0: nothing changes) with ``Cv`` either one (2, 2) covariance
    for all or one per detection, ``(m, 2, 2)``. Other parameters and the result as
    :func:`mem_ekf_update`.
    """
    p = as_array("p", p, (3,))
    if p[1] < 0 or p[2] < 0:
        raise InputError(f"p: expected semi-axes >= 0, got {p[1:].tolist()}")
    Cp = as_spd("Cp", Cp, 3)
    if np.linalg.eigvalsh(Cp)[0] <= 0.0:
        raise InputError(f"Cp: expected a positive definite matrix, got eigenvalues {np.linalg.eigvalsh(Cp).tolist()}")
    centroid = as_array("centroid", centroid, (2,))
    centroid_cov = as_spd("centroid_cov", centroid_cov, 2)
    points = as_points("points", points)
    Cv = np.asarray(Cv, dtype=np.float64)
    if Cv.ndim == 2:
        Cv = as_spd("Cv", Cv, 2)
        cvs = [(float(Cv[0, 0]), float(Cv[0, 1]), float(Cv[1, 1]))] * points.shape[0]
    else:
        Cv = as_array("Cv", Cv, (points.shape[0], 2, 2))
        for i, c in enumerate(Cv):
            as_spd(f"Cv[{i}]", c, 2)
        cvs = [(a, b, d) for (a, b), (_, d) in Cv.tolist()]
    c_h = as_scalar("c_h", c_h, low=0.0, low_open=True)
    axis_floor = as_scalar("axis_floor", axis_floor, low=0.0)
    return _mem_ekf_update_scan(p, Cp, centroid, centroid_cov, points, cvs, c_h, axis_floor)


def _mem_ekf_update_scan(p: np.ndarray, Cp: np.ndarray, centroid: np.ndarray, centroid_cov: np.ndarray,
                         points: np.ndarray, cvs: list, c_h: float = GAMMA_Z,
                         axis_floor: float = AXIS_FLOOR) -> tuple[np.ndarray, np.ndarray]:
    """Kernel of :func:`mem_ekf_update_scan`; no validation.

    Contract: ``p`` (3,) with semi-axes ``>= 0``; ``Cp`` (3, 3) symmetric positive definite;
    ``centroid`` (2,); ``centroid_cov`` (2, 2) symmetric PSD; ``points`` (m, 2); ``cvs`` a list of
    ``m`` triples ``(C_v11, C_v12, C_v22)`` of floats, each a PSD covariance, with
    ``C_m + C_v`` positive definite; ``c_h > 0``; ``axis_floor >= 0``. All finite float64; inputs
    are never modified; returns a new (3,) and a new (3, 3) array.

    Per detection (docs/method.md a.10, Yang & Baum 2019), with ``c, s = cos, sin theta``, ``e`` the
    innovation ``y - m`` and ``C_p`` entries ``c_ij`` (indices theta, l1, l2 = 1, 2, 3):

    1. ``N = diag(l1^2, l2^2) + [[c_22 + l2^2 c_11, l1 c_12 - l2 c_13], [., c_33 + l1^2 c_11]]``:
       ``S S^T + C^II / c_h`` in the frame of the axes (``C^II = c_h R N' R^T``, the trace form of
       the paper with ``J_1, J_2`` expanded);
    2. ``C_y = C_m + C_v + c_h R(theta) N R(theta)^T`` (the predicted covariance of ``y``);
    3. ``E[Y] = [C_y11, C_y22, C_y12]``; ``C^Y`` the Gaussian fourth moments
       ``C^Y_(ij)(kl) = C_y,ik C_y,jl + C_y,il C_y,jk``, inverted in closed form through
       ``P = C_y^-1``: ``(C^Y)^-1 = [[P11^2/2, P12^2/2, P11 P12], [., P22^2/2, P12 P22], [., ., P11 P22 + P12^2]]``;
    4. ``C^pY = C_p H^T`` with ``H`` of :func:`pseudo_measurement_jacobian`;
    5. ``K = C^pY (C^Y)^-1``, ``p += K (Y - E[Y])``, ``C_p -= K (C^pY)^T``;
    6. ``theta`` reduced to ``[0, pi)``, semi-axes floored. If the new ``C_p`` is not positive
       definite (its leading minors; a linearisation far from the truth can overshoot), the
       detection is skipped.

    Measured (timeit, development machine): about 6 us per detection.
    """
    th, l1, l2 = p.tolist()
    (c11, c12, c13), (_, c22, c23), (_, _, c33) = Cp.tolist()
    mx, my = centroid.tolist()
    (m11, m12), (_, m22) = centroid_cov.tolist()
    th, l1, l2, c11, c12, c13, c22, c23, c33 = mem_ekf_scan_entries(
        th, l1, l2, c11, c12, c13, c22, c23, c33, mx, my, m11, m12, m22, points.tolist(), cvs, c_h, axis_floor)
    return (np.array((th, l1, l2)),
            np.array(((c11, c12, c13), (c12, c22, c23), (c13, c23, c33))))


def mem_ekf_predict(p: np.ndarray, Cp: np.ndarray, dt: float, q_theta: float,
                    q_axis: float) -> tuple[np.ndarray, np.ndarray]:
    """Shape prediction of a static landmark: ``p`` unchanged, ``C_p += dt diag(q_theta^2, q_axis^2, q_axis^2)``.

    Parameters
    ----------
    p : array_like, shape (3,)
        Shape ``[theta, l1, l2]``.
    Cp : array_like, shape (3, 3)
        Its covariance, symmetric PSD.
    dt : float
        Time since the last scan (s), ``>= 0``.
    q_theta, q_axis : float
        Random-walk intensities (rad / sqrt(s), m / sqrt(s)), ``>= 0``.

    Returns
    -------
    p, Cp : ndarray
        Copies, the covariance grown (docs/method.md a.10).

    Raises
    ------
    InputError
        Naming the offending argument.
    """
    p = as_array("p", p, (3,))
    Cp = as_spd("Cp", Cp, 3)
    dt = as_scalar("dt", dt, low=0.0)
    q_theta = as_scalar("q_theta", q_theta, low=0.0)
    q_axis = as_scalar("q_axis", q_axis, low=0.0)
    return p.copy(), _mem_ekf_predict(Cp, dt, q_theta, q_axis)


def _mem_ekf_predict(Cp: np.ndarray, dt: float, q_theta: float, q_axis: float) -> np.ndarray:
    """Kernel of :func:`mem_ekf_predict` (:func:`~.mem_ekf_kernels.mem_ekf_predict_cov`): a new (3, 3) array."""
    return mem_ekf_predict_cov(Cp, dt, q_theta, q_axis)


# --------------------------------------------------------------------------- the component
@dataclass
class MemEkfState(RmaEfaState):
    """:class:`~.estimator.RmaEfaState` plus the MEM-EKF* shape ``p = [theta, l1, l2]`` and its
    covariance ``Cp``; ``X`` is kept equal to ``shape_matrix(p)`` (``alpha`` is unused)."""

    p: np.ndarray | None = None
    Cp: np.ndarray | None = None


class MemEkfEstimator(RmaEfaEstimator):
    """MEM-EKF* shapes (Yang & Baum 2019; docs/method.md a.10) initialised by EFA, with the EFA baseline.

    The buffering and EFA initialisation of a.3 are the parent's; from then on the shape
    ``(p, C_p)`` replaces the RMA's ``(X, alpha)``: each scan it is predicted
    (:func:`mem_ekf_predict`) and updated with the scan's detections one by one
    (:func:`mem_ekf_update_scan`, each with its own ``W(i)`` of seed eq. (5) as ``C_v``), and
    ``X = shape_matrix(p)`` serves SLAM (sifting, ``gamma_z X`` in ``R_eff``), snapshots and the
    GWD. The multiplicative-noise variance ``c_h`` is ``extent.gamma_z``: both are the ratio of
    the detection spread to ``X``.

    Parameters
    ----------
    extent_config : ExtentConfig
        The ``extent`` section (``mem_ekf_init_std``, ``mem_ekf_process_std`` and the RMA keys).
    R_extent : ndarray (2, 2)
        Detection noise of the extent step.
    *args, **kwargs
        Passed on to :class:`~.estimator.RmaEfaEstimator` (its further options, such as the backend).
    """

    name = "mem-ekf"

    def __init__(self, extent_config, R_extent: np.ndarray, *args, **kwargs):
        super().__init__(extent_config, R_extent, *args, **kwargs)
        std_theta_deg, std_axis = extent_config.mem_ekf_init_std
        self.Cp0 = np.diag([math.radians(std_theta_deg) ** 2, std_axis ** 2, std_axis ** 2])
        q_theta_deg, self.q_axis = extent_config.mem_ekf_process_std
        self.q_theta = math.radians(q_theta_deg)

    def new(self) -> MemEkfState:
        return MemEkfState()

    def matrix(self, st: MemEkfState) -> np.ndarray | None:
        """``shape_matrix(p)`` (held in ``st.X``), or None before initialisation."""
        return st.X

    # The extent step over array-held states (RmaEfaEstimator._rows_step): a.3 is the parent's,
    # then a.10 by extent.rows.mem_ekf_rows, the function the fused engine calls.
    def _born(self, E, born) -> None:
        self._kernels.mem_ekf_initialise_rows(E, born, len(born), self.Cp0)

    def _scan(self, E, ready, s, efa: bool) -> None:
        ec = self.c
        self._kernels.mem_ekf_rows(E, ready, len(ready), s.old, s.aoff, s.arow, s.polar, s.xy, s.cents, s.ccovs, s.pose,
                                   s.pose_cov, self.R_extent, s.W, s.w_given, s.dt, self.q_theta, self.q_axis,
                                   MEM_NOISE[ec.mem_ekf_noise], ec.spread_factor, not ec.efa_noise_correct, efa)

    def _gather(self, states: list[MemEkfState]):
        E = super()._gather(states)
        for j, st in enumerate(states):
            if st.p is not None:
                E.shape[j], E.Cs[j] = st.p, st.Cp
        return E

    def _scatter(self, E, states: list[MemEkfState], born, k: int) -> None:
        super()._scatter(E, states, born, k)
        for j, st in enumerate(states):
            if E.einit[j]:
                st.p, st.Cp = E.shape[j], E.Cs[j]


