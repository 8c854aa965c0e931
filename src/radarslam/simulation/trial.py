"""One trial of the car park: simulate it from a seed, run EKF-SLAM on it (:mod:`radarslam.slam.driver`),
evaluate against the simulator's truth."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from radarslam.config import Config, validate
from radarslam.core.errors import ConfigError
from radarslam.metrics.extent import extent_metrics, rectangle_centers
from radarslam.metrics.landmarks import landmark_metrics, matches
from radarslam.metrics.pose import avg_rmse, pose_errors, pose_nees
from radarslam.simulation.scenario import Scenario, generate_scenario, initial_estimate
from radarslam.slam.driver import FilterRecord, run_filter


def vehicle_rectangles(vehicles) -> np.ndarray:
    """``(V, 4)`` array ``[x_left, y_bottom, size_x, size_y]`` of the simulator's vehicles (what metrics take)."""
    return np.array([[v.x_left, v.y_bottom, v.size_x, v.size_y] for v in vehicles], dtype=float).reshape(-1, 4)


def evaluate(config: Config, scenario: Scenario, rec: FilterRecord, compiled: bool = True) -> dict:
    """Pose and landmark metrics of one run (scalars and per-step arrays).

    The simulator's objects and the filter's snapshots are turned into plain arrays here; the
    metrics see nothing else. ``compiled=False``: the landmark matching through its reference
    (:func:`~radarslam.metrics.landmarks.match`, the same matches; a first run, :mod:`.first_run`).
    """
    truth = scenario.truth
    pos_err, head_err = pose_errors(rec.poses, truth.poses)
    rects = vehicle_rectangles(truth.vehicles)
    centers = rectangle_centers(rects)
    present = np.asarray(truth.present, dtype=bool)
    positions = [m.positions for m in rec.maps]
    gate = config.metrics.match_gate_m
    matched = matches(positions, centers, gate, compiled)  # every scan's landmarks to every vehicle, once
    lm = landmark_metrics(positions, truth.poses, centers, present,
                          config.radar.max_range_m, gate, config.metrics.missed_grace_scans, matched)
    ext = (extent_metrics(positions, [m.rma for m in rec.maps], [m.efa for m in rec.maps], rects, present,
                          gate, config.metrics.include_stale, matched=matched, compiled=compiled)
           if config.extent.track else {})
    return {
        "position_avg_rmse_m": avg_rmse(pos_err),
        "heading_avg_rmse_deg": float(np.degrees(avg_rmse(head_err))),
        "final_position_error_m": float(pos_err[-1]),
        "final_heading_error_deg": float(np.degrees(abs(head_err[-1]))),
        "n_landmarks_final": int(rec.n_landmarks[-1]),
        "position_error_m": pos_err,
        "heading_error_rad": head_err,
        "nees": pose_nees(rec.poses, rec.pose_covs, truth.poses),
        "nis_sum": rec.nis_sum,
        "nis_count": rec.nis_count,
        **lm,
        **ext,
    }


@dataclass
class TrialResult:
    config: Config
    seed: int | list[int]
    scenario: Scenario
    record: FilterRecord
    metrics: dict


#: The motion model of the car-park simulator's platform (docs/method.md b.2).
SIMULATOR_MOTION_MODEL = "unicycle"


def check_simulation_config(config: Config) -> Config:
    """Refuse a configuration whose filter cannot model the simulated platform (a real-data profile
    on the car park); return ``config``."""
    m = config.filter.motion_model
    if m != SIMULATOR_MOTION_MODEL:
        raise ConfigError(f"filter.motion_model: expected {SIMULATOR_MOTION_MODEL!r} for the car-park simulation, whose "
                          f"platform moves by that model, got {m!r} (profile {config.profile!r}; a real-data profile "
                          "goes with --dataset)")
    if any(s <= 0 for s in config.filter.initial_pose_std):   # b.5: the draw's scale and the NEES's P_1
        raise ConfigError(f"filter.initial_pose_std: expected positive values for the car-park simulation (its "
                          f"initial covariance, docs/method.md b.5), got {config.filter.initial_pose_std}")
    return config


def with_initial_estimate(config: Config, scenario: Scenario, ss: np.random.SeedSequence) -> Config:
    """``config`` with ``filter.initial_pose`` set to the trial's initial estimate
    (:func:`~radarslam.simulation.scenario.initial_estimate`, docs/method.md b.5): ``config`` itself
    when ``filter.initial_error`` is "fixed", else a copy (the original is not changed)."""
    if config.filter.initial_error == "fixed":
        return config
    pose = initial_estimate(config.filter, scenario.truth.poses[0], ss)
    return replace(config, filter=replace(config.filter, initial_pose=pose))


def run_trial(config: Config, seed: int | np.random.SeedSequence, *, use_extent: bool | None = None,
              on_scan=None, engine: str = "auto", first_run=None) -> TrialResult:
    """Simulate one scenario from ``seed`` and run the filter on it.

    ``use_extent`` overrides ``config.extent.use_in_slam`` (same data either way); ``on_scan`` and
    ``engine`` are passed to :func:`run_filter`. ``first_run`` (a
    :class:`~radarslam.compiling.first_run.FirstRun`) runs the parts it names through their
    Python reference (the same results; the record's ``engine`` then says "python").
    """
    config = check_simulation_config(validate(config))
    if use_extent is not None:
        config = replace(config, extent=replace(config.extent, use_in_slam=use_extent))
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    sim, match = (True, True) if first_run is None else (first_run.simulation_compiled, first_run.matching_compiled)
    scenario = generate_scenario(config, np.random.default_rng(ss), compiled=sim)
    config = with_initial_estimate(config, scenario, ss)
    if first_run is not None and first_run.filter_backend == "python":
        rec = run_filter(config, scenario.events, on_scan=on_scan, engine="fused-python")
        rec.engine = "python"
    else:
        rec = run_filter(config, scenario.events, on_scan=on_scan, engine=engine)
    seed_out = ss.entropy if not ss.spawn_key else {"entropy": ss.entropy, "spawn_key": list(ss.spawn_key)}
    return TrialResult(config, seed_out, scenario, rec, evaluate(config, scenario, rec, match))
