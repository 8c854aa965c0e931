"""Your own recording: run EKF-SLAM on it, evaluate against its truth, write the results; and the
simulated car park exported as a recording (docs/recordings.md)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam.config import Config, to_toml, validate
from radarslam.core.angles import wrap_pi
from radarslam.core.errors import InputError
from radarslam.core.types import Scan
from radarslam.egomotion.rig_odometry import with_rig_velocity
from radarslam.egomotion.clock import clock_of, resolved_clock, shift_stamps
from radarslam.runs.start import (FRAMES, START_STD, filter_to_platform, platform_to_filter,  # noqa: F401
                                  sensor_lever, start_pose, start_std, truth_at)
from radarslam.runs.odometry_choice import resolved_odometry
from radarslam.runs.dead_reckoning import dead_reckoning  # noqa: F401  (runs.recording.dead_reckoning, its former home)
from radarslam.runs.recording_outputs import bias_metrics, mounting_metrics, pose_nees_metrics
from radarslam.runs.stream_run import RecordViews, refuse_drawn_start, refuse_online_car_states, run_stream
from radarslam.models.radar import polar_to_xy
from radarslam.slam.driver import FilterRecord, Observer, drive, fused_maps
from radarslam.core.mounting import Mounting, detections_to_sensor
from radarslam.io.recording.stream import Recording, StreamReport, check_motion_model, stream_events
from radarslam.metrics.trajectory import DEFINITIONS, trajectory_errors


@dataclass
class RecordingRun(RecordViews):
    """EKF-SLAM over a recording: the one run type of a recorded stream, your own recording's or a
    dataset's (:func:`radarslam.runs.dataset.run_dataset`). Its record's views by name
    (``poses``, ``final_map``, ``nis``, ``bias``, ...) are :class:`~radarslam.runs.stream_run.RecordViews`'.

    Attributes
    ----------
    config : Config
        The effective configuration (``sensor`` states ``mounting``, :func:`with_mounting`).
    recording : Recording
        What was read: a recording, or a dataset's loaded data (e.g. ``VictoriaParkData``).
    mounting : Mounting
        The one mounting of the steps that take one (:func:`effective_mounting`).
    events : list of Event
        The stream the filter consumed (detections in the platform frame).
    times : ndarray, shape (K,)
        Scan times (s).
    record : FilterRecord
        Pose, covariance and map after every scan.
    truth : ndarray, shape (K, 3), or None
        The truth at the scan times (NaN outside its time span).
    metrics : dict
    stream : StreamReport
        What the event stream left out (one note line each).
    ego : RigVelocitySeries or None
        The rig's ego-motion from every radar's Doppler (detections with ``doppler_mps``).
    flags : DetectionFlags or None
        Each input detection's fate under ``filter.doppler_gate`` (moving, landmark, used).
    name : str
        What ran, for messages and figures: a dataset's name, else "".
    gps : object or None
        Position fixes to evaluate against (``t`` (n,) s on the scans' clock, ``xy`` (n, 2) m):
        a GPS (Victoria Park's), or None.
    reference_hits : ndarray, shape (n, 3), or None
        A reference detector's detections attributed to the landmarks after each scan that has
        some: landmark id, reference diameter (m), distance (m) (Victoria Park's laser mode: ACFR's trees).
    """

    config: Config
    recording: Recording
    mounting: Mounting
    events: list
    times: np.ndarray
    record: FilterRecord
    truth: np.ndarray | None
    metrics: dict
    stream: StreamReport = dataclasses.field(default_factory=StreamReport)
    ego: object = None
    flags: object = None
    name: str = ""
    gps: object = None
    reference_hits: np.ndarray | None = None

    @property
    def filter_config(self) -> Config:
        """The configuration the filter ran with over :attr:`events` (:func:`with_rig` of :attr:`config`)."""
        return with_rig(self.recording, self.config)


def effective_mounting(rec: Recording, config: Config) -> Mounting:
    """The one mounting of the run's steps that take one: the bag's ``/tf_static`` mounting when it
    has one, else the config's ``[sensor]``; with a multi-radar rig (``rec.sensors``) the sensor of
    the most detections (each scan is measured from its own radar's pose, docs/method.md c.13; this
    one is what the filter takes for a scan without a radar of its own, the Doppler gate's and
    odometry's directions). The run states it in its config's ``[sensor]`` (:func:`with_mounting`)
    and says which it is in ``metrics.json["mounting"]`` (``mounting_metrics``).

    With the ``ackermann`` model the pose already is the sensor's (``filter.sensor_a_m``,
    ``sensor_b_m``), so only a yaw may be added.
    """
    if rec.sensors:
        sid = rec.channels.get("sensor_id")
        ids, counts = (np.unique(sid, return_counts=True) if sid is not None and sid.size
                       else (np.array(sorted(rec.sensors)), np.ones(len(rec.sensors))))
        ms = [rec.sensors[int(k)] for k in ids[np.argsort(-counts, kind="stable")]] or list(rec.sensors.values())
    else:
        ms = [rec.mounting or Mounting.from_config(config.sensor)]
    for m in ms:
        if config.filter.motion_model == "ackermann" and (m.x or m.y):
            raise InputError(f"{m.source}: the ackermann model's pose is the sensor's own (filter.sensor_a_m, "
                             f"sensor_b_m); expected a mounting with x = y = 0, got ({m.x}, {m.y})")
    return ms[0]


#: A truth this far (m, deg) from the start pose used, or this many times dead reckoning's RMSE
#: (and over 1 m), looks like another frame: one warning line.
FAR_START_M, FAR_START_DEG, FAR_RATIO = 1.0, 5.0, 10.0


def evaluate_truth(poses: np.ndarray, dr: np.ndarray, truth: np.ndarray, config: Config, align: str,
                   start: dict) -> dict:
    """The run's and dead reckoning's errors against the truth: the platform's pose
    (moved back from the sensor's under ``ackermann``) after ``align``, what each figure is, and a
    warning when the truth looks like another frame."""
    plat, dr_plat = filter_to_platform(poses, config), filter_to_platform(dr, config)
    own = trajectory_errors(plat, truth, align)
    if not own["truth_scans"]:
        return own
    ref = trajectory_errors(dr_plat, truth, align)
    out = {**own, "frame": start["frame"], "alignment": align,
           "pose_compared": "the platform's" + (" (the filter's sensor pose moved back by filter.vehicle_L_m + "
                                                "sensor_a_m, sensor_b_m)" if sensor_lever(config) else ""),
           "dead_reckoning": {k: v for k, v in ref.items() if k != "truth_scans"},
           "ratio_to_dead_reckoning": {"position_rmse": _ratio(own, ref, "position_rmse_m"),
                                       "heading_rmse": _ratio(own, ref, "heading_rmse_deg")},
           "definitions": {**DEFINITIONS, "dead_reckoning": "odometry.csv integrated by the filter's motion model "
                           "from the same start pose, at the same scan times"}}
    warnings = []
    ok = np.all(np.isfinite(truth), axis=1)
    first = truth[np.argmax(ok)]
    s0 = filter_to_platform(np.array([start["pose"]]), config)[0]
    d_m, d_deg = math.hypot(*(first[:2] - s0[:2])), abs(math.degrees(wrap_pi(first[2] - s0[2])))
    if align == "none" and (d_m > FAR_START_M or d_deg > FAR_START_DEG):
        warnings.append(f"the truth's first pose is {d_m:.2f} m / {d_deg:.1f} deg from the start pose used "
                        f"({start['from']}): another frame? (--align first-pose or se2)")
    if own["position_rmse_m"] > max(1.0, FAR_RATIO * ref["position_rmse_m"]):
        times = own["position_rmse_m"] / max(ref["position_rmse_m"], 1e-12)
        warnings.append(f"position RMSE {own['position_rmse_m']:.2f} m is {times:.0f}x dead reckoning's "
                        f"({ref['position_rmse_m']:.2f} m): the truth in another frame, or the run lost")
    if warnings:
        out["warnings"] = warnings
    return out


def _ratio(a: dict, b: dict, key: str) -> float | None:
    return a[key] / b[key] if b[key] > 0 else None


def with_mounting(config: Config, m: Mounting) -> Config:
    """``config`` whose ``[sensor]`` states ``m`` (:meth:`Mounting.sensor_config`, its other keys kept):
    the mounting the filter's steps that take one read (``EstimatorConfig.mounting``), and the one
    the run's config.toml holds, so that it runs again to the same numbers."""
    return dataclasses.replace(config, sensor=m.sensor_config(config.sensor))


def with_rig(rec: Recording, config: Config) -> Config:
    """``config`` as the filter takes it for ``rec``: ``[sensor]`` the effective mounting
    (:func:`effective_mounting`, :func:`with_mounting`) and, for a rig, ``sensors`` the recording's
    mountings when the config names none, so that the estimator's ``EstimatorConfig.rig`` is the rig
    the scans come from (the radar alone's observability, c.10.5.1 / c.12.2; the retirement's
    margin, c.15). The written config is not this one."""
    from radarslam.config import RigSensorConfig

    config = with_mounting(config, effective_mounting(rec, config))
    if rec.sensors and not config.sensors:
        config = dataclasses.replace(config, sensors=[
            RigSensorConfig(int(k), float(v.x), float(v.y), math.degrees(v.yaw), v.name or "")
            for k, v in sorted(rec.sensors.items())])
    return config


def checked_doppler(rec: Recording, config: Config, mounting: Mounting) -> Recording:
    """``rec`` with its Doppler column signed by ``sensor.doppler_sign`` and divided by
    ``sensor.doppler_scale`` (c.16.5), refused in one line when its static consensus says it is negated
    or ego-compensated against the odometry (egomotion/doppler_column.py)."""
    from pathlib import Path

    from radarslam.egomotion.doppler_column import check_doppler_column, with_doppler_scale, with_doppler_sign

    rec = with_doppler_scale(with_doppler_sign(rec, config.sensor.doppler_sign), config.sensor.doppler_scale)
    src = Path(str(rec.source))
    where = str(src / "detections.csv") if src.is_dir() else str(rec.source)
    check_doppler_column(rec, mounting, where)
    return rec


def run_recording(rec: Recording, config: Config, *, on_scan=None, first_run=None, start: str = "auto",
                  align: str = "none", calibration=None) -> RecordingRun:
    """Run :class:`~radarslam.slam.EkfSlam` over ``rec`` with ``config`` and evaluate against its truth.

    The run starts at :func:`start_pose` (``start``) with the std of :func:`start_std` for where that
    start came from; it is compared with the truth after ``align`` (none, first-pose, se2;
    :func:`evaluate_truth`). ``calibration`` (a
    :class:`~radarslam.egomotion.car_calibration.CarCalibration` of this car, c.16) corrects the
    recording first; the run is then in the car's track frame and its poses and truth are handed
    back in the car's (heading minus the thrust angle).
    """
    if calibration is None and config.filter.calibration:          # the config's file (c.16)
        from radarslam.egomotion.car_calibration import read_car_calibration

        calibration = read_car_calibration(config.filter.calibration, key="filter.calibration")
        config = dataclasses.replace(config, filter=dataclasses.replace(config.filter, calibration=""))
    if calibration is not None:
        from radarslam.egomotion.car_calibration import apply_calibration

        if calibration.reference == "truth":             # c.16.5: its own Doppler scale replaces the config's
            config = dataclasses.replace(config, sensor=dataclasses.replace(config.sensor, doppler_scale=1.0))
        if config.filter.radar_clock == "auto":          # c.12.8: the calibration gives each radar's clock
            config = dataclasses.replace(config, filter=dataclasses.replace(config.filter, radar_clock="as-stamped"))
        run = run_recording(apply_calibration(rec, calibration), config, on_scan=on_scan, first_run=first_run,
                            start=start, align=align)
        return _in_car_frame(run, rec, calibration, align)
    config = validate(config)
    config, odometry = resolved_odometry(rec, config)        # c.10.5.2: "auto" by what the recording carries
    config = resolved_clock(rec, config)                      # c.12.8: the same for the radars' clock
    check_motion_model(rec, config.filter.motion_model)
    refuse_drawn_start(config)                  # b.5: a draw needs the true first pose of a simulation
    refuse_online_car_states(config)            # c.13.3: measured worse on every given drive
    m = effective_mounting(rec, config)          # the steps that take one mounting (metrics.json says which)
    config = with_mounting(config, m)
    rec = checked_doppler(rec, config, m)
    clock = clock_of(rec, config)                # c.12.8: the radars' clock against the wheels, online
    if clock is not None:
        rec = shift_stamps(rec, clock)
    events, report = stream_events(rec, m)
    from radarslam.compiling.heartbeat import stage

    with stage("fitting the rig's ego-motion to its Doppler", enabled=first_run is not None):
        fit = rig_fit(rec, m, config)                        # c.12.4: once, for the prediction and ego_velocity.csv
    rig_of_many = fit if fit is not None and fit[0].sensor_ids.size >= 2 and rec.sensors else None
    events = with_rig_velocity(events, rec, config, rig_of_many)  # c.12: the rig's Doppler odometry, if asked
    times = np.array([e.t for e in events if isinstance(e, Scan)])
    pose, origin = start_pose(rec, config, float(times[0]), start)
    std = start_std(config, origin)             # the written config.toml reruns the same start
    config = dataclasses.replace(config, filter=dataclasses.replace(config.filter, initial_pose=pose,
                                                                    initial_pose_std=std))
    record, flags = _run_filter(with_rig(rec, config), events, on_scan, first_run)
    truth = None if rec.truth is None else truth_at(times, rec.truth_t, rec.truth)
    metrics = {"scans": int(times.size), "detections": int(record.n_detections.sum()),
               "associated": int(record.n_associated.sum()),
               # the map: the state's landmarks and those retired from it (docs/method.md c.15)
               "landmarks_final": int(record.maps[-1].ids.size), "landmarks_in_state": int(record.n_landmarks[-1]),
               "landmarks_retired": int(record.maps[-1].ids.size - record.n_landmarks[-1]),
               "filter_seconds": record.seconds, "mounting": mounting_metrics(rec, m, events),
               "start": {"pose": pose, "from": origin, "frame": FRAMES[origin], "std": std,
                         "std_from": START_STD[origin]},
               "dropped_scans": report.dropped_scans, "zero_range_dropped": report.zero_range,
               "single_detection_scans": report.single_detection_scans}
    if truth is not None:
        metrics.update(evaluate_truth(record.poses, dead_reckoning(events, config, pose), truth, config, align,
                                      metrics["start"]))
    if metrics.get("truth_scans"):                    # the NEES against the same truth (docs/recordings.md)
        metrics["pose_nees"] = pose_nees_metrics(record.poses, record.pose_covs, truth, config, align)
        if "error" in metrics["pose_nees"]:
            metrics.setdefault("warnings", []).append(f"no pose NEES: {metrics['pose_nees']['error']}")
    if odometry is not None:
        metrics["odometry"] = odometry
    if clock is not None:
        metrics["radar_clock"] = clock.summary()
    if record.bias is not None:                                # c.11, c.11.12: the car's states
        metrics["odometry_bias"] = bias_metrics(record)
    ego, flags = _doppler_outputs(rec, m, flags, metrics, config, fit)
    return RecordingRun(config, rec, m, events, times, record, truth, metrics, report, ego, flags)


def _in_car_frame(run: RecordingRun, rec: Recording, calibration, align: str) -> RecordingRun:
    """A run of the calibrated recording (the track frame) with its poses, start and truth in the car's
    frame and the calibration said in its metrics; the errors are the same in both frames. Its
    ``dead_reckoning`` is the car's own (the uncalibrated odometry), the calibrated one beside it."""
    from radarslam.egomotion.car_calibration import car_heading

    run.record.poses = car_heading(run.record.poses, calibration)
    truth = None if run.truth is None else car_heading(run.truth, calibration)
    start = dict(run.metrics["start"])
    start["pose"] = [float(v) for v in car_heading(np.array([start["pose"]]), calibration)[0]]
    deg = math.degrees
    metrics = {**run.metrics, "start": start, "calibration": {
        "source": calibration.source, "thrust_angle_deg": deg(calibration.thrust_angle_rad),
        "wheel_scale": calibration.wheel_scale, "gyro_bias_deg_s": deg(calibration.gyro_bias_rad_s),
        "doppler_scale": calibration.doppler_scale,
        "yaw_offset_deg": {str(s): deg(e) for s, e in zip(calibration.sensor_ids, calibration.yaw_offset_rad)},
        "time_offset_ms": {str(s): 1e3 * e for s, e in zip(calibration.sensor_ids, calibration.time_offset_s)},
        "frame": "the car's (the run went in the track frame, turned by the thrust angle; c.16.3)"}}
    if truth is not None and "dead_reckoning" in run.metrics:
        raw, _ = stream_events(rec, effective_mounting(rec, run.config))
        dr = dead_reckoning(raw, run.config, start["pose"])
        tr = np.array([e.t for e in raw if isinstance(e, Scan)])       # the car's own stamps: interpolated to the run's
        dr = np.column_stack([np.interp(run.times, tr, dr[:, 0]), np.interp(run.times, tr, dr[:, 1]),
                              np.interp(run.times, tr, np.unwrap(dr[:, 2]))])
        own = evaluate_truth(run.record.poses, dr, truth, run.config, align, start)
        metrics["dead_reckoning_calibrated"] = run.metrics["dead_reckoning"]
        metrics["dead_reckoning"] = own["dead_reckoning"]
        metrics["ratio_to_dead_reckoning"] = own["ratio_to_dead_reckoning"]
    return dataclasses.replace(run, truth=truth, metrics=metrics)   # its recording: the calibrated one (stamps moved)


def _run_filter(config: Config, events: list, on_scan, first_run):
    """The filter over ``events`` by the first-run plan's engine (:func:`~radarslam.runs.stream_run.run_stream`)
    and, under ``filter.doppler_gate``, every scan detection's flags (runs/detection_flags.py)."""
    from radarslam.runs.detection_flags import FlagsObserver

    flags = FlagsObserver() if config.filter.doppler_gate else None
    record = run_stream(config, events, first_run, observers=[flags] if flags is not None else [], on_scan=on_scan)
    return record, None if flags is None else flags.result()


def rig_fit(rec: Recording, m: Mounting, config: Config):
    """``(rig, series)``: the recording's rig (:func:`~radarslam.egomotion.rig_odometry.rig_of`, ``m`` as
    its sensor 0 without a rig of its own) and its ego-motion fit as the run writes it
    (``rig_velocity_of``), or None without Doppler."""
    from radarslam.egomotion.rig_odometry import rig_of
    from radarslam.runs.recording_outputs import rig_velocity_of

    rig = rig_of(rec, m)
    return None if rig is None else (rig, rig_velocity_of(rig, config.filter))


def _doppler_outputs(rec: Recording, m: Mounting, flags, metrics: dict, config: Config, fit=None):
    """The rig's ego-motion ``fit`` (:func:`rig_fit`; None without Doppler) and, with ``flags``, each
    input detection's in input order; ``metrics`` gains ``ego_velocity`` and, with the annotation,
    ``moving_scores``."""
    from radarslam.runs.detection_flags import detection_flags, moving_scores, stream_rows
    from radarslam.runs.recording_outputs import ego_metrics

    rig, ego = fit if fit is not None else (None, None)
    if ego is not None:
        metrics["ego_velocity"] = ego_metrics(ego, rig)
    if flags is None:
        return ego, None
    flags = detection_flags(rec.det_t.size, stream_rows(rec, m), flags)
    if rec.labels is not None:
        metrics["moving_scores"] = moving_scores(rec.labels, flags)
    return ego, flags


class AnimationFrames(Observer):
    """What the animation draws after each scan, as plain arrays (viz sees no estimator objects): the
    pose, the scan's detections and their landmark (-1 for none), the map, the truth's pose."""

    def __init__(self, truth: np.ndarray | None):
        self.truth, self.frames = truth, []

    def _frame(self, k: int, scan: Scan, pose, pose_cov, labels, mp) -> None:
        self.frames.append({"t": scan.t, "pose": pose, "pose_cov": pose_cov,
                            "detections": polar_to_xy(_seen_from(pose, scan), scan.polar) if scan.polar.size
                            else np.empty((0, 2)),
                            "labels": labels, "positions": mp.positions, "covs": mp.covs, "extents": mp.rma,
                            "truth": None if self.truth is None else self.truth[k]})

    def after_scan(self, k, slam, scan, report):
        labels = np.full(scan.polar.shape[0], -1)
        for lid, idx in report.associations.items():
            labels[np.asarray(idx, dtype=int)] = lid
        self._frame(k, scan, slam.x[:3].copy(), slam.P[:3, :3].copy(), labels, slam.snapshot())

    def after_fused(self, slam, scans, result, associations):
        a = np.asarray(associations, dtype=np.int64).reshape(-1, 3)
        for k, (scan, mp) in enumerate(zip(scans, fused_maps(result))):
            labels = np.full(scan.polar.shape[0], -1)
            mine = a[a[:, 0] == k]
            labels[mine[:, 1]] = mine[:, 2]
            self._frame(k, scan, result["poses"][k], result["pose_covs"][k], labels, mp)


def animation_frames(run: RecordingRun) -> list[dict]:
    """What the animation draws (:class:`AnimationFrames`): the associations are not in the run's
    record, so the stream is run once more (by the same engine: the same estimate) to read them."""
    frames = AnimationFrames(run.truth)
    form = {"fused-steps": "fused-steps", "fused-python": "fused-python", "python": "fused-python"}
    drive(run.config, run.events, observers=[frames], engine=form.get(run.record.engine, "auto"))
    return frames.frames


def _seen_from(pose: np.ndarray, scan: Scan) -> np.ndarray:
    """The pose a scan's detections are measured from: its radar's (docs/method.md c.13), else the platform's."""
    from radarslam.slam.sensor_frame import sensor_pose

    m = scan.sensor
    return pose if m is None else sensor_pose(pose, m.x, m.y, m.yaw)


def map_rows(run: RecordingRun) -> list[dict]:
    """The final map: id, centroid (m), centroid covariance (m^2), extent matrix (m^2) per landmark."""
    mp = run.record.maps[-1]
    rows = []
    for i, p, c, x, e, cr in zip(mp.ids, mp.positions, mp.covs, mp.rma, mp.efa, mp.created):
        rows.append({"id": int(i), "centroid": p, "centroid_cov": c, "created_scan": int(cr),
                     "extent": x if np.all(np.isfinite(x)) else None,
                     "efa_extent": e if np.all(np.isfinite(e)) else None})
    return rows


def write_recording_outputs(out: Path, run: RecordingRun, extra: dict, *, plots: bool = True) -> list[str]:
    """Every result file of a recording run in ``out`` (its figures with ``plots``, ``--no-plot`` none);
    returns their names (``run.json`` last, the marker)."""
    from radarslam.runs.recording_outputs import write_run_figures, write_run_tables
    from radarslam.io.results import atomic_write_text, write_json, write_trajectory_csv, write_tum

    t, poses = run.times, run.record.poses
    write_tum(out / "trajectory_tum.txt", t, poses)
    write_trajectory_csv(out / "trajectory.csv", t, poses, run.truth, run.record.pose_covs)
    names = ["trajectory_tum.txt", "trajectory.csv"]
    if run.recording.truth is not None:
        write_tum(out / "groundtruth_tum.txt", run.recording.truth_t, run.recording.truth)
        names.append("groundtruth_tum.txt")
    rows = map_rows(run)
    origin = run.metrics.get("start", {}).get("from", "config")     # a run of its own start: the config's pose
    write_json(out / "map.json", {"frame": FRAMES[origin], "landmarks": rows})
    lines = ["id,x_m,y_m,cov_xx_m2,cov_xy_m2,cov_yy_m2,extent_xx_m2,extent_xy_m2,extent_yy_m2"]
    for r in rows:
        ext = r["extent"] if r["extent"] is not None else np.full((2, 2), np.nan)
        vals = [*r["centroid"], r["centroid_cov"][0, 0], r["centroid_cov"][0, 1], r["centroid_cov"][1, 1],
                ext[0, 0], ext[0, 1], ext[1, 1]]
        lines.append(",".join([str(r["id"])] + [repr(float(v)) for v in vals]))
    atomic_write_text(out / "map.csv", "\n".join(lines) + "\n")
    names += ["map.json", "map.csv"] + write_run_tables(out, run) + (write_run_figures(out, run) if plots else [])
    chosen = run.metrics.get("mounting", {}).get("chosen")       # which radar [sensor] holds, and why
    note = {"sensor": f"mount_*: {chosen}, the mounting of the steps that take one (metrics.json mounting)"}
    atomic_write_text(out / "config.toml", to_toml(run.config, notes=note if chosen else None))
    write_json(out / "metrics.json", run.metrics)
    names += ["config.toml", "metrics.json", "run.json"]
    write_json(out / "run.json", {**extra, "source": run.recording.source, "t0_ns": run.recording.t0_ns,
                                  "notes": run.recording.notes})
    return names


def recording_from_scenario(scenario, dt: float, mounting: Mounting | None = None) -> Recording:
    """A simulated trial as a :class:`Recording`: every scan's detections (in the sensor frame of
    ``mounting``), the odometer readings at the scan times and the true poses."""
    m = mounting or Mounting()
    scans = scenario.scans
    t = np.concatenate([np.full(s.polar.shape[0], s.t) for s in scans])
    polar = np.concatenate([s.polar if s.sensor is not None else detections_to_sensor(s.polar, m)   # c.13: its frame
                            for s in scans]).reshape(-1, 2)
    scan_t = np.array([s.t for s in scans])
    odo_t = (np.arange(scenario.odometry.shape[0]) * dt)
    odo_t[: scan_t.size] = scan_t        # the readings at exactly the scan times (row 0: the start)
    return Recording(t, polar, {}, odo_t, np.asarray(scenario.odometry, dtype=float), "unicycle", scan_t,
                     np.asarray(scenario.truth.poses, dtype=float), None, "simulation", [], scan_t)


def export_simulation(config: Config, seed: int, out: Path, *, fmt: str = "mcap",
                      mounting: Mounting | None = None, compiled: bool = True) -> dict[str, Path]:
    """Simulate the car-park trial ``seed`` and write it as a bag (``out/bag``, ``out/bag.bag`` for
    ROS 1), the plain format (``out/plain/``), its truth (``out/groundtruth_tum.txt``) and the
    configuration to run it with (``out/config.toml``, with the mounting). ``compiled`` False
    simulates by the reference (the same scans to the bit; a first run, compiling/policy.py)."""
    from radarslam.simulation.trial import check_simulation_config
    from radarslam.io.recording.bag_write import write_bag
    from radarslam.io.recording.plain import write_plain
    from radarslam.io.results import atomic_write_text, make_dir, write_tum
    from radarslam.simulation.scenario import generate_scenario

    config = check_simulation_config(validate(config))
    m = mounting or Mounting()
    config = with_mounting(config, m)
    scenario = generate_scenario(config, np.random.default_rng(np.random.SeedSequence(seed)), compiled=compiled)
    rec = recording_from_scenario(scenario, config.trajectory.dt_s, m)
    bag = out / ("bag.bag" if fmt == "ros1" else "bag")
    write_bag(rec, bag, fmt, mounting=m)
    plain = make_dir(out / "plain")
    write_plain(rec, plain)
    write_tum(out / "groundtruth_tum.txt", rec.truth_t, rec.truth)
    atomic_write_text(out / "config.toml", to_toml(config))
    return {"bag": bag, "plain": plain, "truth": out / "groundtruth_tum.txt", "config": out / "config.toml"}
