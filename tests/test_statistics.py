"""Monte Carlo properties of the whole pipeline (fixed seeds, real bounds, negative controls).

The pipeline's are marked slow; ``RADARSLAM_SLOW_SCALE`` scales their trial counts (CI uses 0.25).
The quick ones at the end check the bounds of tests/consistency_bounds.py by Monte Carlo.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.simulation.trial import run_trial
from radarslam.metrics.pose import avg_rmse

from conftest import scaled
from consistency_bounds import nees_band, nees_upper_bound, share_band, share_lower_bound, share_upper_bound

# Decision 1: both profiles without extent put the position avg. RMSE near 1.21 m and the heading
# near 3.5 deg; the band of the issue is 1.0-1.45 m and 2.9-4.2 deg. With few trials the estimate
# is noisier, so the bands below are widened by the spread measured over disjoint 15-trial blocks
# (position +-0.2 m, heading +-0.6 deg at 15 trials).
POS_BAND = (0.8, 1.65)
HEAD_BAND = (2.3, 4.8)


def _mc(cfg, n, seed0=1):
    pos, head = [], []
    for s in range(seed0, seed0 + n):
        m = run_trial(cfg, s).metrics
        pos.append(m["position_error_m"])
        head.append(m["heading_error_rad"])
    return avg_rmse(np.array(pos)), float(np.degrees(avg_rmse(np.array(head))))


@pytest.mark.slow
@pytest.mark.parametrize("profile", ["apsipa", "reference"])
def test_no_extent_pose_rmse_in_sanity_band(profile):
    n = scaled(60, minimum=15)
    pos, head = _mc(profile_config(profile), n)
    assert POS_BAND[0] <= pos <= POS_BAND[1], pos
    assert HEAD_BAND[0] <= head <= HEAD_BAND[1], head


@pytest.mark.slow
def test_negative_control_overconfident_radar_model_leaves_the_band():
    """A filter that believes the radar 10x more precise than it is (R / 100) must fail the band.

    Measured at 15 trials: 2.90 m and 8.2 deg. (An unmodelled 3 deg/s turn-rate bias does not
    work as a control: the landmarks correct it, 1.21 m / 3.8 deg.)
    """
    cfg = profile_config("apsipa")
    cfg = replace(cfg, filter=replace(cfg.filter, range_std_m=0.05, azimuth_std_deg=0.1))
    n = scaled(60, minimum=15)
    pos, head = _mc(cfg, n)
    assert head > HEAD_BAND[1] or pos > POS_BAND[1], (pos, head)


def _paired(cfgs: dict, n: int, seed: int) -> dict:
    """Per-step position and heading errors ``(n, K)`` of each config, every config on the same data."""
    from radarslam.montecarlo.trials import trial_seed
    from radarslam.simulation.trial import evaluate
    from radarslam.slam.driver import run_filter
    from radarslam.simulation.scenario import generate_scenario

    out = {k: ([], []) for k in cfgs}
    base = next(iter(cfgs.values()))
    for t in range(1, n + 1):
        sc = generate_scenario(base, np.random.default_rng(trial_seed(seed, t)))
        for k, c in cfgs.items():
            m = evaluate(c, sc, run_filter(c, sc.events))
            out[k][0].append(m["position_error_m"])
            out[k][1].append(m["heading_error_rad"])
    return {k: (np.array(p), np.array(h)) for k, (p, h) in out.items()}


def _paired_change_ci(a: np.ndarray, b: np.ndarray, n_boot: int = 2000) -> tuple[float, float]:
    """95% paired-bootstrap interval of the relative change of the avg. RMSE from ``b`` to ``a``
    (the statistic of the report's Table 1: the same resampled trials for both)."""
    from radarslam.metrics.statistics import bootstrap_avg_rmse, bootstrap_counts, percentile_interval

    counts = bootstrap_counts(a.shape[0], n_boot, np.random.default_rng(0))
    return tuple(percentile_interval(100.0 * (bootstrap_avg_rmse(a, counts) / bootstrap_avg_rmse(b, counts) - 1.0)))


@pytest.mark.slow
def test_with_extent_beats_no_extent_on_training_seeds_and_the_literal_test_does_not():
    """The seed's Table 1 direction on the training seed of the sifting sweep (1000, never the
    reporting seed 1): the paired 95% bootstrap interval of the change of the avg. RMSE, With
    extent against No extent, lies below zero for position and heading (as the report computes it).
    A regression guard of the sweep's result (docs/method.md a.7.1): on another training seed, 2000,
    200 trials give heading below zero but position [-9.2%, +1.9%]; the position gain is real
    (1000 trials of seed 1: [-14.2%, -9.8%]) but needs hundreds of trials to resolve. Negative
    control: the paper's literal contour test (kappa = 1), measured worse in the sweep, does not
    improve the heading (its interval is not below zero), and for position and heading its interval
    lies wholly above With extent's (outside that band: measured at 400 trials, heading [+4.4%,
    +20.9%] against [-23.6%, -14.1%], position [-3.0%, +11.2%] against [-18.7%, -10.3%])."""
    base = profile_config("apsipa")
    base = replace(base, filter=replace(base.filter, backend="numba"))

    def ext(**kw):
        return replace(base, extent=replace(base.extent, use_in_slam=True, **kw))

    n = scaled(400, minimum=200)
    r = _paired({"noext": base, "ext": ext(), "literal": ext(sifting_mode="literal")}, n, seed=1000)
    for i, what in enumerate(("position", "heading")):
        lo, hi = _paired_change_ci(r["ext"][i], r["noext"][i])
        assert hi < 0.0, (what, lo, hi)
        lit_lo, lit_hi = _paired_change_ci(r["literal"][i], r["noext"][i])
        assert lit_lo > hi, (what, (lit_lo, lit_hi), (lo, hi))          # the control outside the band
        if what == "heading":
            assert lit_hi > 0.0, (lit_lo, lit_hi)


@pytest.mark.slow
def test_consistent_variant_is_consistent_and_beats_with_extent():
    """The consistent variant (docs/method.md a.7.3) on training seed 2001: its pose NEES (3 dof)
    averaged over the N trials and then over the steps lies in the two-sided 95% band of the
    per-step mean, chi2(3 N) / N (tests/consistency_bounds.py: the steps are correlated, the
    per-step band is the time average's conservative band; measured 3.30 at N = 80, band [2.47,
    3.58]), and its position error is lower than With extent's. Negative controls on the same data:
    the consistent variant with its process noise Q 100 times too small (stds / 10) lies above the
    band (measured 24.8), and the paper's With extent is far above it (time-averaged NEES > 6)."""
    from radarslam.config.variants import CONSISTENT, apply_variant

    base = profile_config("apsipa")
    base = replace(base, filter=replace(base.filter, backend="numba"))
    cons = apply_variant(base, CONSISTENT)
    small_q = replace(cons, filter=replace(cons.filter, process_var_xy_m2=cons.filter.process_var_xy_m2 / 100,
                                           process_var_heading_rad2=cons.filter.process_var_heading_rad2 / 100))
    ext = replace(base, extent=replace(base.extent, use_in_slam=True))
    n = scaled(80, minimum=24)
    nees = {"ext": [], "cons": [], "small_q": []}
    pos = {"ext": [], "cons": []}
    from radarslam.montecarlo.trials import trial_seed
    from radarslam.simulation.trial import evaluate
    from radarslam.slam.driver import run_filter
    from radarslam.simulation.scenario import generate_scenario

    for t in range(1, n + 1):
        sc = generate_scenario(base, np.random.default_rng(trial_seed(2001, t)))
        for k, c in (("ext", ext), ("cons", cons), ("small_q", small_q)):
            m = evaluate(c, sc, run_filter(c, sc.events))
            nees[k].append(m["nees"])
            if k in pos:
                pos[k].append(m["position_error_m"])
    t_avg = {k: float(np.mean(np.mean(v, axis=0))) for k, v in nees.items()}
    lo, hi = nees_band(3, n)
    assert lo <= t_avg["cons"] <= hi, (t_avg, lo, hi)
    assert not lo <= t_avg["small_q"] <= hi, (t_avg, lo, hi)
    assert t_avg["ext"] > 6.0, t_avg
    assert avg_rmse(np.array(pos["cons"])) < avg_rmse(np.array(pos["ext"]))


# ------------------------------------------------------------------ the bounds of tests/consistency_bounds.py
def test_the_nees_band_covers_95_percent_of_chi_square_means():
    """2000 draws of the mean of n chi-square(d) values: the share inside :func:`nees_band` is 0.95
    within the 99.9% band of Binomial(2000, 0.95) / 2000; the one-sided bound holds 99%. Negative
    control: the means of values scaled by 1.5 (a covariance 1.5 times too small) are mostly outside."""
    rng = np.random.default_rng(0)
    for d, n in ((2, 1), (3, 24), (12, 12), (3, 400)):
        means = rng.chisquare(d, size=(2000, n)).mean(axis=1)
        lo, hi = nees_band(d, n)
        inside = np.mean((means >= lo) & (means <= hi))
        a, b = share_band(2000, 0.95, 0.999)
        assert a <= inside <= b, (d, n, inside)
        a, b = share_band(2000, 0.99, 0.999)
        assert a <= np.mean(means <= nees_upper_bound(d, n, 0.99)) <= b
        if n >= 12:
            assert np.mean((1.5 * means >= lo) & (1.5 * means <= hi)) < 0.5
    assert nees_band(3, 400, 0.99) == pytest.approx((2.694, 3.325), abs=1e-3)     # chi2(1200) / 400


def test_the_share_bounds_are_the_binomial_quantiles():
    """:func:`share_lower_bound` is the least k / n with P(X < k) < alpha, and the next k would not
    be (the quantile is tight); 2000 draws of Binomial(n, p) fall below it with a frequency within
    alpha's 99.9% binomial band; :func:`share_upper_bound` alike from above."""
    from scipy import stats

    rng = np.random.default_rng(1)
    for n, p in ((71, 0.9545), (71, 0.9545 ** 2), (300, 0.95), (3000, 0.025)):
        k = round(share_lower_bound(n, p) * n)
        assert stats.binom.cdf(k - 1, n, p) < 0.01 <= stats.binom.cdf(k, n, p)
        ku = round(share_upper_bound(n, p) * n)
        assert stats.binom.sf(ku, n, p) <= 0.01 < stats.binom.sf(ku - 1, n, p)
        draws = rng.binomial(n, p, 2000) / n
        hi = share_band(2000, 0.01, 0.999)[1]
        assert np.mean(draws < share_lower_bound(n, p)) <= hi
        assert np.mean(draws > share_upper_bound(n, p)) <= hi
        lo_b, hi_b = share_band(n, p, 0.99)
        assert 0.98 <= np.mean((draws >= lo_b) & (draws <= hi_b))


def test_the_per_step_band_holds_for_a_time_average_of_correlated_steps():
    """The time average of T = 200 correlated per-step NEES values (a 3-d Gaussian error that is
    AR(1) with a correlation of 0.95 per step, each step's NEES chi-square(3), N = 1 and N = 10
    runs) lies in the per-step band chi2(3 N) / N in at least 95% of 2000 draws (the convention of
    tests/consistency_bounds.py), and within the far narrower band of 3 N T independent values in
    fewer (the steps are not independent)."""
    rng = np.random.default_rng(2)
    T, rho = 200, 0.95
    for N in (1, 10):
        e = np.empty((2000, N, T, 3))
        e[:, :, 0] = rng.standard_normal((2000, N, 3))
        for k in range(1, T):
            e[:, :, k] = rho * e[:, :, k - 1] + math.sqrt(1 - rho * rho) * rng.standard_normal((2000, N, 3))
        t_avg = np.sum(e * e, axis=3).mean(axis=(1, 2))
        lo, hi = nees_band(3, N)
        assert np.mean((t_avg >= lo) & (t_avg <= hi)) >= 0.95
        lo, hi = nees_band(3, N * T)
        assert np.mean((t_avg >= lo) & (t_avg <= hi)) < 0.9
