"""The ``scatter-centres`` radar spread model (docs/method.md b.4.2): returns from the visible
corners and wheel houses, the faces in view and the footprint, fewer with range."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from radarslam.config import SPREAD_FACTORS, from_dict, profile_config, to_dict
from radarslam.core.errors import ConfigError, InputError
from radarslam.simulation import generate_scenario
from radarslam.simulation.radar import vehicle_points
from radarslam.simulation.scatterers import expected_counts, range_gain, scatterers
from radarslam.simulation.world import Vehicle

CAR = Vehicle(0, 0.0, 0.0, 4.5, 1.8)          # long side along x, centre (2.25, 0.9)
SOUTH = np.array([2.25, -10.0])               # broadside, 10.9 m below the centre
WEST = np.array([-10.0, 0.9])                 # end-on, 12.25 m left of the centre


def _radar(model: str = "scatter-centres", **kw):
    return dataclasses.replace(profile_config("apsipa").radar, spread_model=model, **kw)


def _draw(radar, sensor, n, seed):
    rng = np.random.default_rng(seed)
    return [vehicle_points(CAR, radar, rng, sensor) for _ in range(n)]


def _near(p: np.ndarray, q: np.ndarray, r: float = 0.3) -> np.ndarray:
    """Whether each point of ``p (m, 2)`` lies within ``r`` of any point of ``q (s, 2)``."""
    return (np.linalg.norm(p[:, None, :] - q[None, :, :], axis=2) < r).any(axis=1)


def test_scatterers_sit_at_the_corners_and_the_wheel_houses_of_either_orientation():
    pts, sides = scatterers(CAR, 0.85)
    assert np.allclose(pts[:4], [[0, 0], [4.5, 0], [4.5, 1.8], [0, 1.8]])
    assert np.allclose(pts[4:], [[0.85, 0], [3.65, 0], [0.85, 1.8], [3.65, 1.8]])
    assert sides.sum(axis=1).tolist() == [2, 2, 2, 2, 1, 1, 1, 1]
    across = Vehicle(1, 0.0, 0.0, 1.8, 4.5)                       # long side along y
    pts, _ = scatterers(across, 0.85)
    assert np.allclose(pts[4:], [[0, 0.85], [0, 3.65], [1.8, 0.85], [1.8, 3.65]])
    short, _ = scatterers(Vehicle(2, 0.0, 0.0, 2.0, 1.0), 0.85)    # at most a quarter of the length
    assert np.allclose(short[4:6, 0], [0.5, 1.5])


def test_detections_cluster_at_the_visible_scatterers_and_a_few_lie_behind_the_faces():
    r = _radar()
    p = np.concatenate(_draw(r, SOUTH, 3000, 11))
    pts, _ = scatterers(CAR, r.scatter_wheel_inset_m)
    visible, hidden = pts[[0, 1, 4, 5]], pts[[2, 3, 6, 7]]       # the bottom side faces the sensor
    lam = expected_counts(CAR, r, SOUTH)
    assert np.count_nonzero(lam[:8]) == 4 and np.all(lam[[2, 3, 6, 7]] == 0.0)
    # mixture weights (b.4.2): scatterers 3.5 / 6.375 = 0.549 of the returns; 98.9% of those lie
    # within 0.3 m (Rayleigh, sigma 0.1 m); the face returns add 1.8 / 4.5 of theirs. Measured 0.70.
    w_s = lam[:8].sum() / lam.sum()
    assert w_s == pytest.approx(3.5 / 6.375)
    frac = _near(p, visible).mean()
    assert frac > w_s * (1 - math.exp(-4.5)) - 0.01
    # hidden corners and wheel houses get only footprint returns: weight 0.4 / 6.375 = 0.063 times
    # the share of the footprint within 0.3 m of them (0.035), about 0.002
    assert _near(p, hidden).mean() < 0.01
    # the far side / under-body returns lie behind the visible face: 0.063 x (1.5 / 1.8) = 0.052
    w_u = lam[9] / lam.sum()
    behind = (p[:, 1] > 0.3).mean()
    assert abs(behind - w_u * 1.5 / 1.8) < 0.015
    # negative control: visible-faces spreads its points evenly on the side, 1.8 / 4.5 = 0.4 near
    # the scatterers, and never behind the face
    q = np.concatenate(_draw(_radar("visible-faces"), SOUTH, 3000, 11))
    assert _near(q, visible).mean() < 0.45 and np.all(q[:, 1] < 1e-9)


@pytest.mark.parametrize("sensor,end_on", [(SOUTH, False), (WEST, True)])
def test_the_detections_mean_lies_between_the_centroid_and_the_sensor(sensor, end_on):
    p = np.concatenate(_draw(_radar(), sensor, 2000, 12))
    los = sensor - CAR.center
    dist = np.linalg.norm(los)
    toward = float((p.mean(axis=0) - CAR.center) @ los) / dist
    # broadside: every source but the footprint on the bottom side, mean 0.06 m above it (0.84 m
    # towards the sensor); end-on: left side and its corners, mean x 0.27 m (1.98 m towards it)
    assert 0.0 < toward < dist
    assert toward > (1.5 if end_on else 0.6)


def test_the_count_falls_with_range_as_the_documented_law():
    r = _radar()
    base = 0.9 * (2 * 1.0 + 2 * 0.75 + 0.55 * 4.5 + 0.4)          # P_D x the means at r_ref = 10 m
    n = 4000
    for dist in (5.0, 15.0, 2.0):
        sensor = np.array([2.25, 0.9 - dist])
        mean = np.mean([p.shape[0] for p in _draw(r, sensor, n, int(dist * 10))])
        want = base * 10.0 / max(dist, 3.0)                          # (r_ref / max(r, r_near))^1
        assert abs(mean - want) < 4.0 * math.sqrt(want / n), dist  # Poisson: variance = mean
    assert range_gain(5.0, r) / range_gain(15.0, r) == pytest.approx(3.0)
    flat = _radar(scatter_range_exponent=0.0)                        # p = 0: no range effect
    assert range_gain(2.0, flat) == range_gain(19.0, flat) == 1.0


def test_reproducible_with_a_seed_and_routed_to_the_python_reference():
    r = _radar()
    a, b, c = _draw(r, SOUTH, 50, 3), _draw(r, SOUTH, 50, 3), _draw(r, SOUTH, 50, 4)
    assert all(np.array_equal(x, y) for x, y in zip(a, b))
    assert not all(x.shape == y.shape and np.array_equal(x, y) for x, y in zip(a, c))   # negative control
    with pytest.raises(InputError, match=r"^sensor: expected the sensor position"):
        vehicle_points(CAR, r, np.random.default_rng(0))
    d = to_dict(profile_config("apsipa"))
    d["radar"]["spread_model"] = "scatter-centres"
    d["trajectory"]["n_steps"] = 30
    cfg = from_dict(d)
    fast = generate_scenario(cfg, np.random.default_rng(9))                  # compiled=True asked for ...
    ref = generate_scenario(cfg, np.random.default_rng(9), compiled=False)   # ... the reference given
    assert all(np.array_equal(x.polar, y.polar) for x, y in zip(fast.scans, ref.scans))


@pytest.mark.parametrize("key,value,expected", [
    ("scatter_jitter_m", -0.1, ">= 0.0"),
    ("scatter_range_exponent", 5.0, "<= 4.0"),
    ("scatter_near_range_m", 0.0, ">= 0.1"),
    ("scatter_ref_range_m", 0.0, "> 0.0"),
    ("scatter_corner_points", "many", "a number"),
    ("scatter_wheel_inset_m", 11.0, "<= 10.0"),
])
def test_a_bad_parameter_is_refused_in_one_line_naming_the_key(key, value, expected):
    d = to_dict(profile_config("apsipa"))
    d["radar"].update(spread_model="scatter-centres", **{key: value})
    with pytest.raises(ConfigError) as err:
        from_dict(d)
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(f"radar.{key}: expected") and expected in msg and repr(value) in msg


def test_extent_spread_model_accepts_it_and_its_factor_matches_the_measured_scatter():
    """gamma_z (a.11): the detections' second moment about the car's centre in its frame, pooled over
    sensor positions around it at 6-18 m, against X = diag(L^2, W^2) / 3, as sqrt(det). The same
    measure gives the surface model's exact 1/4 (control)."""
    base = to_dict(profile_config())
    cfg = from_dict({**base, "extent": {**base["extent"], "spread_model": "scatter-centres"}})
    assert cfg.extent.spread_factor == SPREAD_FACTORS["scatter-centres"] == 0.6
    X = np.array([4.5, 1.8]) ** 2 / 3.0
    for model, want, tol in (("scatter-centres", 0.6, 0.04), ("surface", 0.25, 0.01)):
        rng = np.random.default_rng(31)
        pts = [vehicle_points(CAR, _radar(model), rng, CAR.center + d * np.array([math.cos(a), math.sin(a)]))
               for a in np.linspace(0, 2 * math.pi, 72, endpoint=False) for d in (6.0, 10.0, 14.0, 18.0)
               for _ in range(10)]
        p = np.concatenate(pts) - CAR.center
        gamma = math.sqrt(np.prod(np.mean(p**2, axis=0) / X))
        assert abs(gamma - want) < tol, (model, gamma)


def test_a_car_park_trial_runs_and_maps_the_cars():
    from radarslam.simulation.trial import run_trial

    d = to_dict(profile_config("apsipa"))
    d["radar"]["spread_model"] = d["extent"]["spread_model"] = "scatter-centres"
    d["trajectory"]["n_steps"] = 40
    res = run_trial(from_dict(d), 3)
    assert res.metrics["n_landmarks_final"] >= 3
    assert np.isfinite(res.metrics["position_avg_rmse_m"]) and res.metrics["position_avg_rmse_m"] < 3.0
