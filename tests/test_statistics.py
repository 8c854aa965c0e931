"""Monte Carlo properties of the whole pipeline (fixed seeds, real bounds, negative controls).

Marked slow; ``RADARSLAM_SLOW_SCALE`` scales the trial counts (CI uses 0.25).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.simulation.trial import run_trial
from radarslam.metrics.pose import avg_rmse

from conftest import scaled

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
    improve the heading (its interval is not below zero)."""
    base = profile_config("apsipa")
    base = replace(base, filter=replace(base.filter, backend="numba"))

    def ext(**kw):
        return replace(base, extent=replace(base.extent, use_in_slam=True, **kw))

    n = scaled(400, minimum=200)
    r = _paired({"noext": base, "ext": ext(), "literal": ext(sifting_mode="literal")}, n, seed=1000)
    for i, what in enumerate(("position", "heading")):
        lo, hi = _paired_change_ci(r["ext"][i], r["noext"][i])
        assert hi < 0.0, (what, lo, hi)
    lo, hi = _paired_change_ci(r["literal"][1], r["noext"][1])
    assert hi > 0.0, (lo, hi)


@pytest.mark.slow
def test_consistent_variant_is_consistent_and_beats_with_extent():
    """The consistent variant (docs/method.md a.7.3) on training seed 2001: time-averaged pose NEES
    within [2, 4.5] and a lower position error than With extent; the paper's With extent on the
    same data is far above (negative control: time-averaged NEES > 6)."""
    from radarslam.config.variants import CONSISTENT, apply_variant

    base = profile_config("apsipa")
    base = replace(base, filter=replace(base.filter, backend="numba"))
    cons = apply_variant(base, CONSISTENT)
    ext = replace(base, extent=replace(base.extent, use_in_slam=True))
    n = scaled(80, minimum=24)
    nees = {"ext": [], "cons": []}
    pos = {"ext": [], "cons": []}
    from radarslam.montecarlo.trials import trial_seed
    from radarslam.simulation.trial import evaluate
    from radarslam.slam.driver import run_filter
    from radarslam.simulation.scenario import generate_scenario

    for t in range(1, n + 1):
        sc = generate_scenario(base, np.random.default_rng(trial_seed(2001, t)))
        for k, c in (("ext", ext), ("cons", cons)):
            m = evaluate(c, sc, run_filter(c, sc.events))
            nees[k].append(m["nees"])
            pos[k].append(m["position_error_m"])
    t_avg = {k: float(np.mean(np.mean(v, axis=0))) for k, v in nees.items()}
    assert 2.0 <= t_avg["cons"] <= 4.5, t_avg
    assert t_avg["ext"] > 6.0, t_avg
    assert avg_rmse(np.array(pos["cons"])) < avg_rmse(np.array(pos["ext"]))
