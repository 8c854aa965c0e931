"""The radar spread models of the simulator (docs/method.md b.4.1): where a car's detections lie."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.core.errors import ConfigError, InputError
from radarslam.simulation.radar import vehicle_points
from radarslam.simulation.world import Vehicle

CAR = Vehicle(0, 0.0, 0.0, 4.5, 1.8)          # long side along x


def _radar(model: str, pd: float = 1.0):
    r = profile_config("apsipa").radar
    return dataclasses.replace(r, spread_model=model, detection_probability=pd)


def _boundary_distance(p: np.ndarray) -> np.ndarray:
    x, y = p[:, 0], p[:, 1]
    return np.minimum.reduce([np.abs(x), np.abs(x - 4.5), np.abs(y), np.abs(y - 1.8)])


def test_surface_is_the_papers_and_contour_lies_on_the_outline_with_the_same_count():
    rng = np.random.default_rng(1)
    surf = [vehicle_points(CAR, _radar("surface"), rng) for _ in range(3000)]
    cont = [vehicle_points(CAR, _radar("contour"), rng) for _ in range(3000)]
    # the same count model: floor(N(0.8 A, 1.5)), A = 8.1 m^2
    assert abs(np.mean([p.shape[0] for p in surf]) - np.mean([p.shape[0] for p in cont])) < 0.15
    c = np.concatenate(cont)
    assert np.all(_boundary_distance(c) < 1e-9)
    s = np.concatenate(surf)
    assert np.mean(_boundary_distance(s) > 0.1) > 0.7            # negative control: the surface fills
    # uniform by arc length: the long sides carry L / (L + W) of the points
    on_long = (np.abs(c[:, 1]) < 1e-9) | (np.abs(c[:, 1] - 1.8) < 1e-9)
    assert abs(on_long.mean() - 4.5 / 6.3) < 0.02


def test_visible_faces_only_the_sides_facing_the_sensor_and_count_follows_the_aspect():
    rng = np.random.default_rng(2)
    r = _radar("visible-faces")
    south = np.array([2.25, -20.0])                               # broadside, below the car
    p = np.concatenate([vehicle_points(CAR, r, rng, south) for _ in range(2000)])
    assert np.all(np.abs(p[:, 1]) < 1e-9)                         # only the bottom side
    west = np.array([-20.0, 0.9])                                  # end-on, left of the car
    q = np.concatenate([vehicle_points(CAR, r, rng, west) for _ in range(2000)])
    assert np.all(np.abs(q[:, 0]) < 1e-9)                          # only the left side
    # the count scales with the width presented: 4.5 m broadside, 1.8 m end-on (1.5 points per m)
    assert p.shape[0] / 2000 == pytest.approx(1.5 * 4.5 - 0.5, abs=0.2)   # E[floor(N(mu, .))] ~ mu - 1/2
    assert q.shape[0] / 2000 == pytest.approx(1.5 * 1.8 - 0.5, abs=0.2)
    corner = np.array([-10.0, -10.0])                              # two faces at 45 deg
    c = np.concatenate([vehicle_points(CAR, r, rng, corner) for _ in range(500)])
    assert np.all((np.abs(c[:, 0]) < 1e-9) | (np.abs(c[:, 1]) < 1e-9))
    assert np.any(np.abs(c[:, 0]) < 1e-9) and np.any(np.abs(c[:, 1]) < 1e-9)
    with pytest.raises(InputError, match=r"^sensor: expected the sensor position"):
        vehicle_points(CAR, r, rng)


def test_spread_model_key_is_checked_and_every_model_runs_a_scenario():
    d = to_dict(profile_config("apsipa"))
    d["radar"]["spread_model"] = "edges"
    with pytest.raises(ConfigError, match="radar.spread_model"):
        from_dict(d)
    from radarslam.experiments.single import run_trial

    counts = {}
    for model in ("surface", "contour", "visible-faces"):
        d = to_dict(profile_config("apsipa"))
        d["radar"]["spread_model"] = model
        d["trajectory"]["n_steps"] = 40
        res = run_trial(from_dict(d), 3)
        assert res.metrics["n_landmarks_final"] >= 3, model            # cars get mapped in every model
        assert np.isfinite(res.metrics["position_avg_rmse_m"]) and res.metrics["position_avg_rmse_m"] < 3.0
        counts[model] = sum(s.polar.shape[0] for s in res.scenario.scans)
    # the same count model places the points differently, not more or fewer of them (the streams
    # part after the first car, so the totals differ by chance only: measured 1620 / 1632) ...
    assert abs(counts["surface"] - counts["contour"]) < 0.05 * counts["surface"]
    # ... while the visible faces give fewer: a car shows at most two sides' projected width
    assert counts["visible-faces"] < counts["surface"]
