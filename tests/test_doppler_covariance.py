"""The Doppler ego-velocity's covariance from the residuals' own scale: velocity
NEES near 2 whatever the RANSAC threshold, and a scan too small or too exact for a fit is a scan
without a fit, never a division by zero. The negative controls compute the old covariance (the
consensus inliers' RSS, docs/method.md c.10.3 before this change) from the same draws."""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.models import _doppler_compiled as C
from radarslam.models._ransac import ransac_kernel
from radarslam.models.doppler import directions, fit_ego_velocity
from test_doppler import synthetic_scan

NOISE = 0.1
#: Scans of 30 detections: Hotelling's T^2 with 28 dof has mean 2 * 28 / 26 = 2.15; the band allows
#: the refit's own small excess (2.2-2.6 measured) and the Monte Carlo spread of 800 scans (+-0.1).
NEES_BAND = (1.8, 2.8)


def _scans(seed: int, outliers: float, k: int = 800):
    rng = np.random.default_rng(seed)
    for _ in range(k):
        v = np.array([rng.uniform(0.0, 15.0), rng.uniform(-1.0, 1.0)])
        U, d, _ = synthetic_scan(rng, v, n=30, outliers=outliers, moving_share=0.0, noise=NOISE)
        yield v, U, d


def _old_fit(U, d, rng, threshold):
    """The old ego fit's covariance: ``s^2 = RSS_I / (n_I - dim)`` of the RANSAC consensus."""
    v, N, rss, mask, ok = ransac_kernel(U, d, rng, 50, threshold)
    n_in = int(mask.sum())
    if not (ok and n_in >= 4 and n_in >= 0.3 * U.shape[0]):
        return None
    return v, rss / (n_in - 2) * np.linalg.inv(N)


@pytest.mark.parametrize("sigmas", [1.5, 2.0])
@pytest.mark.parametrize("outliers", [0.0, 0.3])
def test_velocity_nees_is_near_2_at_tight_thresholds(sigmas, outliers):
    new, old = [], []
    for i, (v, U, d) in enumerate(_scans(11, outliers)):
        e = fit_ego_velocity(U, d, np.random.default_rng(i), threshold_mps=sigmas * NOISE)
        if e.valid:
            new.append(float((e.v - v) @ np.linalg.solve(e.cov, e.v - v)))
        f = _old_fit(U, d, np.random.default_rng(i), sigmas * NOISE)
        if f is not None:
            old.append(float((f[0] - v) @ np.linalg.solve(f[1], f[0] - v)))
    assert len(new) >= 790
    assert NEES_BAND[0] < np.mean(new) < NEES_BAND[1], np.mean(new)
    assert np.mean(old) > NEES_BAND[1], np.mean(old)            # the negative control: 3.1-5.7


@pytest.mark.parametrize("n", [1, 2, 3])
def test_a_scan_too_small_for_a_fit_has_none(n):
    U = directions(np.column_stack([np.full(n, 10.0), np.linspace(-0.5, 0.5, n)]))
    e = fit_ego_velocity(U, -U @ np.array([5.0, 0.0]), np.random.default_rng(0))
    assert not e.valid and np.all(np.isnan(e.v)) and np.all(np.isnan(e.cov))


def test_a_scan_of_exact_zero_doppler_has_no_fit_instead_of_a_division_by_zero():
    """nuScenes scene-0655 / 0916: most of a scan's Doppler exactly 0 (the ARS408's clusters at
    rest), so the consensus fitted them exactly (RSS 0) and with no sigma floor the covariance was 0:
    the compiled solve of ``v^T cov^-1 v`` raised ZeroDivisionError (the negative control below).
    That scan (13 detections of scene-0655) now has a fit scaled by its +-0.5 m/s detections; a scan
    with no spread at all has none."""
    polar = np.array([[7.6, 1.24], [8.1, 1.21], [7.9, 1.31], [12.7, 1.35], [17.0, 2.41], [17.7, 2.36],
                      [19.0, 2.65], [23.6, 0.53], [24.2, 1.45], [26.4, 0.47], [23.5, 2.38], [37.5, 0.35],
                      [7.7, 1.28]])
    d = np.array([0.0, -0.4987, 0.4995, 0.0, 6.8958, 0.0, 0.0, -7.1736, -0.4998, 0.0, 6.9148, 0.0, 0.4999])
    U = directions(polar)
    e = fit_ego_velocity(U, d, np.random.default_rng(0), sigma_floor_mps=0.0)
    assert e.valid and np.all(np.isfinite(e.cov)) and np.linalg.det(e.cov) > 0
    exact = np.where(np.abs(d) > 5, d, 0.0)                         # no spread: 10 exact zeros, 3 movers
    e = fit_ego_velocity(U, exact, np.random.default_rng(0), sigma_floor_mps=0.0)
    assert not e.valid and math.isnan(e.sigma_mps) and np.all(np.isnan(e.cov))
    ok = fit_ego_velocity(U, exact, np.random.default_rng(0), sigma_floor_mps=0.05)
    assert ok.valid and np.all(np.isfinite(ok.cov))                 # a floor gives the exact fit a scale
    with pytest.raises(ZeroDivisionError):                          # the old arithmetic, compiled: cov = 0
        C._K["solve_small"](np.zeros((2, 2)), np.zeros(2))
