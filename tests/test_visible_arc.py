"""The visible-arc trunk diameter (docs/method.md a.9) against simulated laser beams on circles."""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.core.errors import InputError
from radarslam.core.registry import EXTENT_ESTIMATORS
from radarslam.extent.visible_arc import VisibleArcEstimator, arc_diameter

DELTA = math.radians(0.5)


def beams_on_circle(centre_range: float, radius: float, phase: float, step: float = DELTA,
                    noise: float = 0.0, rng=None) -> np.ndarray:
    """Hits ``[range, bearing]`` of beams ``phase + k step`` on a circle straight ahead (exact ray casting)."""
    half = math.asin(radius / centre_range)
    k = np.arange(math.ceil((-half - phase) / step), math.floor((half - phase) / step) + 1)
    phi = phase + k * step
    # ray r (cos phi, sin phi) meets the circle |p - (D, 0)| = rho at the nearer root
    b = centre_range * np.cos(phi)
    r = b - np.sqrt(np.maximum(b * b - centre_range ** 2 + radius ** 2, 0.0))
    if noise:
        r = r + rng.normal(0.0, noise, r.size)
    return np.column_stack([r, phi])


@pytest.mark.parametrize("d, dist", [(0.2, 5.0), (0.42, 10.0), (0.8, 20.0), (0.3, 25.0)])
def test_width_estimate_is_unbiased_over_the_beam_phase(d, dist):
    """Averaged over the beam grid's phase the estimate is the true diameter (E[n delta] = w)."""
    phases = (np.arange(400) + 0.5) / 400 * DELTA
    est = np.array([arc_diameter(beams_on_circle(dist, d / 2, p), DELTA) for p in phases])
    assert np.all(np.isfinite(est))
    assert abs(est.mean() - d) < 0.01 * d + 1e-3
    # one scan is off by at most about one beam's width at that range
    assert np.max(np.abs(est - d)) < 1.05 * dist * DELTA


def test_median_over_scans_with_range_noise_is_close_and_filled_disc_is_not():
    """The estimator's gated mean over scans with 5 cm range noise is within 2 cm, at one fixed
    range (the worst case for the beam quantisation); the plain median is not (half a beam off),
    nor is the filled-disc reading of the hits' scatter, 2 sqrt(4 lambda_max) (negative controls)."""
    rng = np.random.default_rng(11)
    d, dist = 0.5, 12.0
    scans = [beams_on_circle(dist, d / 2, rng.uniform(0, DELTA), noise=0.05, rng=rng) for _ in range(200)]
    est = EXTENT_ESTIMATORS.create("visible-arc", profile_config("victoria-park"))
    st = est.new()
    st.arc = [arc_diameter(s, DELTA) for s in scans]
    st.beam = [s[:, 0].min() * DELTA for s in scans]
    assert abs(est.diameter(st) - d) < 0.02
    assert abs(np.median(st.arc) - d) > 0.02
    pts = np.concatenate([np.column_stack([s[:, 0] * np.cos(s[:, 1]), s[:, 0] * np.sin(s[:, 1])]) for s in scans])
    lam = np.linalg.eigvalsh(np.cov(pts.T))[-1]
    filled = 2 * math.sqrt(4 * lam)            # gamma_z = 1/4, the RMA's uniform-disc model
    assert abs(filled - d) > 0.05          # 0.574 m: 15% high


def test_gaps_and_bad_input():
    hits = beams_on_circle(10.0, 0.3, 0.1 * DELTA)
    assert math.isfinite(arc_diameter(hits, DELTA))
    split = np.vstack([hits, [[10.0, hits[-1, 1] + 3 * DELTA]]])     # another object two beams on
    assert math.isnan(arc_diameter(split, DELTA))
    assert math.isnan(arc_diameter(np.empty((0, 2)), DELTA))
    one = np.array([[10.0, 0.0]])
    assert arc_diameter(one, DELTA) == pytest.approx(2 * 10.0 * math.sin(DELTA / 2) / (1 - math.sin(DELTA / 2)))
    with pytest.raises(InputError, match=r"^polar: expected shape \(m, 2\)"):
        arc_diameter(np.zeros(3), DELTA)
    with pytest.raises(InputError, match=r"^beam_step: expected radians"):
        arc_diameter(hits, 0.0)


def test_estimator_reports_the_median_circle_after_min_scans_and_pools_on_merge():
    cfg = profile_config("victoria-park")
    assert cfg.extent.estimator == "visible-arc"
    est = EXTENT_ESTIMATORS.create("visible-arc", cfg)
    assert isinstance(est, VisibleArcEstimator)
    st = est.new()
    rng = np.random.default_rng(3)
    pose, pc = np.zeros(3), np.eye(3) * 1e-4
    for k in range(cfg.extent.arc_min_scans):
        assert est.matrix(st) is None
        hits = beams_on_circle(8.0, 0.2, rng.uniform(0, DELTA))
        pts = np.column_stack([hits[:, 0] * np.cos(hits[:, 1]), hits[:, 0] * np.sin(hits[:, 1])])
        est.step(st, hits, pts, np.array([8.0, 0.0]), np.eye(2) * 1e-2, pose, pc, 0.2, k)
    X = est.matrix(st)
    assert X is not None and np.allclose(X, X[0, 0] * np.eye(2))
    assert abs(2 * math.sqrt(X[0, 0]) - 0.4) < 0.07
    other = est.new()
    other.arc, other.beam = [1.0] * 20, [0.07] * 20
    merged = est.merge(st, other)
    assert len(merged.arc) == cfg.extent.arc_min_scans + 20 and est.diameter(merged) == pytest.approx(1.0)
