"""Platform pose errors (docs/method.md f.1) and consistency (NEES): of Monte Carlo runs
(:func:`chi2_band` of the average over runs) and of one recorded run against its truth
(:func:`pose_nees_summary`, docs/recordings.md "What metrics.json holds")."""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_pi
from radarslam.core.errors import InputError

#: Largest ``|P - P^T|`` relative to ``max |P|`` taken as rounding (a filter's covariance is symmetric
#: to rounding only).
SYMMETRY_RTOL = 1e-8
#: Smallest eigenvalue, relative to the largest, of a covariance taken as positive definite.
DEFINITE_RTOL = 1e-12


def pose_errors(estimated: np.ndarray, true: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-step position error norm (m) and heading error wrapped to (-pi, pi] (rad), each ``(K,)``."""
    d = estimated[:, :2] - true[:, :2]
    return np.hypot(d[:, 0], d[:, 1]), wrap_pi(estimated[:, 2] - true[:, 2])


def avg_rmse(errors: np.ndarray) -> float:
    """f.1 [PROP] "avg. RMSE": the mean over k of sqrt(mean over runs of e_{r,k}^2).

    Parameters
    ----------
    errors : ndarray, shape (R, K) or (K,)
        Position error norms or heading errors; a 1-D input is a single run.
    """
    e = np.atleast_2d(errors)
    return float(np.mean(np.sqrt(np.mean(e * e, axis=0))))


def pose_nees(estimated: np.ndarray, covs: np.ndarray, true: np.ndarray) -> np.ndarray:
    """Normalised estimation error squared ``e^T P^-1 e`` of the 3-D pose per step, ``(K,)``."""
    e = estimated - true
    e[:, 2] = wrap_pi(e[:, 2])
    sol = np.linalg.solve(covs, e[:, :, None])[:, :, 0]
    return np.einsum("ki,ki->k", e, sol)


def chi2_band(dof: int, n_runs: int, prob: float = 0.95) -> tuple[float, float]:
    """Two-sided ``prob`` band of the average NEES over ``n_runs`` runs (each chi^2 with ``dof``).

    ``n_runs * mean NEES ~ chi^2(n_runs * dof)``.
    """
    from scipy.stats import chi2

    a = (1.0 - prob) / 2.0
    n = n_runs * dof
    return float(chi2.ppf(a, n) / n_runs), float(chi2.ppf(1.0 - a, n) / n_runs)


def degrees(x: float) -> float:
    return x * 180.0 / math.pi


def checked_nees_covs(covs: np.ndarray, name: str = "pose_covs", index=None) -> np.ndarray:
    """``covs`` (K, 3, 3) as float, refused in one line naming ``name[k]`` (``k`` the row, or
    ``index[row]``) when a row is not finite, not symmetric (to :data:`SYMMETRY_RTOL`) or not positive
    definite (to :data:`DEFINITE_RTOL`); an all-zero row (a pose held exact: the anchored frame's
    first scan, docs/method.md b.5.1) passes."""
    c = np.asarray(covs, dtype=float)
    if c.ndim != 3 or c.shape[1:] != (3, 3):
        raise InputError(f"{name}: expected shape (K, 3, 3), got {c.shape}")
    at = (lambda row: int(row)) if index is None else (lambda row: int(index[row]))
    bad = ~np.all(np.isfinite(c), axis=(1, 2))
    if bad.any():
        raise InputError(f"{name}[{at(np.argmax(bad))}]: expected a finite covariance, got NaN or inf")
    scale = np.abs(c).max(axis=(1, 2), initial=0.0)
    asym = np.abs(c - np.swapaxes(c, 1, 2)).max(axis=(1, 2), initial=0.0)
    bad = asym > SYMMETRY_RTOL * scale
    if bad.any():
        r = int(np.argmax(bad))
        raise InputError(f"{name}[{at(r)}]: expected a symmetric covariance, got |P - P^T| = {asym[r]:.3g} "
                         f"(max |P| {scale[r]:.3g})")
    lam = np.linalg.eigvalsh(0.5 * (c + np.swapaxes(c, 1, 2))) if c.shape[0] else np.empty((0, 3))
    bad = (scale > 0) & (lam[:, 0] <= DEFINITE_RTOL * lam[:, -1])
    if bad.any():
        r = int(np.argmax(bad))
        raise InputError(f"{name}[{at(r)}]: expected a positive definite covariance, got eigenvalues "
                         f"{', '.join(f'{v:.3g}' for v in lam[r])}")
    return c


def pose_nees_summary(estimated: np.ndarray, covs: np.ndarray, true: np.ndarray, truth_std=(0.0, 0.0, 0.0),
                      prob: float = 0.95, name: str = "pose_covs") -> dict:
    """The 3-dof pose NEES of one run at every scan against its truth (:func:`pose_nees`: the heading
    error wrapped to (-pi, pi]), with the covariance ``P_k + diag(truth_std^2)`` (the truth's own
    accuracy added), and its chi-square bands. A row where ``true`` is NaN has no NEES, nor one whose
    summed covariance is zero (a pose held exact against an exact truth).

    Parameters
    ----------
    estimated, true : ndarray, shape (K, 3)
        Matched poses ``x_m, y_m, theta_rad``.
    covs : ndarray, shape (K, 3, 3)
        The estimate's covariances; with the truth's added, symmetric positive definite at every row
        with a truth (:func:`checked_nees_covs`, refused in one line naming ``name[k]``).
    truth_std : sequence of 3 float
        The truth's std ``[x_m, y_m, theta_rad]``, each >= 0.
    prob : float
        Two-sided probability of the bands.

    Returns
    -------
    dict
        ``per_scan`` (K,) (NaN without a NEES); ``scans`` with one; ``time_average`` (their mean);
        ``dof`` 3; ``probability``; ``band_per_scan`` ``[chi2.ppf((1-prob)/2, 3), chi2.ppf((1+prob)/2, 3)]``;
        ``share_inside_band``, ``share_below_band``, ``share_above_band`` of the scans with one;
        ``band_time_average`` :func:`chi2_band` ``(3, scans)`` (``chi2(3 K) / K``: K independent scans);
        ``time_average_inside_band``; ``exact_pose_scans``, the rows left out for a zero covariance;
        ``components`` (:func:`nees_components`): which direction the filter misjudges.
    """
    est, true, covs = (np.asarray(a, dtype=float) for a in (estimated, true, covs))
    K = est.shape[0] if est.ndim == 2 else -1
    if est.shape != (K, 3) or true.shape != (K, 3) or covs.shape != (K, 3, 3):
        raise InputError(f"estimated, true, {name}: expected shapes (K, 3), (K, 3), (K, 3, 3), got {est.shape}, "
                         f"{true.shape}, {covs.shape}")
    std = np.asarray(truth_std, dtype=float)
    if std.shape != (3,) or not np.all(np.isfinite(std)) or np.any(std < 0):
        raise InputError(f"truth_std: expected 3 values >= 0 [x_m, y_m, theta_rad], got {np.ravel(std).tolist()}")
    if not 0.0 < prob < 1.0:
        raise InputError(f"prob: expected a probability in (0, 1), got {prob!r}")
    rows = np.flatnonzero(np.all(np.isfinite(true), axis=1))
    bad = ~np.all(np.isfinite(est[rows]), axis=1)
    if bad.any():
        raise InputError(f"estimated[{int(rows[np.argmax(bad)])}]: expected a finite pose, got NaN or inf")
    total = covs[rows] + np.diag(std ** 2)
    checked_nees_covs(total, name if not std.any() else f"{name} + diag(truth_std^2)", index=rows)
    held = ~np.all(total == 0.0, axis=(1, 2))
    rows, total = rows[held], total[held]
    nees = np.full(K, np.nan)
    if rows.size:
        nees[rows] = pose_nees(est[rows], total, true[rows])
    return {**nees_bands(nees, prob), "exact_pose_scans": int(held.size - rows.size),
            "components": nees_components(est[rows], total, true[rows], prob)}


#: The pose's directions of :func:`nees_components`, in the order of their rows.
COMPONENTS = ("along_track", "cross_track", "heading")


def nees_components(est: np.ndarray, covs: np.ndarray, true: np.ndarray, prob: float = 0.95) -> dict:
    """The 1-dof NEES of the position error along and across the true heading and of the heading
    error, each against its own variance (the covariance turned into the true heading's frame:
    ``u^T P_xy u`` with ``u = (cos theta, sin theta)`` along, ``(-sin theta, cos theta)`` across), time
    averaged, with the chi-square band of the time average (1 dof per scan), the RMS error (m; the
    heading's in deg) and the RMS std. A consistent filter has each near 1; the 3-dof NEES alone does
    not say which direction the filter misjudges."""
    if not est.shape[0]:
        return {}
    e = est - true
    e[:, 2] = wrap_pi(e[:, 2])
    c, s = np.cos(true[:, 2]), np.sin(true[:, 2])
    dirs = (np.column_stack([c, s]), np.column_stack([-s, c]))
    errs = [np.einsum("ki,ki->k", u, e[:, :2]) for u in dirs] + [e[:, 2]]
    var = [np.einsum("ki,kij,kj->k", u, covs[:, :2, :2], u) for u in dirs] + [covs[:, 2, 2]]
    band = list(chi2_band(1, int(est.shape[0]), prob))
    out = {}
    for name, err, v, unit in zip(COMPONENTS, errs, var, (1.0, 1.0, 180.0 / math.pi)):
        keep = v > 0.0
        avg = float(np.mean(err[keep] ** 2 / v[keep])) if keep.any() else float("nan")
        out[name] = {"time_average": avg, "band_time_average": band,
                     "rms_error": float(unit * np.sqrt(np.mean(err * err))), "rms_std": float(unit * np.sqrt(np.mean(v)))}
    return out


def nees_bands(nees: np.ndarray, prob: float = 0.95, dof: int = 3) -> dict:
    """A run's per-scan NEES ``nees`` (K,) (NaN: none at that scan) against the two-sided ``prob``
    chi-square band of one scan (``dof`` degrees of freedom) and its time average against that of
    the mean of the scans with one (:func:`chi2_band`); the fields of :func:`pose_nees_summary`."""
    from scipy.stats import chi2

    nees = np.asarray(nees, dtype=float)
    v = nees[np.isfinite(nees)]
    a = (1.0 - prob) / 2.0
    lo, hi = float(chi2.ppf(a, dof)), float(chi2.ppf(1.0 - a, dof))
    out = {"dof": dof, "probability": prob, "per_scan": nees, "scans": int(v.size),
           "band_per_scan": [lo, hi], "time_average": float("nan"), "band_time_average": None,
           "share_inside_band": None, "share_below_band": None, "share_above_band": None,
           "time_average_inside_band": None}
    if v.size:
        avg = float(v.mean())
        band = list(chi2_band(dof, int(v.size), prob))
        out.update(time_average=avg, band_time_average=band, time_average_inside_band=bool(band[0] <= avg <= band[1]),
                   share_inside_band=float(np.mean((v >= lo) & (v <= hi))), share_below_band=float(np.mean(v < lo)),
                   share_above_band=float(np.mean(v > hi)))
    return out
