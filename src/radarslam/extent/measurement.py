"""Covariance ``W`` of the converted (Cartesian) radar detections (seed eqs. (3), (5)-(7)).

A detection ``s = [r, phi]`` (range, azimuth relative to the heading) seen from the pose
``x^m = [x, y, theta]`` is converted to the world frame by seed eq. (3),

    z = f(x^m, s) = [x + r cos(theta + phi), y + r sin(theta + phi)]^T,

and its covariance is linearised (seed eq. (5)) as ``W(i) = F_x P^m F_x^T + F_s R F_s^T`` with the
Jacobians of seed eqs. (6)-(7). One ``W`` per scan and landmark is then chosen from the ``W(i)``
(docs/method.md a.2, h.3, Decision 3: the one with the largest trace).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.validation import as_array, as_scalar, as_spd

#: Ways of reducing the per-detection ``W(i)`` of a scan to one ``W`` (docs/method.md h.3).
W_MODES = ("max_trace", "max_det", "mean")
#: :data:`W_MODES` as the kernels take them (:func:`scan_w_entries`).
W_MAX_TRACE, W_MAX_DET, W_MEAN = 0, 1, 2

#: Detection count above which :func:`_converted_measurement_covs` switches from a plain-float
#: loop to numpy arrays (the measured break-even point).
_VECTORISE_FROM = 20


def converted_measurement_cov(pose: np.ndarray, pose_cov: np.ndarray, r: float, phi: float,
                              R: np.ndarray) -> np.ndarray:
    """Covariance of one converted detection, seed eq. (5).

    Parameters
    ----------
    pose : array_like, shape (3,)
        Platform pose ``[x (m), y (m), theta (rad)]``.
    pose_cov : array_like, shape (3, 3)
        Pose covariance ``P^m``, symmetric PSD.
    r : float
        Range (m), ``>= 0``.
    phi : float
        Azimuth relative to the heading (rad).
    R : array_like, shape (2, 2)
        Covariance of ``[r, phi]``, symmetric PSD.

    Returns
    -------
    W : ndarray, shape (2, 2)
        ``F_x P^m F_x^T + F_s R F_s^T`` (m^2).

    Raises
    ------
    InputError
        Naming the offending argument (shape, non-finite value, negative range, non-PSD matrix).
    """
    pose = as_array("pose", pose, (3,))
    pose_cov = as_spd("pose_cov", pose_cov, 3)
    r = as_scalar("r", r, low=0.0)
    phi = as_scalar("phi", phi)
    R = as_spd("R", R, 2)
    return _converted_measurement_covs(pose, pose_cov, np.array(((r, phi),)), R)[0]


def converted_measurement_covs(pose: np.ndarray, pose_cov: np.ndarray, polar: np.ndarray,
                               R: np.ndarray) -> np.ndarray:
    """Seed eq. (5) for every detection of a scan.

    Parameters
    ----------
    pose : array_like, shape (3,)
        Platform pose ``[x, y, theta]``.
    pose_cov : array_like, shape (3, 3)
        Pose covariance, symmetric PSD.
    polar : array_like, shape (m, 2)
        Detections ``[range (m), azimuth (rad)]``; ranges ``>= 0``; ``m`` may be 0.
    R : array_like, shape (2, 2)
        Covariance of one ``[range, azimuth]`` detection, symmetric PSD.

    Returns
    -------
    Ws : ndarray, shape (m, 2, 2)
        ``W(i)`` for each detection.

    Raises
    ------
    InputError
        Naming the offending argument.
    """
    pose = as_array("pose", pose, (3,))
    pose_cov = as_spd("pose_cov", pose_cov, 3)
    polar = _as_polar(polar)
    R = as_spd("R", R, 2)
    return _converted_measurement_covs(pose, pose_cov, polar, R)


def _as_polar(polar: object) -> np.ndarray:
    arr = np.asarray(polar, dtype=np.float64) if not isinstance(polar, np.ndarray) else polar
    if arr.size == 0 and arr.ndim <= 2:
        return np.empty((0, 2))
    arr = as_array("polar", arr, (None, 2))
    if np.any(arr[:, 0] < 0):
        raise InputError(f"polar: expected ranges >= 0, got min {arr[:, 0].min()}")
    return arr


def _w_entries(c, s, r, p00: float, p01: float, p02: float, p11: float,
               p12: float, q22: float, r00: float, r01: float) -> tuple:
    """``(W11, W12, W22)`` of seed eq. (5), expanded; ``c, s, r`` floats or (m,) arrays.

    ``c, s = cos, sin(theta + phi)``. With ``j = [-r s, r c]`` (the third column of ``F_x``,
    seed eq. (6), and also the second column of ``F_s``, seed eq. (7)), ``f1 = [c, s]`` (the first
    column of ``F_s``), ``g = [P02, P12]`` and ``q22 = P22 + R11``:

        F_x P F_x^T = P_xy + j g^T + g j^T + P22 j j^T,
        F_s R F_s^T = R00 f1 f1^T + R01 (f1 j^T + j f1^T) + R11 j j^T,

    and ``u = g + R01 f1`` collects the cross terms.
    """
    j0 = -r * s
    j1 = r * c
    u0 = p02 + r01 * c
    u1 = p12 + r01 * s
    w00 = p00 + r00 * c * c + 2.0 * j0 * u0 + q22 * j0 * j0
    w01 = p01 + r00 * c * s + j0 * u1 + j1 * u0 + q22 * j0 * j1
    w11 = p11 + r00 * s * s + 2.0 * j1 * u1 + q22 * j1 * j1
    return w00, w01, w11


def _converted_measurement_covs(pose: np.ndarray, pose_cov: np.ndarray, polar: np.ndarray,
                                R: np.ndarray) -> np.ndarray:
    """Kernel of :func:`converted_measurement_covs` (seed eqs. (5)-(7)); no validation.

    Contract: ``pose`` (3,), ``pose_cov`` (3, 3) symmetric, ``polar`` (m, 2), ``R`` (2, 2)
    symmetric, all finite float64. Returns a new (m, 2, 2) array.

    The same expanded formula (:func:`_w_entries`) runs as a plain-float loop for
    ``m <= _VECTORISE_FROM`` and on numpy arrays beyond: measured 4.5-5 us (loop) against 15 us
    (arrays) for m = 6; break-even near m = 20, where both take about 15 us.
    """
    theta = float(pose[2])
    (p00, p01, p02), (_, p11, p12), (_, _, p22) = pose_cov.tolist()
    (r00, r01), (_, r11) = R.tolist()
    q22 = p22 + r11
    m = polar.shape[0]
    if m > _VECTORISE_FROM:
        ang = polar[:, 1] + theta
        w00, w01, w11 = _w_entries(np.cos(ang), np.sin(ang), polar[:, 0], p00, p01, p02, p11, p12, q22, r00, r01)
        out = np.empty((m, 2, 2))
        out[:, 0, 0] = w00
        out[:, 0, 1] = w01
        out[:, 1, 0] = w01
        out[:, 1, 1] = w11
        return out
    if m == 0:
        return np.empty((0, 2, 2))
    flat = []
    for r, phi in polar.tolist():
        ang = theta + phi
        w00, w01, w11 = _w_entries(math.cos(ang), math.sin(ang), r, p00, p01, p02, p11, p12, q22, r00, r01)
        flat += (w00, w01, w01, w11)
    return np.array(flat).reshape(m, 2, 2)  # a flat list converts ~3x faster than nested tuples


def select_scan_W(Ws: np.ndarray, mode: str = "max_trace") -> np.ndarray:
    """Reduce a scan's ``W(i)`` to the one ``W`` of seed eq. (12) (docs/method.md a.2, h.3).

    Parameters
    ----------
    Ws : array_like, shape (m, 2, 2)
        Per-detection covariances, each symmetric PSD; ``m >= 1``.
    mode : {"max_trace", "max_det", "mean"}
        ``"max_trace"`` (default, Decision 3): the ``W(i)`` of largest trace; ``"max_det"``: of
        largest determinant; ``"mean"``: their mean. Ties go to the first.

    Returns
    -------
    W : ndarray, shape (2, 2)
        A new array.

    Raises
    ------
    InputError
        For an unknown ``mode``, or ``Ws`` of the wrong shape, empty, non-finite or not PSD.
    """
    if mode not in W_MODES:
        raise InputError(f"mode: expected one of {W_MODES}, got {mode!r}")
    Ws = as_array("Ws", Ws, (None, 2, 2))
    if Ws.shape[0] == 0:
        raise InputError("Ws: expected at least one covariance, got shape (0, 2, 2)")
    scale = max(1.0, float(np.max(np.abs(Ws))))
    asym = float(np.max(np.abs(Ws - Ws.transpose(0, 2, 1))))
    if asym > 1e-9 * scale:
        raise InputError(f"Ws: expected symmetric matrices, got asymmetry {asym:.3g}")
    lam_min = float(np.linalg.eigvalsh(Ws)[:, 0].min())
    if lam_min < -1e-9 * scale:
        raise InputError(f"Ws: expected positive semi-definite matrices, got smallest eigenvalue {lam_min:.3g}")
    return _select_scan_W(Ws, mode)


def _select_scan_W(Ws: np.ndarray, mode: str = "max_trace") -> np.ndarray:
    """Kernel of :func:`select_scan_W`; no validation (``Ws`` (m, 2, 2) with m >= 1, valid mode)."""
    if mode == "max_trace":
        return Ws[int(np.argmax(Ws[:, 0, 0] + Ws[:, 1, 1]))].copy()
    if mode == "max_det":
        det = Ws[:, 0, 0] * Ws[:, 1, 1] - Ws[:, 0, 1] * Ws[:, 1, 0]
        return Ws[int(np.argmax(det))].copy()
    return Ws.mean(axis=0)


def _scan_W(pose: np.ndarray, pose_cov: np.ndarray, polar: np.ndarray, R: np.ndarray,
            mode: str = "max_trace") -> np.ndarray:
    """``_select_scan_W(_converted_measurement_covs(...), mode)`` fused, for the SLAM loop.

    Contract as :func:`_converted_measurement_covs`, with ``m >= 1`` and a valid ``mode``. For
    ``"max_trace"`` only the selected ``W(i)`` is built: since rotations keep the trace and
    ``|j|^2 = r^2``,

        tr W(i) = P00 + P11 + R00 + 2 r (-s P02 + c P12) + (P22 + R11) r^2,

    (2.6 us for m = 6, against 8 us for building all and selecting). A plain-float loop: meant
    for one landmark's detections in one scan (a handful).
    """
    if mode != "max_trace":
        w00, w01, w11 = scan_w_entries(np.asarray(pose, dtype=float), np.asarray(pose_cov, dtype=float),
                                       np.asarray(polar, dtype=float).reshape(-1, 2), np.asarray(R, dtype=float),
                                       W_MODES.index(mode))
        return np.array(((w00, w01), (w01, w11)))
    (p00, p01, p02), (_, p11, p12), (_, _, p22) = pose_cov.tolist()
    (r00, r01), (_, r11) = R.tolist()
    w00, w01, w11 = max_trace_w_entries(float(pose[2]), p00, p01, p02, p11, p12, p22, r00, r01, r11, polar.tolist())
    return np.array(((w00, w01), (w01, w11)))


def scan_w_entries(pose, pose_cov, pol, R, mode):
    """Entries ``(W11, W12, W22)`` of the scan's one ``W`` (seed eq. 12, h.3) from the ``W(i)`` of the
    detections ``pol`` (m, 2), ``m >= 1``: ``mode`` :data:`W_MAX_TRACE` the one of largest trace
    (:func:`max_trace_w_entries`), :data:`W_MAX_DET` of largest determinant, :data:`W_MEAN` their
    mean; first on ties. A kernel: the estimators' own methods (:func:`_scan_W`) and the fused
    engine's extent step call it."""
    p00, p01, p02 = pose_cov[0, 0], pose_cov[0, 1], pose_cov[0, 2]
    p11, p12, p22 = pose_cov[1, 1], pose_cov[1, 2], pose_cov[2, 2]
    r00, r01, r11 = R[0, 0], R[0, 1], R[1, 1]
    if mode == W_MAX_TRACE:
        return max_trace_w_entries(pose[2], p00, p01, p02, p11, p12, p22, r00, r01, r11, pol)
    q22 = p22 + r11
    best = -math.inf
    a00, a01, a11 = 0.0, 0.0, 0.0
    for i in range(pol.shape[0]):
        ang = pose[2] + pol[i, 1]
        w00, w01, w11 = _w_entries(math.cos(ang), math.sin(ang), pol[i, 0], p00, p01, p02, p11, p12, q22, r00, r01)
        if mode == W_MAX_DET:
            d = w00 * w11 - w01 * w01
            if d > best:
                best = d
                a00, a01, a11 = w00, w01, w11
        else:
            a00 += w00
            a01 += w01
            a11 += w11
    if mode == W_MEAN:
        m = pol.shape[0]
        a00, a01, a11 = a00 / m, a01 / m, a11 / m
    return a00, a01, a11


def max_trace_w_entries(theta: float, p00: float, p01: float, p02: float, p11: float, p12: float, p22: float,
                        r00: float, r01: float, r11: float, polar) -> tuple[float, float, float]:
    """Entries of the ``W(i)`` of largest trace among the detections ``polar`` (a list of
    ``[r, phi]`` or an (m, 2) array, ``m >= 1``), first on ties; ``p..`` the pose covariance and
    ``r..`` R. A kernel: :func:`_scan_W` calls it on a list, the compiled backend compiles it."""
    q22 = p22 + r11
    best = -math.inf
    br, bc, bs = 0.0, 1.0, 0.0
    for r, phi in polar:
        ang = theta + phi
        c = math.cos(ang)
        s = math.sin(ang)
        tr = r * (2.0 * (p12 * c - p02 * s) + q22 * r)  # the trace up to its constant part
        if tr > best:
            best = tr
            br, bc, bs = r, c, s
    return _w_entries(bc, bs, br, p00, p01, p02, p11, p12, q22, r00, r01)
