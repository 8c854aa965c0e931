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
