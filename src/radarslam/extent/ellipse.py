"""Ellipse parameters <-> extent matrix (docs/method.md d.1-d.2, a.6).

An ellipse with semi-axes ``(l1, l2)`` and orientation ``o`` (angle of the ``l1`` axis, radians,
counter-clockwise from the world x axis) corresponds to the SPD matrix

    X = R(o) diag(l1^2, l2^2) R(o)^T,

whose contour ``{x : x^T X^-1 x = 1}`` is the ellipse ([LI14] eq. (8)). For a random-matrix
extent ``X`` this is the object's contour, because a uniform spread over the ellipse has
covariance ``X / 4`` (docs/method.md d.4).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.validation import as_array, as_scalar, as_spd

#: Relative eigenvalue gap below which an ellipse is treated as a circle (orientation 0).
CIRCLE_REL_TOL = 1e-12

#: Relative size of ``|X12|`` below which [LI14] eq. (9) is guarded with ``o = 0`` (docs/method.md d.2).
LI_X12_EPS = 1e-15


def ellipse_to_matrix(semi_axes: np.ndarray, orientation: float) -> np.ndarray:
    """Extent matrix of an ellipse ([LI14] eq. (8), docs/method.md d.1).

    Parameters
    ----------
    semi_axes : array_like, shape (2,)
        Semi-axis lengths ``(l1, l2)`` (m), ``>= 0``; ``l1`` lies along ``orientation``. Either may be
        the larger one.
    orientation : float
        Angle of the ``l1`` axis (rad).

    Returns
    -------
    X : ndarray, shape (2, 2)
        ``R(o) diag(l1^2, l2^2) R(o)^T``, symmetric PSD.

    Raises
    ------
    InputError
        For a wrong shape, a non-finite value or a negative semi-axis.
    """
    ax = as_array("semi_axes", semi_axes, (2,))
    if np.any(ax < 0):
        raise InputError(f"semi_axes: expected lengths >= 0, got {ax.tolist()}")
    o = as_scalar("orientation", orientation)
    return _ellipse_to_matrix(float(ax[0]), float(ax[1]), o)


def _ellipse_to_matrix(l1: float, l2: float, o: float) -> np.ndarray:
    """Kernel of :func:`ellipse_to_matrix` on trusted floats; returns a new (2, 2) array."""
    co = math.cos(o)
    so = math.sin(o)
    q1 = l1 * l1
    q2 = l2 * l2
    x11 = q1 * co * co + q2 * so * so
    x22 = q1 * so * so + q2 * co * co
    x12 = (q1 - q2) * so * co
    return np.array(((x11, x12), (x12, x22)))


def matrix_to_ellipse(X: np.ndarray) -> tuple[np.ndarray, float]:
    """Semi-axes and orientation of the ellipse of an extent matrix (docs/method.md a.6, d.2 [PROP]).

    Uses ``np.linalg.eigh``: semi-axes are the square roots of the eigenvalues, the orientation is
    the direction of the eigenvector of the largest eigenvalue.

    Parameters
    ----------
    X : array_like, shape (2, 2)
        Symmetric positive semi-definite extent matrix (m^2).

    Returns
    -------
    semi_axes : ndarray, shape (2,)
        ``(major, minor)`` semi-axis lengths (m), major first.
    orientation : float
        Angle of the major axis in ``[0, pi)`` (rad); ``0`` for a circle (eigenvalues equal to a
        relative :data:`CIRCLE_REL_TOL`).

    Raises
    ------
    InputError
        When ``X`` is not a finite symmetric PSD (2, 2) matrix.
    """
    X = as_spd("X", X, 2)
    lam, U = np.linalg.eigh(0.5 * (X + X.T))
    lam = np.maximum(lam, 0.0)  # as_spd admits -1e-9 * scale of rounding
    semi_axes = np.sqrt(lam[::-1])
    if lam[1] - lam[0] <= CIRCLE_REL_TOL * lam[1]:
        return semi_axes, 0.0
    return semi_axes, _axis_angle_mod_pi(math.atan2(U[1, 1], U[0, 1]))


def _axis_angle_mod_pi(angle: float) -> float:
    """An axis direction reduced to ``[0, pi)``."""
    o = math.fmod(angle, math.pi)
    if o < 0.0:
        o += math.pi
    return 0.0 if o >= math.pi else o  # fmod of a tiny negative can round up to pi


def li_orientation(X: np.ndarray) -> tuple[np.ndarray, float]:
    """Semi-axes and orientation by the closed form of [LI14] eq. (9) (docs/method.md d.2).

    ``rho = (X11 - X22) / (2 X12)``, ``o = arctan(-rho + sqrt(1 + rho^2))`` and
    ``[l1^2, l2^2] = diag(R(o)^T X R(o))``. Kept as a cross-check of :func:`matrix_to_ellipse`.

    Parameters
    ----------
    X : array_like, shape (2, 2)
        Symmetric positive semi-definite extent matrix (m^2).

    Returns
    -------
    semi_axes : ndarray, shape (2,)
        ``(l1, l2)`` in Li's order: ``l1`` belongs to the axis at ``orientation`` and may be the
        minor one (then the major axis is at ``orientation + pi/2``).
    orientation : float
        In ``[0, pi/2)`` (rad); ``0`` when ``|X12| < LI_X12_EPS * max|X_ij|`` (the guard of d.2).

    Raises
    ------
    InputError
        When ``X`` is not a finite symmetric PSD (2, 2) matrix.

    Notes
    -----
    ``-rho + sqrt(1 + rho^2)`` is evaluated as ``1 / (rho + sqrt(1 + rho^2))`` when ``rho > 0``,
    the same number without the cancellation for large ``rho``.
    """
    X = as_spd("X", X, 2)
    x11 = float(X[0, 0])
    x22 = float(X[1, 1])
    x12 = 0.5 * float(X[0, 1] + X[1, 0])
    scale = max(abs(x11), abs(x22), abs(x12))
    if abs(x12) <= LI_X12_EPS * scale:
        o = 0.0
    else:
        rho = (x11 - x22) / (2.0 * x12)
        root = math.hypot(1.0, rho)
        t = 1.0 / (rho + root) if rho > 0.0 else root - rho
        o = math.atan(t)
    co = math.cos(o)
    so = math.sin(o)
    q1 = x11 * co * co + 2.0 * x12 * so * co + x22 * so * so
    q2 = x11 * so * so - 2.0 * x12 * so * co + x22 * co * co
    return np.sqrt(np.maximum((q1, q2), 0.0)), o


def trunk_diameter(X: np.ndarray, gamma_z: float = 0.25) -> np.ndarray:
    """Trunk diameter (m) implied by extent matrices ``X (..., 2, 2)`` of the RMA model.

    The RMA measurement model spreads detections with covariance ``gamma_z X`` about the centroid
    (seed eq. (4); ``gamma_z = 1/4`` for a uniformly filled ellipse). A laser does not see a filled
    disc: beams equally spaced in bearing hit the visible half of a trunk of radius ``rho`` at
    offsets across the line of sight that are uniform on ``[-rho, rho]`` (variance ``rho^2 / 3``),
    while the spread along the line of sight is small (``(2/3 - pi^2/16) rho^2 = 0.05 rho^2``). So
    the major eigenvalue ``lambda`` of ``X`` is the across-sight one and ``gamma_z lambda = rho^2 / 3``,
    i.e. ``d = 2 rho = 2 sqrt(3 gamma_z lambda)`` (``sqrt(3 lambda)`` for ``gamma_z = 1/4``), not the
    filled-disc ``2 sqrt(lambda)``. This is the far-field limit: at range ``r`` the rays diverge
    across the trunk and the visible arc is less than a half, so ``d`` comes out small by about
    ``0.6 rho / r`` (1.5% at ``r = 40 rho``, i.e. a 0.5 m trunk at 10 m; 8% at ``r = 7.5 rho``).
    """
    X = np.asarray(X, dtype=float)
    if X.shape[-2:] != (2, 2):
        raise InputError(f"X: expected shape (..., 2, 2), got {X.shape}")
    if not gamma_z > 0:
        raise InputError(f"gamma_z: expected a positive number, got {gamma_z!r}")
    lam = np.linalg.eigvalsh(X)[..., -1]
    return 2.0 * np.sqrt(3.0 * gamma_z * np.maximum(lam, 0.0))
