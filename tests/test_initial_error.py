"""The initial error of a trial (docs/method.md b.5): the paper's fixed offset, or a draw from the
filter's initial covariance on a child of the trial's stream."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy import stats

from radarslam.config import from_dict, profile_config
from radarslam.core.errors import ConfigError
from radarslam.montecarlo.trials import trial_seed
from radarslam.simulation.scenario import generate_scenario, initial_estimate

N_DRAWS = 4000


def _errors(mode: str, n: int = N_DRAWS, seed: int = 777) -> tuple[np.ndarray, np.ndarray]:
    f = replace(profile_config("apsipa").filter, initial_error=mode)
    truth = np.array([1.0, -2.0, 0.3])
    e = np.array([initial_estimate(f, truth, trial_seed(seed, t)) for t in range(1, n + 1)]) - truth
    P1 = np.diag(np.square(f.initial_pose_std))
    return e, P1


def _bartlett(e: np.ndarray, P1: np.ndarray) -> tuple[float, float]:
    """Likelihood-ratio (Bartlett-corrected) statistic of H0: cov(e) = P1 with mean 0, and its 99.9%
    chi-square quantile (6 + 3 = 9 dof: the covariance's 6 entries and the mean's 3)."""
    n, p = e.shape
    W = np.linalg.solve(P1, e.T @ e / n)          # P1^-1 S with S about the known mean 0
    sign, logdet = np.linalg.slogdet(W)
    if sign <= 0:                                  # a singular sample covariance: no draw from P1
        return np.inf, stats.chi2.ppf(0.999, p * (p + 1) / 2 + p)
    lr = n * (np.trace(W) - logdet - p)
    corr = 1.0 - (2 * p * p + 3 * p - 1) / (6.0 * n * (p + 1))
    return corr * lr, stats.chi2.ppf(0.999, p * (p + 1) / 2 + p)


def test_drawn_initial_error_has_the_initial_covariance():
    """4000 seeded draws: mean inside 4 standard errors of 0, every variance within 10% of P_1's,
    correlations below 0.07, and the likelihood-ratio statistic of cov = P_1 below its 99.9% quantile."""
    e, P1 = _errors("draw")
    std = np.sqrt(np.diag(P1))
    assert np.all(np.abs(e.mean(axis=0)) < 4 * std / np.sqrt(N_DRAWS))
    S = np.cov(e.T)
    assert np.allclose(np.diag(S) / np.diag(P1), 1.0, atol=0.1)
    corr = S / np.sqrt(np.outer(np.diag(S), np.diag(S)))
    assert np.max(np.abs(corr - np.eye(3))) < 0.07
    stat, q = _bartlett(e, P1)
    assert stat < q, (stat, q)


def test_fixed_initial_error_is_the_same_offset_and_fails_the_covariance_test():
    """Negative control: "fixed" gives initial_pose in every trial (zero spread), which the same
    statistic rejects by orders of magnitude; a covariance twice P_1 is rejected too."""
    f = profile_config("apsipa").filter
    e_fixed = np.array([initial_estimate(f, np.zeros(3), trial_seed(777, t)) for t in range(1, 200)])
    assert np.all(e_fixed == np.array(f.initial_pose))
    stat, q = _bartlett(e_fixed, np.diag(np.square(f.initial_pose_std)))
    assert stat > 1e3 * q
    e, P1 = _errors("draw")
    stat, q = _bartlett(np.sqrt(2.0) * e, P1)
    assert stat > 5 * q


def test_the_draw_does_not_disturb_the_trial_stream_and_is_reproducible():
    """The trial's simulated data are the same bit for bit with "draw" and "fixed" (the draw comes
    from a child stream); the same trial draws the same error, another trial another."""
    cfg = replace(profile_config("apsipa"), trajectory=replace(profile_config("apsipa").trajectory, n_steps=5))
    a = generate_scenario(cfg, np.random.default_rng(trial_seed(777, 3)))
    f = replace(cfg.filter, initial_error="draw")
    e1 = initial_estimate(f, a.truth.poses[0], trial_seed(777, 3))
    b = generate_scenario(cfg, np.random.default_rng(trial_seed(777, 3)))
    assert np.array_equal(a.truth.poses, b.truth.poses)
    assert all(np.array_equal(x.polar, y.polar) for x, y in zip(a.scans, b.scans))
    assert e1 == initial_estimate(f, a.truth.poses[0], trial_seed(777, 3))
    assert e1 != initial_estimate(f, a.truth.poses[0], trial_seed(777, 4))


def test_initial_error_key_is_checked():
    with pytest.raises(ConfigError, match=r"filter.initial_error: expected one of \['fixed', 'draw'\], got 'random'"):
        from_dict({"filter": {"initial_error": "random"}})
