"""Bounds of the consistency statistics the tests assert, derived from the statistics' distributions
at the test's sample size under the hypothesis that the filter is consistent (never from measured
values).

- :func:`nees_band`: ``n`` times the mean of ``n`` independent chi-square(``dof``) values (the NEES
  of a ``dof``-dimensional error over ``n`` trials, the NIS of ``n`` innovations) is
  chi-square(``n dof``); the two-sided ``p`` band of the mean is ``chi2.ppf((1 -+ p) / 2, n dof) / n``.
- :func:`nees_upper_bound`: its one-sided upper quantile ``chi2.ppf(p, n dof) / n`` (a filter whose
  mean lies above it is overconfident).
- :func:`share_lower_bound`: the share of ``n`` independent values that fall inside a region of
  probability ``p`` is Binomial(``n``, ``p``) / ``n``; the bound is its lower ``alpha`` quantile,
  ``binom.ppf(alpha, n, p) / n``. :func:`share_upper_bound` is the upper ``1 - alpha`` quantile and
  :func:`share_band` the two-sided band.

A time average along one trajectory: the per-step values are correlated, so ``T`` steps are not
``T`` independent samples. When every step's value has the distribution above (``n`` runs per
step), their time average has the same mean and is less spread (the mean of identically distributed
values lies below each of them in the convex order), so the tests take the per-step band as the time
average's: conservative in its spread, an approximation in its tails (checked by a Monte Carlo of
correlated steps in tests/test_statistics.py).
"""

from __future__ import annotations

from scipy import stats

__all__ = ["nees_band", "nees_upper_bound", "share_band", "share_lower_bound", "share_upper_bound"]


def nees_band(dof: int, n: int, probability: float = 0.95) -> tuple[float, float]:
    """Two-sided ``probability`` band of the mean of ``n`` independent chi-square(``dof``) values:
    ``(chi2.ppf((1 - p) / 2, n dof) / n, chi2.ppf((1 + p) / 2, n dof) / n)``."""
    if not (dof >= 1 and n >= 1 and 0.0 < probability < 1.0):
        raise ValueError(f"dof, n, probability: expected >= 1, >= 1, in (0, 1), got {dof}, {n}, {probability}")
    lo, hi = stats.chi2.ppf([(1.0 - probability) / 2.0, (1.0 + probability) / 2.0], dof * n) / n
    return float(lo), float(hi)


def nees_upper_bound(dof: int, n: int, probability: float = 0.99) -> float:
    """Upper ``probability`` quantile of the mean of ``n`` independent chi-square(``dof``) values:
    ``chi2.ppf(p, n dof) / n``."""
    if not (dof >= 1 and n >= 1 and 0.0 < probability < 1.0):
        raise ValueError(f"dof, n, probability: expected >= 1, >= 1, in (0, 1), got {dof}, {n}, {probability}")
    return float(stats.chi2.ppf(probability, dof * n)) / n


def share_lower_bound(n: int, p: float = 0.95, alpha: float = 0.01) -> float:
    """Lower ``alpha`` quantile of the share of ``n`` independent values inside a region of
    probability ``p``: ``binom.ppf(alpha, n, p) / n``. The share is below it with probability below
    ``alpha`` (``binom.ppf`` is the least ``k`` with ``P(X <= k) >= alpha``, so ``P(X < k) < alpha``)."""
    if not (n >= 1 and 0.0 < p < 1.0 and 0.0 < alpha < 1.0):
        raise ValueError(f"n, p, alpha: expected >= 1, in (0, 1), in (0, 1), got {n}, {p}, {alpha}")
    return float(stats.binom.ppf(alpha, n, p)) / n


def share_band(n: int, p: float = 0.95, probability: float = 0.99) -> tuple[float, float]:
    """Two-sided ``probability`` band of the share of ``n`` independent values inside a region of
    probability ``p``: ``binom.ppf((1 -+ probability) / 2, n, p) / n``."""
    if not (n >= 1 and 0.0 < p < 1.0 and 0.0 < probability < 1.0):
        raise ValueError(f"n, p, probability: expected >= 1, in (0, 1), in (0, 1), got {n}, {p}, {probability}")
    lo, hi = stats.binom.ppf([(1.0 - probability) / 2.0, (1.0 + probability) / 2.0], n, p) / n
    return float(lo), float(hi)


def share_upper_bound(n: int, p: float, alpha: float = 0.01) -> float:
    """Upper ``1 - alpha`` quantile of the share of ``n`` independent values inside a region of
    probability ``p``: ``binom.ppf(1 - alpha, n, p) / n``; the share exceeds it with probability at
    most ``alpha``."""
    if not (n >= 1 and 0.0 < p < 1.0 and 0.0 < alpha < 1.0):
        raise ValueError(f"n, p, alpha: expected >= 1, in (0, 1), in (0, 1), got {n}, {p}, {alpha}")
    return float(stats.binom.ppf(1.0 - alpha, n, p)) / n
