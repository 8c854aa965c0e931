"""The generated large car park (docs/method.md b.1.1): layout, route, driver, configuration."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.core.errors import ConfigError
from radarslam.simulation.scenario import generate_scenario
from radarslam.simulation.trajectory import noise_free_path
from radarslam.simulation.world import carpark_vehicles, row_geometry, rows_layout


def _rects(world) -> np.ndarray:
    return np.array(rows_layout(world))


def test_rows_layout_geometry():
    """504 cars of the given size, car_gap apart along each row, back-to-back rows row_back_gap
    apart, aisles of the given width free of cars."""
    w = profile_config("large-carpark").world
    r = _rects(w)
    assert r.shape == (w.rows * w.cars_per_row, 4) == (504, 4)
    assert np.all(r[:, 2] == w.car_width_m) and np.all(r[:, 3] == w.car_length_m)
    pitch, row_length, _ = row_geometry(w)
    assert pitch == 2 * w.car_length_m + w.aisle_width_m + w.row_back_gap_m
    for i in range(w.rows):
        row = r[i * w.cars_per_row:(i + 1) * w.cars_per_row]
        assert np.allclose(np.diff(row[:, 0]), w.car_width_m + w.car_gap_m)
        assert np.isclose(row[-1, 0] + w.car_width_m - row[0, 0], row_length)
        y_aisle = (i // 2) * pitch
        edge = row[0, 1] + w.car_length_m if i % 2 == 0 else row[0, 1]
        assert np.isclose(abs(edge - y_aisle), w.aisle_width_m / 2)     # the row borders its aisle
    # rows 1 and 2 are back to back, row_back_gap apart
    assert np.isclose(r[2 * w.cars_per_row, 1] - (r[w.cars_per_row, 1] + w.car_length_m), w.row_back_gap_m)
    # no two cars overlap
    c = r[:, :2] + r[:, 2:] / 2
    d = np.abs(c[:, None] - c[None])
    overlap = (d[..., 0] < w.car_width_m) & (d[..., 1] < w.car_length_m)
    assert overlap.sum() == r.shape[0]  # only each car with itself


def test_serpentine_drives_every_aisle_and_turns_by_pi():
    """The noise-free route runs along the aisles (y = a * pitch on the straights) with headings 0
    and pi, visits them up and down, and passes within radar range of every car."""
    cfg = profile_config("large-carpark")
    cfg = replace(cfg, trajectory=replace(cfg.trajectory, n_steps=4000))
    p = noise_free_path(cfg.trajectory, cfg.world)
    pitch, _, _ = row_geometry(cfg.world)
    straight = np.isclose(np.cos(p[:, 2]) ** 2, 1.0, atol=1e-9)
    assert straight.mean() > 0.8
    aisle = p[straight, 1] / pitch
    # every half turn ends on the next aisle: no drift over 4000 steps and a dozen turns
    assert np.abs(aisle - np.round(aisle)).max() < 1e-6
    visited = np.round(aisle).astype(int)
    n_aisles = (cfg.world.rows + 1) // 2
    assert set(visited.tolist()) == set(range(n_aisles))
    first_top = np.argmax(visited == n_aisles - 1)
    assert visited[-1] < n_aisles - 1 and first_top > 0                 # up to the last aisle, then back down
    r = _rects(cfg.world)
    c = r[:, :2] + r[:, 2:] / 2
    dmin = np.min(np.hypot(c[:, None, 0] - p[None, :, 0], c[:, None, 1] - p[None, :, 1]), axis=1)
    assert dmin.max() < cfg.radar.max_range_m


def test_driver_keeps_the_true_path_on_the_route():
    """With the paper's process noise an open-loop path leaves the aisles; the driver keeps the true
    path within a metre of the plan over 2000 steps, and the odometer reads the applied controls."""
    cfg = profile_config("large-carpark")
    paper_q = replace(cfg.trajectory, process_var_xy_m2=1.5e-3, process_var_heading_rad2=5e-5)
    for traj in (cfg.trajectory, paper_q):
        c = replace(cfg, trajectory=traj)
        sc = generate_scenario(c, np.random.default_rng(3))
        plan = noise_free_path(traj, c.world)
        dev = np.hypot(*(sc.truth.poses[:, :2] - plan[:, :2]).T)
        assert dev.max() < 1.0
        assert np.abs(sc.odometry[1:] - sc.truth.controls[1:]).max() < 0.1   # readings = applied + noise
    # negative control: the same noise without the driver wanders tens of metres off
    from radarslam.simulation.trajectory import process_noise, true_path

    w = process_noise(paper_q, np.random.default_rng(3))
    open_loop = true_path(paper_q, w, cfg.world)
    assert np.hypot(*(open_loop[:, :2] - plan[:, :2]).T).max() > 10.0


def test_large_carpark_config_errors_and_the_paper_layout_untouched():
    base = to_dict(profile_config("large-carpark"))
    with pytest.raises(ConfigError, match=r"world\.cars_per_row: expected at most 100000 cars"):
        from_dict({**base, "world": {**base["world"], "rows": 1000, "cars_per_row": 200}})
    with pytest.raises(ConfigError, match=r"world\.departing_vehicle: expected -1 or an index < 504, got 504"):
        from_dict({**base, "world": {**base["world"], "departing_vehicle": 504}})
    with pytest.raises(ConfigError, match=r"world\.layout: expected one of \['paper', 'rows'\], got 'grid'"):
        from_dict({**base, "world": {**base["world"], "layout": "grid"}})
    # the default layout is the paper's twelve vehicles
    vs = carpark_vehicles(profile_config().world)
    assert len(vs) == 12 and vs[5].departure == 60
