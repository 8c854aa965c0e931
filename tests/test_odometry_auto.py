"""``filter.odometry = "auto"`` (docs/method.md c.10.5.2): the automotive profile's
prediction is decided by what the recording carries -- the wheel speed fused with the radar's Doppler
velocity ("both") when its detections carry Doppler and its odometry a speed and a yaw rate, the
odometer otherwise -- and the run says which, bit for bit the run of the value it chose."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from helpers import first_seconds, shared_data

from radarslam.config import profile_config
from radarslam.runs.odometry_choice import resolved_odometry


def _with_filter(cfg, **kw):
    return dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, **kw))


@pytest.fixture(scope="module")
def rec(tmp_path_factory):
    from radarslam.io.recording import read_recording

    out = tmp_path_factory.mktemp("auto") / "rec"
    return read_recording(first_seconds(shared_data() / "nuscenes_radar" / "scene-0103", 5.0, out))


def test_the_profile_asks_the_recording():
    assert profile_config("automotive").filter.odometry == "auto"
    assert profile_config("apsipa").filter.odometry == "odometer"          # the paper's, unchanged


def test_a_recording_with_doppler_and_a_yaw_rate_takes_both(rec):
    cfg, choice = resolved_odometry(rec, profile_config("automotive"))
    assert cfg.filter.odometry == "both" and choice["chosen"] == "both"
    assert "Doppler column" in choice["from"]


def test_without_doppler_or_with_a_state_that_needs_the_odometer_it_takes_the_odometer(rec):
    no_doppler = dataclasses.replace(rec, channels={k: v for k, v in rec.channels.items() if k != "doppler_mps"})
    cfg, choice = resolved_odometry(no_doppler, profile_config("automotive"))
    assert cfg.filter.odometry == "odometer" and "no Doppler column" in choice["from"]
    nan_doppler = dataclasses.replace(rec, channels={**rec.channels, "doppler_mps": np.full(rec.det_t.size, np.nan)})
    assert resolved_odometry(nan_doppler, profile_config("automotive"))[0].filter.odometry == "odometer"
    thrust = _with_filter(profile_config("automotive"), odometry_bias="states", bias_thrust=True)
    cfg, choice = resolved_odometry(rec, thrust)
    assert cfg.filter.odometry == "odometer" and "filter.bias_thrust" in choice["from"]
    given = _with_filter(profile_config("automotive"), odometry="doppler")      # a value of its own: untouched
    assert resolved_odometry(rec, given) == (given, None)


def test_the_run_is_the_run_of_the_value_chosen_and_says_so(rec):
    pytest.importorskip("numba")
    from radarslam.cli.recording import run_notes
    from radarslam.runs.recording import run_recording

    cfg = profile_config("automotive")
    auto = run_recording(rec, cfg)
    both = run_recording(rec, _with_filter(cfg, odometry="both"))
    odometer = run_recording(rec, _with_filter(cfg, odometry="odometer"))      # negative control
    np.testing.assert_array_equal(auto.record.poses, both.record.poses)
    assert not np.array_equal(auto.record.poses, odometer.record.poses)
    assert auto.config.filter.odometry == "both"                          # what config.toml writes
    assert auto.metrics["odometry"]["chosen"] == "both" and "odometry" not in both.metrics
    assert any(n.startswith("the prediction: filter.odometry 'both'") for n in run_notes(auto))


def test_a_filter_without_a_recording_takes_the_odometer():
    pytest.importorskip("numba")
    from radarslam.simulation.trial import run_trial

    cfg = profile_config("apsipa")
    a = run_trial(_with_filter(cfg, odometry="auto"), 3)
    b = run_trial(_with_filter(cfg, odometry="odometer"), 3)
    np.testing.assert_array_equal(a.record.poses, b.record.poses)
