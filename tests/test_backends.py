"""The numba backend against the Python reference on whole car-park runs."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from radarslam.config import profile_config
from radarslam.experiments.single import run_trial

from conftest import require


def test_numba_backend_agrees_with_python_backend():
    """Same associations on every scan; poses and maps agree to rounding (not bit for bit)."""
    require("numba")
    base = profile_config()
    fast = replace(base, filter=replace(base.filter, backend="numba"))
    for seed in (1, 2, 3):
        for ext in (False, True):
            a, b = run_trial(base, seed, use_extent=ext), run_trial(fast, seed, use_extent=ext)
            assert np.array_equal(a.record.n_associated, b.record.n_associated)
            assert np.array_equal(a.record.n_landmarks, b.record.n_landmarks)
            assert np.allclose(a.record.poses, b.record.poses, atol=1e-9, rtol=0)
            assert np.allclose(a.record.pose_covs, b.record.pose_covs, atol=1e-12, rtol=1e-9)
            assert np.allclose(a.record.maps[-1].positions, b.record.maps[-1].positions, atol=1e-9)
