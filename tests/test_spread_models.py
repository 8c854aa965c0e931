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
    from radarslam.simulation.trial import run_trial

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


# ------------------------------------------------------------------ the estimators' spread factor (a.11)
def test_spread_factor_follows_the_spread_model_unless_gamma_z_is_set():
    from radarslam.config import SPREAD_FACTORS

    base = to_dict(profile_config())
    assert profile_config().extent.spread_factor == 0.25 == SPREAD_FACTORS["surface"]
    for model, gamma in (("contour", 0.5), ("visible-faces", 0.5)):
        cfg = from_dict({**base, "extent": {**base["extent"], "spread_model": model}})
        assert cfg.extent.spread_factor == gamma
    cfg = from_dict({**base, "extent": {**base["extent"], "spread_model": "contour", "gamma_z": 0.3}})
    assert cfg.extent.spread_factor == 0.3
    with pytest.raises(ConfigError, match=r"extent\.spread_model: expected one of \['surface', 'contour', 'visible-faces', 'scatter-centres'\], got 'edge'"):
        from_dict({**base, "extent": {**base["extent"], "spread_model": "edge"}})


def _ellipse_outline(rng, n, a, b, angle):
    """Points uniform in angle on the outline of the ellipse of semi-axes a, b: covariance X / 2."""
    u = rng.uniform(0, 2 * np.pi, n)
    c, s = np.cos(angle), np.sin(angle)
    p = np.column_stack([a * np.cos(u), b * np.sin(u)])
    return p @ np.array([[c, s], [-s, c]])


def test_contour_spread_factor_recovers_the_outline_ellipse_and_the_surface_one_does_not():
    """RMA and EFA on detections on an ellipse's outline (no noise, known centroid): with the contour
    factor 1/2 both converge to the true X; with the surface factor 1/4 (negative control) their
    axes come out sqrt(2) too long, as a.11 predicts."""
    from radarslam.extent.ellipse import _ellipse_to_matrix
    from radarslam.extent.ellipse_fit import _fit_ellipse
    from radarslam.extent.random_matrix import _rm_update
    from radarslam.metrics.gwd import gaussian_wasserstein_distance

    rng = np.random.default_rng(21)
    a, b, angle = 2.3, 1.1, 0.4
    X_true = _ellipse_to_matrix(a, b, angle)
    zero, W = np.zeros(2), 1e-6 * np.eye(2)
    sizes = {}
    for gamma in (0.5, 0.25):
        X, alpha = _fit_ellipse(_ellipse_outline(rng, 40, a, b, angle), True, None, gamma)[1], 50.0
        efa = []
        for _ in range(200):
            pts = _ellipse_outline(rng, 8, a, b, angle)
            X, alpha = _rm_update(X, alpha, zero, 1e-6 * np.eye(2), pts, W, gamma)
            alpha = 2.0 + np.exp(-0.16 / 100.0) * (alpha - 2.0)
            efa.append(_fit_ellipse(pts, True, None, gamma)[1])
        efa_mean = np.mean(efa, axis=0)
        sizes[gamma] = (np.sqrt(np.linalg.eigvalsh(X)), np.sqrt(np.linalg.eigvalsh(efa_mean)))
        if gamma == 0.5:
            assert gaussian_wasserstein_distance(zero, X, zero, X_true) < 0.08
            assert gaussian_wasserstein_distance(zero, efa_mean, zero, X_true) < 0.08
    for k in (0, 1):  # the RMA's and the EFA's axes
        assert np.allclose(sizes[0.25][k] / sizes[0.5][k], np.sqrt(2), rtol=0.05)
