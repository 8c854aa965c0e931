"""Landmarks retired from the state (docs/method.md c.15, ``landmarks.retire_distance_m``).

On io/recording/synthetic.py's car at 10 m/s past reflectors its radar sees up to 25 m: a landmark
retired beyond 40 m could never be measured again, so retiring it is the exact marginal and the
trajectory is the one without retirement; the map keeps every landmark, the retired ones after the
state's. The negative control retires inside the radar's range and changes the run.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from radarslam.config import profile_config, validate
from radarslam.runs.recording import run_recording
from radarslam.io.recording.synthetic import synthetic_recording

RANGE_M = 25.0


def _config(retire_m: float, backend: str = "python", fused: bool = True):
    cfg = profile_config("automotive")
    return validate(dataclasses.replace(
        cfg, filter=dataclasses.replace(cfg.filter, backend=backend, fused=fused, doppler_gate=False,
                                        max_range_m=RANGE_M),
        landmarks=dataclasses.replace(cfg.landmarks, retire_distance_m=retire_m)))


@pytest.fixture(scope="module")
def rec():
    return synthetic_recording(duration_s=12.0, speed_mps=10.0, turn_rate_rad_s=0.02, max_range_m=RANGE_M,
                               range_std_m=0.1, azimuth_std_rad=0.005, rng=np.random.default_rng(3))


@pytest.fixture(scope="module")
def kept(rec):
    return run_recording(rec, _config(0.0))


def test_retiring_beyond_the_radars_reach_is_the_exact_marginal(rec, kept):
    run = run_recording(rec, _config(40.0))
    active, final = run.record.n_landmarks[-1], run.record.maps[-1]
    assert final.ids.size > active + 5                     # landmarks did leave the state
    assert kept.record.n_landmarks[-1] == final.ids.size   # none is lost from the map
    np.testing.assert_allclose(run.record.poses, kept.record.poses, rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.record.pose_covs, kept.record.pose_covs, rtol=0, atol=1e-12)
    assert sorted(final.ids.tolist()) == sorted(kept.record.maps[-1].ids.tolist())
    # each retired row is its landmark as it left: the state's landmarks first, then the retired
    retired = final.ids[active:]
    assert not set(retired.tolist()) & set(final.ids[:active].tolist())
    m = run.metrics
    assert (m["landmarks_final"], m["landmarks_in_state"]) == (final.ids.size, active)
    assert m["landmarks_retired"] == final.ids.size - active and kept.metrics["landmarks_retired"] == 0
    pose = run.record.poses[-1, :2]
    assert np.all(np.hypot(*(final.positions[active:] - pose).T) > 40.0)


def test_negative_control_retiring_inside_the_range_changes_the_run(rec, kept):
    run = run_recording(rec, _config(12.0))
    assert run.record.maps[-1].ids.size > kept.record.maps[-1].ids.size      # retired and born again
    assert np.max(np.abs(run.record.poses[:, :2] - kept.record.poses[:, :2])) > 1e-3


def test_the_fused_engine_retires_as_its_steps_form(rec):
    ref = run_recording(rec, _config(40.0))
    fused = run_recording(rec, _config(40.0, backend="numba"))
    assert fused.record.engine == "fused"
    np.testing.assert_allclose(fused.record.poses, ref.record.poses, rtol=0, atol=1e-9)
    a, b = fused.record.maps[-1], ref.record.maps[-1]
    assert a.ids.tolist() == b.ids.tolist()
    np.testing.assert_allclose(a.positions, b.positions, rtol=0, atol=1e-9)
    np.testing.assert_allclose(a.covs, b.covs, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(np.isnan(a.rma), np.isnan(b.rma))
    np.testing.assert_allclose(np.nan_to_num(a.rma), np.nan_to_num(b.rma), rtol=0, atol=1e-9)
