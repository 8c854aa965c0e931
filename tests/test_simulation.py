"""The simulated car park (docs/method.md section b)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.simulation import generate_scenario
from radarslam.simulation.radar import CLUTTER, simulate_scan
from radarslam.simulation.trajectory import noise_free_path
from radarslam.simulation.world import carpark_vehicles

# docs/method.md b.2, [PROP] convention: (k, x, y, heading_deg).
REFERENCE_POINTS = [
    (10, 5.76, 0.02, 2.9), (25, 14.25, 3.97, 46.9), (40, 17.62, 12.71, 90.9), (60, 11.44, 23.29, 149.6),
    (85, -3.40, 21.65, 222.9), (100, -7.36, 13.17, 267.0), (120, -8.04, 0.38, 267.0),
]


@pytest.mark.parametrize("k,x,y,deg", REFERENCE_POINTS)
def test_noise_free_path_passes_reference_points(default_config, k, x, y, deg):
    p = noise_free_path(default_config.trajectory)[k - 1]
    # The table is printed to 0.01 m / 0.1 deg: 1 cm plus its rounding (0.005 m) per axis.
    assert abs(p[0] - x) <= 0.01 and abs(p[1] - y) <= 0.01
    assert abs(math.degrees(p[2]) - deg) <= 0.05 + 1e-9


def test_pose_one_is_origin_and_turn_window(default_config):
    p = noise_free_path(default_config.trajectory)
    assert np.allclose(p[0], 0.0)
    dth = np.diff(np.unwrap(p[:, 2]))
    turning = np.flatnonzero(dth > 1e-9) + 2  # step k whose control turned
    assert turning[0] == 10 and turning[-1] == 100 and turning.size == 91
    assert math.isclose(np.unwrap(p[:, 2])[-1], 91 * 0.32 * 0.16, rel_tol=1e-12)


def test_scenario_is_reproducible_bit_for_bit(default_config):
    a = generate_scenario(default_config, np.random.default_rng(7))
    b = generate_scenario(default_config, np.random.default_rng(7))
    c = generate_scenario(default_config, np.random.default_rng(8))
    assert np.array_equal(a.truth.poses, b.truth.poses)
    assert all(np.array_equal(x.polar, y.polar) for x, y in zip(a.scans, b.scans))
    assert all(np.array_equal(x, y) for x, y in zip(a.truth.sources, b.truth.sources))
    assert np.array_equal(a.odometry, b.odometry)
    assert not np.array_equal(a.truth.poses, c.truth.poses)  # negative control


def test_event_stream_shape(default_config):
    sc = generate_scenario(default_config, np.random.default_rng(1))
    assert len(sc.scans) == 120 and len(sc.events) == 239
    assert [s.index for s in sc.scans] == list(range(1, 121))
    assert all(len(s) == s_.polar.shape[0] for s, s_ in zip(sc.truth.sources, sc.scans))


def test_departing_car_leaves_at_k60(default_config):
    vs = carpark_vehicles(default_config.world)
    dep = vs[5]
    assert np.allclose(dep.center, [-13, 6]) and dep.present(59) and not dep.present(60)
    pose = np.array([-13.0, 0.0, 0.0])  # 6 m from it, nothing else in range... but (-13, 14) is 14 m away
    rng = np.random.default_rng(0)
    srcs = np.concatenate([simulate_scan(pose, vs, 60, default_config.radar, rng)[1] for _ in range(50)])
    assert not np.any(srcs == 5)


def test_detection_counts_match_expected_means():
    """Per-car kept detections: E = sum_n P(n) * n * P_D with n = max(floor(N(0.8 A, 1.5)), 0)."""
    from scipy.stats import norm

    cfg = profile_config()
    cfg = replace(cfg, radar=replace(cfg.radar, clutter_rate_per_m2=0.0))
    vs = carpark_vehicles(cfg.world)
    pose = np.array([7.0, 0.0, 0.0])  # (7,6), (7,11), (7,16), (4.5,-7), (13.5,-7) in range
    rng = np.random.default_rng(2024)
    n_scans = 4000
    counts = np.zeros(len(vs))
    sq = np.zeros(len(vs))
    for _ in range(n_scans):
        _, src = simulate_scan(pose, vs, 1, cfg.radar, rng)
        c = np.bincount(src, minlength=len(vs))
        counts += c
        sq += c * c
    for v in vs:
        if np.hypot(*(v.center - pose[:2])) > 20:
            assert counts[v.index] == 0
            continue
        mu = 0.8 * v.area
        ns = np.arange(0, 40)
        pn = norm.cdf(ns + 1, mu, math.sqrt(1.5)) - norm.cdf(ns, mu, math.sqrt(1.5))
        expected = 0.9 * np.sum(pn * ns)
        mean = counts[v.index] / n_scans
        sd = math.sqrt(sq[v.index] / n_scans - mean**2)
        # 5-sigma bound on the mean of n_scans iid counts.
        assert abs(mean - expected) < 5 * sd / math.sqrt(n_scans), (v.index, mean, expected)
    # The two car sizes differ as the model says (small ~5.3, large ~6.75).
    assert 5.0 < counts[2] / n_scans < 5.6 and 6.4 < counts[8] / n_scans < 7.1


def test_clutter_count_matches_poisson_mean_in_range():
    """Clutter kept in range: Poisson with mean lambda * (grid cells within R_max) * cell area."""
    cfg = profile_config()
    cfg = replace(cfg, world=replace(cfg.world, vehicles=[]), radar=replace(cfg.radar, shuffle_detections=False))
    cfg = replace(cfg, world=replace(cfg.world, departing_vehicle=-1))
    pose = np.array([10.0, 12.0, 0.3])
    r = cfg.radar
    side = r.scene_max_m - r.scene_min_m
    cells = int(round(side / r.clutter_grid_m))
    centres = r.scene_min_m + (np.arange(cells) + 0.5) * side / cells
    gx, gy = np.meshgrid(centres, centres)
    frac = np.mean((gx - pose[0]) ** 2 + (gy - pose[1]) ** 2 <= r.max_range_m**2)
    expected = r.clutter_rate_per_m2 * side * side * frac  # ~ 0.005 * 3600 * pi 400 / 3600 = 6.28
    rng = np.random.default_rng(99)
    n = np.array([simulate_scan(pose, [], 1, r, rng)[1].size for _ in range(5000)])
    assert abs(n.mean() - expected) < 5 * math.sqrt(expected / n.size)
    assert abs(n.var() - expected) < 0.1 * expected  # Poisson: variance = mean
    assert 5.0 < expected < 7.0


def test_clutter_is_noise_free_and_on_grid(default_config):
    cfg = replace(default_config, world=replace(default_config.world, vehicles=[], departing_vehicle=-1))
    pose = np.array([0.0, 0.0, 0.0])
    polar, src = simulate_scan(pose, [], 1, cfg.radar, np.random.default_rng(3))
    assert np.all(src == CLUTTER)
    xy = np.column_stack([polar[:, 0] * np.cos(polar[:, 1]), polar[:, 0] * np.sin(polar[:, 1])])
    cell = (xy + 15.0) / 0.2 - 0.5
    assert np.allclose(cell, np.round(cell), atol=1e-9)


def test_vehicle_detections_lie_on_rectangle_before_noise(default_config):
    cfg = replace(default_config, radar=replace(default_config.radar, range_std_m=0.0, azimuth_std_deg=0.0,
                                                clutter_rate_per_m2=0.0))
    vs = carpark_vehicles(cfg.world)
    pose = np.array([7.0, 0.0, 0.7])
    polar, src = simulate_scan(pose, vs, 1, cfg.radar, np.random.default_rng(5))
    a = pose[2] + polar[:, 1]
    xy = pose[:2] + polar[:, :1] * np.column_stack([np.cos(a), np.sin(a)])
    for p, s in zip(xy, src):
        v = vs[s]
        assert v.x_left - 1e-9 <= p[0] <= v.x_left + v.size_x + 1e-9
        assert v.y_bottom - 1e-9 <= p[1] <= v.y_bottom + v.size_y + 1e-9


@pytest.mark.parametrize("profile,seeds", [("apsipa", range(12)), ("reference", range(4)), ("large-carpark", [7])])
def test_compiled_scans_equal_reference_bit_for_bit(profile, seeds):
    """The compiled scan simulation (simulation._compiled) draws what simulate_scan draws, in the
    same order: every detection and source equal to the last bit, the generator left in the same state."""
    pytest.importorskip("numba")
    cfg = profile_config(profile)
    if profile == "large-carpark":
        cfg = replace(cfg, trajectory=replace(cfg.trajectory, n_steps=300))
    for seed in seeds:
        r1, r2 = np.random.default_rng(seed), np.random.default_rng(seed)
        fast, ref = generate_scenario(cfg, r1), generate_scenario(cfg, r2, compiled=False)
        scans_f, scans_r = fast.scans, ref.scans
        assert len(scans_f) == len(scans_r) == cfg.trajectory.n_steps
        for a, b in zip(scans_f, scans_r):
            assert a.polar.shape == b.polar.shape and np.array_equal(a.polar, b.polar), (seed, a.index)
        for a, b in zip(fast.truth.sources, ref.truth.sources):
            assert np.array_equal(a, b)
        assert r1.random() == r2.random()


def test_compiled_scans_differ_for_another_seed():
    """Negative control of the comparison above."""
    pytest.importorskip("numba")
    cfg = profile_config("apsipa")
    a = generate_scenario(cfg, np.random.default_rng(1)).scans
    b = generate_scenario(cfg, np.random.default_rng(2), compiled=False).scans
    assert any(x.polar.shape != y.polar.shape or not np.array_equal(x.polar, y.polar) for x, y in zip(a, b))
