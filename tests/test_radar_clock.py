"""The radars' clock against the wheels, online (docs/method.md c.12.8, ``filter.radar_clock``):
recovery of a known offset and scale on a synthetic drive, causality, the negative control of a
steady drive, the stamps' shift, the refusal, and the given scenes against the independent
review's cross-correlation."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.core.errors import ConfigError
from radarslam.egomotion.clock import ClockTrack, clock_of, online_clock, shift_stamps

NUSCENES = Path(__file__).resolve().parents[2] / "shared" / "data" / "nuscenes_radar"


def _drive(tau: float, scale: float, rng, accelerate: bool = True, n: int = 1500, sd: float = 0.03):
    """Sweeps at 13 Hz whose forward speed is ``(1 + scale) v(t + tau)`` plus white noise of ``sd``;
    the wheels' ``v(t)`` at 100 Hz (speeding up and slowing down, or steady)."""
    ot = np.arange(0.0, n / 13 + 1.0, 0.01)
    v = 8.0 + (3.0 * np.sin(2 * np.pi * ot / 9.0) if accelerate else np.zeros_like(ot))
    odo = np.column_stack([ot, v, np.zeros_like(ot)])
    t = 0.3 + np.arange(n) / 13.0
    vx = (1 + scale) * np.interp(t + tau, ot, v) + sd * rng.standard_normal(n)
    theta = np.column_stack([vx, np.zeros(n), np.zeros(n)])
    cov = np.zeros((n, 3, 3))
    cov[:, 0, 0] = sd ** 2
    series = SimpleNamespace(t=t, theta=theta, valid=np.ones(n, dtype=bool), white_cov=lambda: cov)
    return series, odo


@pytest.mark.parametrize("seed", [2, 3, 4])
def test_a_known_offset_and_scale_are_recovered(seed):
    """tau = +45 ms and a 1% scale, accelerations of +-2 m/s^2: both within 3 std at the end, the
    offset's std under 5 ms (seeds 2-4)."""
    rng = np.random.default_rng(seed)
    series, odo = _drive(0.045, 0.01, rng)
    tr = online_clock(series, odo, 0.1, 0.02, 0.2)
    assert abs(tr.offset_s[-1] - 0.045) < 3 * tr.std_s[-1] and tr.std_s[-1] < 0.005, tr.summary()
    assert abs(tr.scale[-1] - 0.01) < 0.002
    assert tr.used.sum() > 0.95 * tr.t.size


def test_the_estimate_is_causal():
    """The estimate after sweep k does not depend on any later sweep."""
    rng = np.random.default_rng(5)
    series, odo = _drive(0.03, 0.0, rng)
    a = online_clock(series, odo, 0.1, 0.02, 0.2)
    series.theta[800:, 0] += 0.5                      # later sweeps changed
    b = online_clock(series, odo, 0.1, 0.02, 0.2)
    assert np.array_equal(a.offset_s[:800], b.offset_s[:800]) and not np.array_equal(a.offset_s, b.offset_s)


def test_a_steady_drive_tells_nothing_of_the_clock():
    """The negative control: at a steady speed the offset is not observable, so it stays at its
    prior (mean near 0, std near the prior's) whatever the true offset, while the scale is learnt."""
    rng = np.random.default_rng(6)
    series, odo = _drive(0.045, 0.01, rng, accelerate=False)
    tr = online_clock(series, odo, 0.1, 0.02, 0.2)
    assert abs(tr.offset_s[-1]) < 0.01 and tr.std_s[-1] > 0.09
    assert abs(tr.scale[-1] - 0.01) < 0.002


