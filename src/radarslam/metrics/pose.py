"""Platform pose errors (docs/method.md f.1) and consistency (NEES)."""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_pi


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
