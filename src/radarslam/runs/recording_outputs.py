"""What a recording run adds for a car's radars (docs/recordings.md
"Outputs"): another ``sensors.csv`` for the run (``--sensors``, e.g. ``radarslam calibrate``'s
``sensors_calibrated.csv``), the rig's ego-motion from every radar's Doppler (``ego_velocity.csv``,
``ego_velocity.png``), each input detection's fate under the Doppler gate (``moving.csv``, scored
against the annotation when the recording has one), the map figure (``map.png``) and, with a truth,
the pose NEES (``metrics.json["pose_nees"]``, ``nees.png``; docs/recordings.md "What metrics.json holds").
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.types import Scan
from radarslam.egomotion.rig import Rig, checked_rig_velocity, compare_with_odometry, write_ego_velocity_csv
from radarslam.core.mounting import Mounting
from radarslam.io.recording.stream import Recording

__all__ = ["landmark_sensors", "mounting_metrics", "pose_nees_metrics", "rig_velocity_of", "with_sensors_file",
           "write_run_figures", "write_run_tables"]

#: The seed of the rig fit's RANSAC draws (a run is reproducible).
EGO_SEED = 0


def with_sensors_file(rec: Recording, path: str | Path) -> Recording:
    """``rec`` with its sensors replaced by the ``sensors.csv`` at ``path`` (its columns, docs/recordings.md
    "Several radars"), refused in one line as the recording's own would be (the file, line, column)."""
    from radarslam.io.recording import sensors as S
    from radarslam.io.recording.plain import (
        _read_csv,  # the reader's own checks and messages
    )

    path = Path(path)
    if not path.is_file():
        raise InputError(f"--sensors: {path}: no such file")
    cols = _read_csv(path, "sensors")
    sensors = S.sensors_from_columns(cols, str(path))
    S.check_detection_sensors(rec.channels.get("sensor_id"), sensors, f"{rec.source} (detections)", "detection", 1)
    return dataclasses.replace(rec, sensors=sensors, mounting=None)


def rig_velocity_of(rig: Rig, filter_config):
    """The rig's ``(v_x, v_y, omega)`` about every sweep (docs/method.md c.12.4) as the run takes it
    (:func:`~radarslam.egomotion.rig.checked_rig_velocity`: the configured Doppler floor,
    the systematic terms, the consistency gates of c.12.7): with one radar the no-sideslip model
    (``v_y = 0``: one radar sees its own velocity only, rank 2, c.12.2)."""
    return checked_rig_velocity(rig, filter_config, np.random.default_rng(EGO_SEED),
                                lateral=rig.sensor_ids.size >= 2)


def mounting_metrics(rec: Recording, m: Mounting, events: list) -> dict:
    """``metrics.json["mounting"]``: the one mounting ``m`` the run took for the steps that take one
    (``runs.recording.effective_mounting``; its ``[sensor]`` in the run's config.toml), which radar it
    is and why (``chosen``), and how many scans the filter measured about the platform origin with
    it (``single_mounting_scans``: the Doppler gate's and odometry's directions of a scan without a
    radar of its own; every other scan is measured from its own radar's pose, docs/method.md c.13)."""
    from radarslam.slam.sensor_frame import scan_mounting

    sensors = rec.sensors or {}
    if len(sensors) > 1:
        chosen = (f"sensor {m.sensor_id}{f' ({m.name})' if m.name else ''}, the radar of the most detections of the "
                  f"rig's {len(sensors)}")
    elif sensors:
        chosen = f"sensor {m.sensor_id}{f' ({m.name})' if m.name else ''}, the rig's one radar"
    elif rec.mounting is not None:
        chosen = "the recording's own (a bag's /tf_static), over the config's [sensor]"
    else:
        chosen = "the config's [sensor]"
    n = sum(1 for e in events if isinstance(e, Scan) and scan_mounting(e.sensor) is None)
    return {"x_m": m.x, "y_m": m.y, "yaw_rad": m.yaw, "source": m.source,
            "sensors": {str(k): v.name or str(k) for k, v in sensors.items()},
            "chosen": chosen, "single_mounting_scans": int(n)}


