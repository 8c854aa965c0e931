"""One trial: simulate the car park from a seed, run EKF-SLAM on it, evaluate."""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from radarslam.config import Config, validate
from radarslam.core.errors import ConfigError
from radarslam.core.types import Odometry, Scan
from radarslam.metrics.extent import extent_metrics, rectangle_centers
from radarslam.metrics.landmarks import landmark_metrics, matches
from radarslam.metrics.pose import avg_rmse, pose_errors, pose_nees
from radarslam.simulation.scenario import Scenario, generate_scenario, initial_estimate
from radarslam.slam import _fused
from radarslam.slam.filter import EkfSlam, MapSnapshot


@dataclass
class FilterRecord:
    """What the filter estimated after every scan.

    Attributes
    ----------
    poses : ndarray (K, 3)
    pose_covs : ndarray (K, 3, 3)
    maps : list of MapSnapshot
    n_detections, n_associated, n_landmarks : ndarray of int (K,)
    nis_sum, nis_count : ndarray (K,)
        Sum and number of the normalised innovations squared of the scan's EKF updates (2 dof each).
    seconds : float
        Wall time of the filter alone.
    engine : str
        Which engine ran it: ``"fused"`` (one compiled call) or ``"orchestrator"`` (per event).
    """

    poses: np.ndarray
    pose_covs: np.ndarray
    maps: list[MapSnapshot]
    n_detections: np.ndarray
    n_associated: np.ndarray
    n_landmarks: np.ndarray
    seconds: float = 0.0
    events: list = field(default_factory=list)
    nis_sum: np.ndarray = field(default_factory=lambda: np.empty(0))
    nis_count: np.ndarray = field(default_factory=lambda: np.empty(0))
    engine: str = "orchestrator"


#: ``engine`` of :func:`run_filter`: the fused engine where it covers the configuration, or never.
ENGINES = ("auto", "orchestrator")


def run_filter(config: Config, events: list[Odometry | Scan], slam: EkfSlam | None = None,
               on_scan=None, engine: str = "auto") -> FilterRecord:
    """Run :class:`EkfSlam` over an event stream, recording the estimate after every scan;
    ``on_scan()`` (optional) is called after each scan (a progress bar).

    Without ``slam`` and with ``engine="auto"``, a configuration the fused engine covers
    (:func:`radarslam.slam._fused.why_not`) runs the whole stream in one compiled call: the same
    record (docs/architecture.md "The fused engine"); ``on_scan`` is then called once per scan at
    the end. ``engine="orchestrator"`` runs it event by event whatever the configuration (the same
    associations, values equal to 1e-9: the first run on a machine uses it while the fused engine
    has not been compiled yet, experiments/warmup.py)."""
    if engine not in ENGINES:
        raise ConfigError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
    t0 = time.perf_counter()
    if slam is None:
        slam = EkfSlam(config)
        if engine == "auto" and _fused.why_not(slam, events) is None:
            return _fused_record(slam, events, t0, on_scan)
    poses, covs, maps, ndet, nass, nlm, nis_sum, nis_n = [], [], [], [], [], [], [], []
    for ev in events:
        rep = slam.process(ev)
        if rep is None:
            continue
        poses.append(slam.x[:3].copy())
        covs.append(slam.P[:3, :3].copy())
        maps.append(slam.snapshot())
        ndet.append(rep.n_detections)
        nass.append(rep.n_associated)
        nlm.append(slam.state.n_landmarks)
        nis_sum.append(float(rep.nis.sum()))
        nis_n.append(rep.nis.size)
        if on_scan is not None:
            on_scan()
    return FilterRecord(np.array(poses).reshape(-1, 3), np.array(covs).reshape(-1, 3, 3), maps,
                        np.array(ndet), np.array(nass), np.array(nlm), time.perf_counter() - t0,
                        nis_sum=np.array(nis_sum), nis_count=np.array(nis_n, dtype=float))


def _fused_record(slam: EkfSlam, events, t0: float, on_scan) -> FilterRecord:
    """:func:`run_filter` by the fused engine (:mod:`radarslam.slam._fused`): the same record."""
    r, _ = _fused.run(slam, events)
    off = r["map_offsets"].tolist()
    maps = [MapSnapshot(r["ids"][a:b], r["positions"][a:b], r["covs"][a:b], r["rma"][a:b], r["efa"][a:b],
                        r["created"][a:b]) for a, b in zip(off[:-1], off[1:])]
    seconds = time.perf_counter() - t0
    if on_scan is not None:
        for _ in maps:
            on_scan()
    return FilterRecord(r["poses"], r["pose_covs"], maps, r["n_detections"], r["n_associated"], r["n_landmarks"],
                        seconds, nis_sum=r["nis_sum"], nis_count=r["nis_count"].astype(float), engine="fused")


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
    :class:`~radarslam.experiments.first_run.FirstRun`) runs the parts it names through their
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
        python = replace(config, filter=replace(config.filter, backend="python"))
        rec = run_filter(python, scenario.events, on_scan=on_scan, engine="orchestrator")
        rec.engine = "python"
    else:
        rec = run_filter(config, scenario.events, on_scan=on_scan, engine=engine)
    seed_out = ss.entropy if not ss.spawn_key else {"entropy": ss.entropy, "spawn_key": list(ss.spawn_key)}
    return TrialResult(config, seed_out, scenario, rec, evaluate(config, scenario, rec, match))
