"""Monte Carlo properties of the whole pipeline (fixed seeds, real bounds, negative controls).

Marked slow; ``RADARSLAM_SLOW_SCALE`` scales the trial counts (CI uses 0.25).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.experiments.single import run_trial
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
    """Per-trial mean squared position and heading errors of each config, on the same data."""
    from radarslam.experiments.montecarlo import trial_seed
    from radarslam.experiments.single import evaluate, run_filter
    from radarslam.simulation.scenario import generate_scenario

    out = {k: ([], []) for k in cfgs}
    base = next(iter(cfgs.values()))
    for t in range(1, n + 1):
        sc = generate_scenario(base, np.random.default_rng(trial_seed(seed, t)))
        for k, c in cfgs.items():
            m = evaluate(c, sc, run_filter(c, sc.events))
            out[k][0].append(np.mean(m["position_error_m"] ** 2))
            out[k][1].append(np.mean(m["heading_error_rad"] ** 2))
    return {k: (np.array(p), np.array(h)) for k, (p, h) in out.items()}


@pytest.mark.slow
def test_with_extent_beats_no_extent_on_training_seeds_and_the_literal_test_does_not():
    """The seed's Table 1 direction, on a training seed (2000, never the reporting seed 1): the
    paired per-trial differences of mean squared position and heading error, With extent minus
    No extent, are negative by a one-sided paired t-test (p < 0.05). Negative control: the paper's
    literal contour test (kappa = 1), measured worse on 300 training trials, shows no improvement in
    heading at the same level."""
    from scipy import stats

    base = profile_config("apsipa")
    base = replace(base, filter=replace(base.filter, backend="numba"))

    def ext(**kw):
        return replace(base, extent=replace(base.extent, use_in_slam=True, **kw))

    n = scaled(80, minimum=24)
    r = _paired({"noext": base, "ext": ext(), "literal": ext(sifting_mode="literal")}, n, seed=2000)
    for i, what in enumerate(("position", "heading")):
        d = r["ext"][i] - r["noext"][i]
        p = stats.ttest_1samp(d, 0.0, alternative="less").pvalue
        assert p < 0.05, (what, d.mean(), p)
    d_lit = r["literal"][1] - r["noext"][1]
    assert stats.ttest_1samp(d_lit, 0.0, alternative="less").pvalue > 0.05, d_lit.mean()


@pytest.mark.slow
def test_consistent_variant_is_consistent_and_beats_with_extent():
    """The consistent variant (docs/method.md a.7.3) on training seed 2001: time-averaged pose NEES
    within [2, 4.5] and a lower position error than With extent; the paper's With extent on the
    same data is far above (negative control: time-averaged NEES > 6)."""
    from radarslam.experiments.variants import CONSISTENT, apply_variant

    base = profile_config("apsipa")
    base = replace(base, filter=replace(base.filter, backend="numba"))
    cons = apply_variant(base, CONSISTENT)
    ext = replace(base, extent=replace(base.extent, use_in_slam=True))
    n = scaled(80, minimum=24)
    nees = {"ext": [], "cons": []}
    pos = {"ext": [], "cons": []}
    from radarslam.experiments.montecarlo import trial_seed
    from radarslam.experiments.single import evaluate, run_filter
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