def landmark_sensors(events: list, created: np.ndarray) -> np.ndarray:
    """The ``sensor_id`` of the scan that created each landmark (``created``: the scans' stream
    indices, :class:`~radarslam.slam.filter.MapSnapshot`), -1 where the scan names none."""
    by_index = {}
    for e in events:
        if isinstance(e, Scan):
            sid = e.sensor.sensor_id if e.sensor is not None else None
            if sid is None and e.channels and "sensor_id" in e.channels and len(e.channels["sensor_id"]):
                sid = int(e.channels["sensor_id"][0])
            by_index[e.index] = -1 if sid is None else int(sid)
    return np.array([by_index.get(int(k), -1) for k in np.asarray(created).reshape(-1)], dtype=np.int64)


def bias_metrics(record) -> dict | None:
    """metrics.json's ``odometry_bias``: each state's final value, std and unit (docs/method.md c.11,
    c.11.12, c.13.1), named as the filter's record names them, or None without the states."""
    if record.bias is None:
        return None
    m = len(record.bias_names)
    return {n: {"final": float(record.bias[-1, i]), "final_std": float(record.bias[-1, m + i]), "unit": u}
            for i, (n, u) in enumerate(zip(record.bias_names, record.bias_units))}


def pose_nees_metrics(poses: np.ndarray, covs: np.ndarray, truth: np.ndarray, config, align: str) -> dict:
    """``metrics.json["pose_nees"]``: the platform's pose NEES at every scan against ``truth`` (K, 3) after
    ``align``, as :func:`~radarslam.runs.recording.evaluate_truth` compares the pose (under ``ackermann``
    the filter's sensor pose and its covariance moved back to the axle), with the truth's own accuracy
    ``filter.truth_pose_std`` added to the covariance (:func:`~radarslam.metrics.trajectory.trajectory_nees`).
    A covariance it refuses gives ``{"error": its one line}`` instead."""
    from radarslam.metrics.trajectory import NEES_DEFINITIONS, trajectory_nees
    from radarslam.runs.start import filter_cov_to_platform, filter_to_platform

    std = [float(v) for v in config.filter.truth_pose_std]
    try:
        out = trajectory_nees(filter_to_platform(poses, config), filter_cov_to_platform(poses, covs, config), truth,
                              align, std)
    except InputError as exc:
        return {"error": str(exc)}
    return {**out, "alignment": align, "definitions": NEES_DEFINITIONS,
            "truth_std_added": {"from": "filter.truth_pose_std", "std": std, "units": ["m", "m", "rad"],
                                "what": "diag(std^2) added to the filter's pose covariance at every scan: the "
                                        "truth's own accuracy"}}


def write_run_tables(out: Path, run) -> list[str]:
    """``bias.csv`` (with the odometry-bias states), ``ego_velocity.csv`` (with a rig fit) and
    ``moving.csv`` (under the Doppler gate) of ``run`` (a
    :class:`~radarslam.runs.recording.RecordingRun`); returns the names written."""
    from radarslam.io.results import write_bias_csv
    from radarslam.runs.detection_flags import write_moving_csv

    names = []
    if run.bias is not None:                              # filter.odometry_bias "states" (c.11, c.11.12)
        write_bias_csv(out / "bias.csv", run.times, run.bias, run.bias_std, run.bias_names)
        names.append("bias.csv")
    if run.ego is not None:
        write_ego_velocity_csv(out / "ego_velocity.csv", run.ego)
        names.append("ego_velocity.csv")
    if run.flags is not None:
        rec = run.recording
        sid = rec.channels.get("sensor_id")
        if sid is None:
            sid = np.full(rec.det_t.size, next(iter(rec.sensors)) if rec.sensors else 0)
        write_moving_csv(out / "moving.csv", rec.det_t, sid, run.flags)
        names.append("moving.csv")
    return names