def test_stamps_move_by_the_offset_known_then():
    track = ClockTrack(np.array([1.0, 2.0]), np.array([0.04, -0.5]), np.ones(2), np.zeros(2), np.ones(2, dtype=bool))
    rec = SimpleNamespace(det_t=np.array([0.5, 1.0, 1.5, 2.0, 2.2]), det_polar=np.arange(10.0).reshape(5, 2),
                          channels={"sensor_id": np.arange(5)}, labels=None, det_scan=None, scan_t=np.zeros(2))
    np.testing.assert_allclose(track.at(rec.det_t), [0.0, 0.04, 0.04, -0.5, -0.5])
    out = shift_stamps(_Rec(**vars(rec)), track)
    np.testing.assert_allclose(out.det_t, [0.5, 1.04, 1.5, 1.54, 1.7])       # re-sorted: 2.0 - 0.5 < 1.54
    assert out.channels["sensor_id"].tolist() == [0, 1, 3, 2, 4] and out.scan_t is None


@dataclasses.dataclass
class _Rec:
    det_t: np.ndarray
    det_polar: np.ndarray
    channels: dict
    labels: object
    det_scan: object
    scan_t: object


def test_online_without_a_rig_is_refused_in_one_line():
    cfg = profile_config("automotive")
    cfg = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, radar_clock="online"))
    rec = SimpleNamespace(channels={}, sensors={}, det_t=np.zeros(0))
    with pytest.raises(ConfigError, match=r"^filter\.radar_clock: 'online' needs a rig .*got no rig with Doppler$"):
        clock_of(rec, cfg)
    assert clock_of(rec, profile_config("automotive")) is None          # the profile's auto: no rig, as stamped


def test_auto_is_online_on_a_rig_with_wheels_and_as_stamped_otherwise():
    """``radar_clock = "auto"`` (the automotive profile's): a recording with a rig of radars with Doppler
    and wheel speeds runs the online clock, the same track as "online"; one without a rig keeps its
    stamps (where "online" refuses, above); a run with a car calibration, which gives each radar's
    clock, keeps them too, and the run's configuration (its config.toml) holds the value chosen."""
    from radarslam.egomotion.clock import resolved_clock
    from radarslam.egomotion.car_calibration import calibrate_car
    from radarslam.egomotion.rig import read_rig
    from radarslam.io.recording import read_recording
    from radarslam.runs.recording import run_recording

    scene = NUSCENES / "scene-0103"
    if not scene.is_dir():
        pytest.skip("the given nuScenes scenes are not beside the checkout") if not __import__("os").environ.get("CI") \
            else pytest.fail("CI must provide ../shared")
    cfg = profile_config("automotive")
    assert cfg.filter.radar_clock == "auto"
    rec = read_recording(scene)
    assert resolved_clock(rec, cfg).filter.radar_clock == "online"
    online = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, radar_clock="online"))
    a, b = clock_of(rec, cfg), clock_of(rec, online)
    assert np.array_equal(a.offset_s, b.offset_s) and abs(a.offset_s[-1] - 0.040) < 0.01
    bare = SimpleNamespace(channels={}, sensors={}, det_t=np.zeros(0))
    assert resolved_clock(bare, cfg).filter.radar_clock == "as-stamped"
    cal = calibrate_car(read_rig(scene), np.random.default_rng(0), source="scene-0103")
    run = run_recording(rec, cfg, calibration=cal)
    assert run.config.filter.radar_clock == "as-stamped" and "radar_clock" not in run.metrics


@pytest.mark.parametrize("scene, review_ms", [("scene-0103", 40.0), ("scene-0655", 30.0)])
def test_the_boston_car_reads_as_the_independent_review(scene, review_ms):
    """On the Boston car's two drives the online offset ends within 3 std of the review's
    cross-correlation of the rig's Doppler speed with the wheel speed (40 and 30 ms early),
    computed without the project's code."""
    from radarslam.io.recording import read_recording

    if not (NUSCENES / scene).is_dir():
        pytest.skip("the given nuScenes scenes are not beside the checkout") if not __import__("os").environ.get("CI") \
            else pytest.fail("CI must provide ../shared")
    cfg = profile_config("automotive")
    cfg = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, radar_clock="online"))
    tr = clock_of(read_recording(NUSCENES / scene), cfg)
    assert abs(tr.offset_s[-1] * 1e3 - review_ms) < 3 * tr.std_s[-1] * 1e3, tr.summary()
    assert tr.std_s[-1] < 0.025
