"""Trajectory alignment and error against position fixes (GPS)."""

from __future__ import annotations

import numpy as np

from radarslam.core.errors import InputError


def rigid_align_2d(est: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least-squares rotation ``R`` (2, 2) and translation ``t`` (2,) with ``R est + t ~ ref``.

    Kabsch / Umeyama without scale: the SVD of the cross-covariance, with the reflection removed.
    ``est`` and ``ref`` are matched point sets ``(n, 2)``, ``n >= 2``.
    """
    mu_e, mu_r = est.mean(axis=0), ref.mean(axis=0)
    H = (est - mu_e).T @ (ref - mu_r)
    U, _, Vt = np.linalg.svd(H)
    D = np.diag([1.0, np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0])
    R = Vt.T @ D @ U.T
    return R, mu_r - R @ mu_e


def robust_rigid_align_2d(est: np.ndarray, ref: np.ndarray, *, k: float = 4.0, floor: float = 2.0,
                          max_iter: int = 20) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`rigid_align_2d` with iterative outlier rejection.

    Pairs whose residual exceeds ``max(floor, k * 1.4826 * MAD)`` (m) are dropped and the fit is
    repeated until the inlier set stops changing. Returns ``(R, t, inliers)``.
    """
    inl = np.ones(est.shape[0], dtype=bool)
    for _ in range(max_iter):
        R, t = rigid_align_2d(est[inl], ref[inl])
        res = np.linalg.norm(est @ R.T + t - ref, axis=1)
        med = np.median(res[inl])
        thr = max(floor, k * 1.4826 * np.median(np.abs(res[inl] - med)) + med)
        new = res <= thr
        if np.array_equal(new, inl) or new.sum() < 3:
            break
        inl = new
    return R, t, inl


def error_against_fixes(times: np.ndarray, positions: np.ndarray, fix_t: np.ndarray, fix_xy: np.ndarray,
                        robust: bool = False, max_speed: float | None = None) -> dict:
    """Align an estimated track to position fixes and report the error.

    The track (``times`` (K,), ``positions`` (K, 2)) is linearly interpolated at each fix time
    within its span; the fixes are then aligned by a least-squares 2-D rigid transform. With
    ``max_speed`` the fixes that the GPS track itself shows to be jumps
    (:func:`gps_speed_outliers`) are left out first. ``robust`` additionally rejects pairs by their
    residual to the estimate; it flatters a drifting estimate and is off by default.

    Besides the errors, the result holds the fixes within the track's span, ``span_xy`` (M, 2), the
    jump flags over them, ``span_jumps`` (M,) (all False without ``max_speed``), and ``max_speed``,
    so that a plot can draw them without recomputing anything.
    """
    m = (fix_t >= times[0]) & (fix_t <= times[-1])
    ft, fxy = fix_t[m], fix_xy[m]
    jumps = gps_speed_outliers(ft, fxy, max_speed) if max_speed is not None else np.zeros(ft.size, dtype=bool)
    span = {"span_xy": fxy, "span_jumps": jumps, "max_speed": max_speed}
    ft, fxy = ft[~jumps], fxy[~jumps]
    est = np.column_stack([np.interp(ft, times, positions[:, 0]), np.interp(ft, times, positions[:, 1])])
    if ft.size < 3:
        return {"n_fixes": int(ft.size), "rmse_m": float("nan"), "max_m": float("nan"), **span}
    if robust:
        R, t, inl = robust_rigid_align_2d(est, fxy)
    else:
        R, t = rigid_align_2d(est, fxy)
        inl = np.ones(ft.size, dtype=bool)
    err = np.linalg.norm(est @ R.T + t - fxy, axis=1)
    return {
        "n_fixes": int(ft.size),
        "n_gps_jumps_removed": int(jumps.sum()),
        "n_inliers": int(inl.sum()),
        "rmse_m": float(np.sqrt(np.mean(err[inl] ** 2))),
        "max_m": float(err[inl].max()),
        "median_m": float(np.median(err[inl])),
        "rmse_all_m": float(np.sqrt(np.mean(err**2))),
        "rotation_deg": float(np.degrees(np.arctan2(R[1, 0], R[0, 0]))),
        "translation_m": t,
        "fix_t": ft,
        "errors_m": err,
        "inliers": inl,
        "R": R,
        **span,
    }


def gps_speed_outliers(t: np.ndarray, xy: np.ndarray, max_speed: float = 8.0) -> np.ndarray:
    """Fixes inconsistent with the GPS track itself: ``True`` where a fix implies a speed above
    ``max_speed`` (m/s) from the last accepted fix (a greedy forward pass).

    This uses only the fixes, never the estimate under evaluation, so it cannot hide estimation
    error (a residual-based robust fit would reject exactly the stretches where the estimate drifts).
    """
    bad = np.zeros(t.size, dtype=bool)
    last = 0
    for i in range(1, t.size):
        dt = t[i] - t[last]
        if dt <= 0 or np.hypot(*(xy[i] - xy[last])) > max_speed * dt:
            bad[i] = True
        else:
            last = i
    return bad


#: Time stamps on a millisecond grid land exactly on the tolerance; rounding must not decide them.
TIE_S = 1e-9


def error_at_fixes(times: np.ndarray, positions: np.ndarray, fix_t: np.ndarray, fix_xy: np.ndarray,
                   tolerance: float = 0.025) -> dict:
    """Position error without any alignment, at every estimate whose time lies within ``tolerance``
    seconds of a fix (the nearest fix; every fix kept, jumps included): the published Victoria Park
    protocol (docs/method.md v.4).

    Parameters
    ----------
    times : (K,) estimate times (s), ascending.
    positions : (K, 2) estimated positions in the fixes' frame.
    fix_t, fix_xy : (n,), (n, 2) fix times (ascending) and positions.
    tolerance : float
        Largest |t_estimate - t_fix| that counts (s).

    Returns
    -------
    dict
        ``rmse_m``, ``max_m``, ``median_m`` over the matched estimates, ``n_matched``, and per match
        ``index`` (estimate), ``fix`` (fix index), ``errors_m``.
    """
    times = np.asarray(times, dtype=float)
    positions = np.asarray(positions, dtype=float)
    fix_t = np.asarray(fix_t, dtype=float)
    fix_xy = np.asarray(fix_xy, dtype=float)
    if times.ndim != 1 or positions.shape != (times.size, 2):
        raise InputError(f"positions: expected shape ({times.size}, 2) matching times, got {positions.shape}")
    if fix_t.ndim != 1 or fix_xy.shape != (fix_t.size, 2) or fix_t.size == 0:
        raise InputError(f"fix_xy: expected shape (n >= 1, 2) matching fix_t, got {fix_xy.shape}")
    if not tolerance >= 0:
        raise InputError(f"tolerance: expected a value >= 0, got {tolerance!r}")
    right = np.clip(np.searchsorted(fix_t, times), 0, fix_t.size - 1)
    left = np.clip(right - 1, 0, fix_t.size - 1)
    nearest = np.where(np.abs(fix_t[left] - times) <= np.abs(fix_t[right] - times), left, right)
    ok = np.abs(fix_t[nearest] - times) <= tolerance + TIE_S   # a time exactly at the edge is within
    idx = np.flatnonzero(ok)
    err = np.hypot(*(positions[idx] - fix_xy[nearest[idx]]).T) if idx.size else np.empty(0)
    nan = float("nan")
    return {"rmse_m": float(np.sqrt(np.mean(err ** 2))) if err.size else nan,
            "max_m": float(err.max()) if err.size else nan, "median_m": float(np.median(err)) if err.size else nan,
            "n_matched": int(idx.size), "index": idx, "fix": nearest[idx], "errors_m": err}