def write_run_figures(out: Path, run) -> list[str]:
    """``map.png``, (with a rig fit) ``ego_velocity.png`` and (with a truth) ``nees.png``; nothing
    without matplotlib (the ``viz`` extra). Returns the names written."""
    from radarslam.viz import have_matplotlib

    if not have_matplotlib():
        return []
    from radarslam.viz.recording import plot_ego_velocity, plot_recording_map

    names = []
    rec, mp = run.recording, run.record.maps[-1]
    if rec.truth is not None:
        reference, label = rec.truth[:, :2], "truth"
    elif run.config.filter.odometry != "odometer":      # no wheel odometry to integrate (the radar alone)
        reference, label = None, ""
    else:
        from radarslam.runs.dead_reckoning import dead_reckoning

        reference, label = dead_reckoning(run.events, run.config, _start(run))[:, :2], \
            "dead reckoning (odometry.csv)"
    names_of = {int(k): (m.name or f"sensor {k}") for k, m in (rec.sensors or {}).items()} or {-1: "radar"}
    sensor = landmark_sensors(run.events, mp.created)
    if not rec.sensors:
        sensor[:] = -1
    plot_recording_map(out / "map.png", run.record.poses, mp.positions, mp.rma, sensor, names_of, reference,
                       reference_label=label, title=f"{Path(rec.source).name}: {mp.ids.size} landmarks, "
                                                    f"{run.times.size} scans")
    names.append("map.png")
    if run.ego is not None:
        odo = np.column_stack([rec.odo_t, rec.odo]) if rec.odo_kind == "unicycle" else None
        plot_ego_velocity(out / "ego_velocity.png", run.ego.t, run.ego.theta, run.ego.cov, run.ego.valid, odo)
        names.append("ego_velocity.png")
    nees = run.metrics.get("pose_nees") or {}
    if nees.get("scans"):                                  # a truth to compare with
        from radarslam.viz.recording import plot_pose_nees

        plot_pose_nees(out / "nees.png", run.times, nees["per_scan"], nees["band_per_scan"], nees["time_average"],
                       share_inside=nees["share_inside_band"], prob=nees["probability"],
                       title=f"{Path(rec.source).name}: pose NEES against the truth (alignment {nees['alignment']})")
        names.append("nees.png")
    return names


def ego_metrics(ego, rig: Rig) -> dict:
    """``metrics.json["ego_velocity"]``: the fit's windows and model (the single-track model's
    compliance with it, docs/method.md c.12.4.1), and its speed and yaw rate against the odometry (:func:`~radarslam.egomotion.rig.compare_with_odometry`) when there is one."""
    from radarslam.models.rig_velocity import FLAGGED_GYRO, FLAGGED_JUMP

    out = {"windows": int(ego.t.size), "valid": int(ego.valid.sum()), "sensors": int(rig.sensor_ids.size),
           "flagged_gyro": int(np.sum(ego.status == FLAGGED_GYRO)),
           "flagged_jump": int(np.sum(ego.status == FLAGGED_JUMP)),
           "model": getattr(ego, "model", "v_x, v_y, omega") if rig.sensor_ids.size >= 2
           else "v_x, omega (no sideslip: one radar)"}
    if getattr(ego, "compliance", None) is not None:   # the single-track model's D (docs/method.md c.12.4.1)
        out["cornering_compliance_rad_per_mps2"] = {"value": ego.compliance[0], "std": ego.compliance[1],
                                                    "yaw_rate_vif": ego.yaw_rate_vif}
    if rig.odometry is not None and rig.odometry.shape[0] >= 2:
        out["against_odometry"] = compare_with_odometry(ego, rig.odometry)
    return out


def _start(run) -> list:
    """The pose the run started at: its metrics' (a recording run), else the
    configuration's (a run of its own start, e.g. the radar alone)."""
    return (run.metrics.get("start") or {}).get("pose", list(run.config.filter.initial_pose))

