"""Statistics over Monte Carlo runs: the trial bootstrap and the RMSE over defined values (docs/method.md f.1, f.2).

Definitions ([PROP]):

- *trial bootstrap*: resample the R runs with replacement B times; a statistic's bootstrap
  replicates are its values on the resamples. Its ``level`` confidence interval is the *percentile
  interval*: the ``(1 - level) / 2`` and ``(1 + level) / 2`` quantiles of the replicates. A *paired*
  bootstrap uses the same resamples (one :func:`bootstrap_counts` matrix) for every configuration
  run on the same data, so ratios of their replicates keep the pairing.
- *avg. RMSE* of a resample: ``mean_k sqrt(mean over the resampled runs of e_{r,k}^2)``
  (:func:`radarslam.metrics.pose.avg_rmse` on the resampled rows).
- *RMSE over defined values* at step k: ``sqrt(mean over the runs with a finite value of g_{r,k}^2)``.
- *Clopper-Pearson interval* of a count ``k`` of ``n`` trials: the exact binomial interval from the
  beta quantiles (:func:`clopper_pearson`).

This module depends on numpy (and scipy's beta quantile for :func:`clopper_pearson`); the random
draws come from the ``numpy.random.Generator`` passed in.
"""

from __future__ import annotations

import numpy as np

from radarslam.core.errors import InputError


def bootstrap_counts(n_runs: int, n_boot: int, rng: np.random.Generator) -> np.ndarray:
    """How often each run is drawn in each bootstrap resample.

    Parameters
    ----------
    n_runs, n_boot : int
        Runs R (>= 1) and resamples B (>= 1).
    rng : numpy.random.Generator

    Returns
    -------
    ndarray of float, shape (n_boot, n_runs)
        Row b holds the multiplicities of ``rng.integers(0, n_runs, n_runs)``; every row sums to ``n_runs``.
    """
    for name, v in (("n_runs", n_runs), ("n_boot", n_boot)):
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < 1:
            raise InputError(f"{name}: expected an integer >= 1, got {v!r}")
    if not isinstance(rng, np.random.Generator):
        raise InputError(f"rng: expected a numpy.random.Generator, got {type(rng).__name__}")
    idx = rng.integers(0, n_runs, size=(n_boot, n_runs))
    flat = idx + n_runs * np.arange(n_boot)[:, None]
    return np.bincount(flat.ravel(), minlength=n_boot * n_runs).reshape(n_boot, n_runs).astype(float)


def bootstrap_avg_rmse(errors: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """avg. RMSE of every bootstrap resample.

    Parameters
    ----------
    errors : ndarray, shape (R, K)
    counts : ndarray, shape (B, R)
        From :func:`bootstrap_counts`.

    Returns
    -------
    ndarray, shape (B,)
        ``avg_rmse(errors[resample_b])`` for each b (computed as a weighted mean, so no (B, R, K) copy).
    """
    e2 = np.asarray(errors, dtype=float) ** 2
    counts = np.asarray(counts, dtype=float)
    if e2.ndim != 2 or counts.ndim != 2 or counts.shape[1] != e2.shape[0]:
        raise InputError(f"counts: expected shape (B, {e2.shape[0] if e2.ndim == 2 else 'R'}) for errors of shape "
                         f"{e2.shape}, got {counts.shape}")
    ms = counts @ e2 / counts.sum(axis=1, keepdims=True)
    return np.sqrt(ms).mean(axis=1)


def percentile_interval(samples: np.ndarray, level: float = 0.95) -> list[float]:
    """Percentile interval ``[q_{(1-level)/2}, q_{(1+level)/2}]`` of bootstrap replicates.

    Parameters
    ----------
    samples : ndarray, shape (B,)
    level : float
        Confidence level in (0, 1).
    """
    if not 0.0 < level < 1.0:
        raise InputError(f"level: expected a probability in (0, 1), got {level!r}")
    a = 100.0 * (1.0 - level) / 2.0
    lo, hi = np.percentile(np.asarray(samples, dtype=float), [a, 100.0 - a])
    return [float(lo), float(hi)]


def rmse_over_defined(g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """RMSE over runs of a per-step quantity that is NaN where undefined.

    Parameters
    ----------
    g : ndarray, shape (R, K)

    Returns
    -------
    rmse : ndarray, shape (K,)
        ``sqrt(mean over runs with a finite value of g^2)``; NaN where no run has one.
    n_runs : ndarray of int, shape (K,)
    """
    g = np.asarray(g, dtype=float)
    if g.ndim != 2:
        raise InputError(f"g: expected shape (R, K), got {g.shape}")
    ok = np.isfinite(g)
    n = ok.sum(axis=0)
    s = np.where(ok, g, 0.0) ** 2
    rmse = np.full(g.shape[1], np.nan)
    has = n > 0
    rmse[has] = np.sqrt(s.sum(axis=0)[has] / n[has])
    return rmse, n.astype(int)


def clopper_pearson(k: int, n: int, level: float = 0.95) -> list[float]:
    """The exact (Clopper-Pearson) ``level`` interval of a binomial proportion from ``k`` of ``n``:
    ``[B((1-level)/2; k, n-k+1), B((1+level)/2; k+1, n-k)]`` (``B`` the beta quantile), 0 and 1 at the ends."""
    if not (isinstance(n, (int, np.integer)) and n >= 1 and isinstance(k, (int, np.integer)) and 0 <= k <= n):
        raise InputError(f"k, n: expected integers with 0 <= k <= n and n >= 1, got {k!r}, {n!r}")
    if not 0.0 < level < 1.0:
        raise InputError(f"level: expected a probability in (0, 1), got {level!r}")
    from scipy.stats import beta

    a = (1.0 - level) / 2.0
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1.0 - a, k + 1, n - k))
    return [lo, hi]
