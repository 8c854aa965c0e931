"""``radarslam run --recording``, ``radarslam convert`` and ``radarslam export``: your own recording
(docs/recordings.md). Inputs are read and checked in full before ``--out`` is created."""

from __future__ import annotations

import argparse
import math
import sys
import time

from radarslam import __version__
from radarslam.cli.common import (add_config_args, config_from_args, one_topic, radar_topics, stream_first_run,
                                  topic_arg)
from radarslam.core.errors import InputError


def add_recording_args(p: argparse.ArgumentParser, run: bool) -> None:
    """The options that name a recording and its topics."""
    p.add_argument("--recording", metavar="PATH", required=not run,
                   help="a bag (ROS 1 .bag, a ROS 2 bag directory: sqlite3 or MCAP) or the plain format (a directory "
                        "with detections.csv and odometry.csv, or an .npz file)")
    p.add_argument("--radar-topic", metavar="TOPIC", action="append",
                   help="bag: sensor_msgs/PointCloud2 (or radar_msgs/RadarScan) topic of the radar; give it once per "
                        "radar for a rig (or a comma-separated list): topic i is sensor_id i, its mounting from "
                        "/tf_static for its frame (docs/recordings.md \"Bags\")")
    p.add_argument("--odom-topic", metavar="TOPIC", help="bag: nav_msgs/Odometry topic (forward speed, yaw rate)")
    p.add_argument("--truth-topic", metavar="TOPIC", help="bag: optional truth (nav_msgs/Odometry or PoseStamped)")
    p.add_argument("--imu-topic", metavar="TOPIC", help="bag: sensor_msgs/Imu topic; without --odom-topic the run "
                   "is the ego-motion from Doppler alone (its gyro for the lever arm), or with filter.odometry = "
                   "'doppler' SLAM driven by the Doppler and the gyro (docs/recordings.md \"A radar alone\")")
    p.add_argument("--doppler-field", metavar="NAME", help="bag: the PointCloud2 field holding the radial velocity "
                   "(default: doppler, velocity, v_r, VrelRad, ... when present)")
    if run:
        p.add_argument("--align", choices=("none", "first-pose", "se2"), default="none",
                       help="--recording: how the estimate is aligned to the truth before its errors are taken: none "
                            "(default, as evo_ape without -a), first-pose, or se2 (rotation and translation of least "
                            "squares, no scale, as evo_ape -a)")
        p.add_argument("--calibration", metavar="FILE.json", help="--recording: the car's fixed errors from "
                       "'radarslam calibrate' on another drive of the same car (car_calibration.json: thrust angle, wheel "
                       "scale, gyro bias, each radar's yaw and time offset; docs/method.md c.16)")
        p.add_argument("--sensors", metavar="FILE.csv", help="--recording: each radar's mounting from this sensors.csv "
                       "instead of the recording's (e.g. radarslam calibrate's sensors_calibrated.csv)")
        p.add_argument("--doppler-sign", type=int, choices=(1, -1), default=None,
                       help="--recording: the sign of the Doppler column, 1 positive receding (the raw radial "
                            "velocity) or -1 approaching-positive; overrides [sensor] doppler_sign (a column whose "
                            "static consensus disagrees with the odometry is refused, docs/recordings.md \"Doppler\")")
        p.add_argument("--animate", metavar="FILE", help="--recording: draw the run scan by scan into FILE.gif "
                       "(or .mp4 with ffmpeg)")


def chosen_rig(args, config=None):
    """The rig that takes the place of the recording's own, by precedence (docs/recordings.md "A rig in
    the config"): ``--sensors FILE``, else the config's ``[[sensors]]``, else None (the recording's own:
    its ``sensors.csv``, a bag's ``/tf_static``). Returns ``(sensors, origin)``, ``origin`` naming where
    the mountings were looked for in the one-line refusal of a detection without one (None for
    ``--sensors``, whose refusals read as the recording's own ``sensors.csv``'s)."""
    from radarslam.io.recording import sensors as S

    path = getattr(args, "sensors", None)
    if path:
        from radarslam.io.recording.plain import read_sensors_file

        return read_sensors_file(path), None
    if config is not None and config.sensors:
        where = "the config's [[sensors]]" + (f" ({args.config})" if getattr(args, "config", None) else "")
        return S.sensors_from_config(config.sensors, where), where
    return None, None


def _read(args, rig=None):
    """The recording; ``rig`` (:func:`chosen_rig`'s) gives a bag rig the mountings its /tf_static lacks;
    a dataset in its official layout (``--dataset nuscenes|radarscenes``) is read by its reader."""
    from radarslam.io.recording import read_recording

    if getattr(args, "official", None):
        from radarslam.cli.official import read_official

        rec = read_official(args)
    else:
        rec = read_recording(args.recording, radar_topic=topic_arg(args), odom_topic=args.odom_topic,
                             truth_topic=args.truth_topic, doppler_field=args.doppler_field,
                             sensors=rig if len(radar_topics(args)) > 1 else None)
    for note in rec.notes:
        print(f"radarslam: warning: {note}", file=sys.stderr)
    return rec


def run_recording_cmd(args: argparse.Namespace) -> int:
    """``radarslam run --recording PATH ... --out DIR``."""
    from radarslam.runs.progress import Progress
    from radarslam.runs.recording import run_recording, write_recording_outputs
    from radarslam.io.results import prepare_out_dir, refuse_finished
    from pathlib import Path

    if args.dataset:
        raise InputError("--recording: expected either --recording or --dataset, got both")
    if args.animate and not args.animate.endswith((".gif", ".mp4")):
        raise InputError(f"--animate: expected a .gif or .mp4 file, got {args.animate}")
    refuse_finished(Path(args.out) / "run.json", "--out", args.overwrite)   # before any work
    config = config_from_args(args)
    if getattr(args, "doppler_sign", None) is not None:
        import dataclasses

        config = dataclasses.replace(config, sensor=dataclasses.replace(config.sensor, doppler_sign=args.doppler_sign))
    if not args.odom_topic and radar_topics(args):
        if getattr(args, "sensors", None):
            raise InputError("--sensors: expected a run with odometry (a plain recording, or --odom-topic), got a "
                             "run without")
        if config.sensors:
            raise InputError("sensors: the config's [[sensors]] rig expects a run with odometry (a plain recording, "
                             "or --odom-topic), got a run without (one radar: its mounting is [sensor])")
        if config.filter.odometry == "doppler":
            from radarslam.cli.radar_alone import radar_alone_cmd

            return radar_alone_cmd(args, config)
        return ego_motion_cmd(args, config)
    t0 = time.perf_counter()
    rig, origin = chosen_rig(args, config)        # --sensors FILE, else the config's [[sensors]], else None
    rec = _read(args, rig)
    sensors_file = _sensors_file(args, config)
    rig_from = "--sensors" if args.sensors else "config" if config.sensors else "recording" if rec.sensors else None
    if rig is not None:
        from radarslam.io.recording.sensors import with_sensors

        rec = with_sensors(rec, rig, origin)
    n = rec.scan_times().size
    from radarslam.runs.recording import with_rig

    # the one compile policy (compiling/policy.py) for the filter this recording drives: its rig, its mounting
    from radarslam.runs.odometry_choice import resolved_odometry

    first = stream_first_run(with_rig(rec, resolved_odometry(rec, config)[0]), n, rec.det_t.size)
    # a run expected to take over 10 s shows its rate and ETA, on a terminal or not
    bar = Progress(n, 0, unit="scans", enabled=sys.stderr.isatty() or first.expected_s > 10.0,
                   warm_up_unit=True)      # the first scan carries the reading and the setup: no rate from it
    calibration = None
    if getattr(args, "calibration", None):
        from radarslam.egomotion.car_calibration import read_car_calibration

        calibration = read_car_calibration(args.calibration)
    run = run_recording(rec, config, on_scan=bar.update, first_run=first, align=args.align, calibration=calibration)
    for note in run_notes(run):
        print(f"radarslam: {note}", file=sys.stderr)
    out = prepare_out_dir(args.out)
    refuse_finished(out / "run.json", "--out", args.overwrite)
    names = write_recording_outputs(out, run, {"recording": str(args.recording), "version": __version__,
                                                "argv": sys.argv, "wall_seconds": time.perf_counter() - t0,
                                                "engine": run.record.engine, "sensors_file": sensors_file,
                                                "rig_from": rig_from}, plots=not getattr(args, "no_plot", False))
    if args.animate:
        from radarslam.runs.recording import animation_frames
        from radarslam.viz.animation import animate_run

        frames = animation_frames(run)
        bar = Progress(len(frames), 0, unit="frames")
        animate_run(args.animate, frames, on_frame=bar.update)
        names.append(args.animate)
    m = run.metrics
    line = (f"radarslam run --recording: {m['scans']} scans, {m['detections']} detections, {m['associated']} "
            f"associated, {m['landmarks_final']} landmarks; filter {m['filter_seconds']:.2f} s")
    if "position_rmse_m" in m:
        dr, ratio = m["dead_reckoning"], m["ratio_to_dead_reckoning"]["position_rmse"]
        line += (f"; against the truth ({m['truth_scans']} scans, alignment {m['alignment']}): position RMSE (evo's "
                 f"APE rmse) {m['position_rmse_m']:.3f} m, heading RMSE {m['heading_rmse_deg']:.3f} deg; dead "
                 f"reckoning {dr['position_rmse_m']:.3f} m, {dr['heading_rmse_deg']:.3f} deg"
                 + (f" (ratio {ratio:.2f})" if ratio is not None else ""))
    print(line)
    print(f"wrote {out}/ ({', '.join(names)})")
    return 0


def _sensors_file(args, config=None) -> str | None:
    """The sensors.csv a run takes: ``--sensors``, else None under a config rig, else the plain
    recording's own, else None."""
    from pathlib import Path

    if args.sensors:
        return str(args.sensors)
    if config is not None and config.sensors:
        return None
    own = Path(args.recording) / "sensors.csv"
    return str(own) if own.is_file() else None


def run_notes(run) -> list[str]:
    """One line each: what the stream left out, where the run started
    and what its evaluation found suspicious."""
    st = run.metrics["start"]
    x, y, yaw = st["pose"]
    where = {"truth": "the truth's first pose", "zero": "zero (no truth at the first scan)",
             "config": "the config's filter.initial_pose"}[st["from"]]
    notes = [f"warning: {n}" for n in run.stream.notes + run.metrics.get("warnings", [])]
    sx, sy, syaw = st["std"]
    start = (f"the run starts at {where}: ({x:.3f} m, {y:.3f} m, {math.degrees(yaw):.3f} deg) with std "
             f"({sx:.3g} m, {sy:.3g} m, {math.degrees(syaw):.3g} deg) from {st['std_from']}; map and trajectory "
             f"are in {st['frame']}")
    odometry = run.metrics.get("odometry")
    chosen = [f"the prediction: filter.odometry {odometry['chosen']!r} ({odometry['from']})"] if odometry else []
    return [*notes, start, *chosen]


def ego_motion_cmd(args: argparse.Namespace, config) -> int:
    """``radarslam run --recording BAG --radar-topic T [--imu-topic T]`` without odometry: the
    ego-motion from Doppler alone (docs/recordings.md "A radar alone")."""
    from pathlib import Path

    import numpy as np

    from radarslam.config import to_toml
    from radarslam.egomotion.single_radar import ego_motion, summary, write_ego_motion
    from radarslam.io.recording.bag import read_bag, read_imu
    from radarslam.io.results import atomic_write_text, prepare_out_dir, refuse_finished, write_json

    t0 = time.perf_counter()
    topic = one_topic(args, "the ego-motion from Doppler (a run without --odom-topic)")
    rec = read_bag(args.recording, topic, None, doppler_field=args.doppler_field)
    for note in rec.notes:
        print(f"radarslam: warning: {note}", file=sys.stderr)
    gyro = None
    if args.imu_topic:
        log_time = any("log time" in n for n in rec.notes)
        t_ns, rates = read_imu(args.recording, args.imu_topic, log_time=log_time)
        gyro = ((t_ns - rec.t0_ns) * 1e-9, rates)
    run = ego_motion(rec, config, np.random.default_rng(0), gyro)
    out = prepare_out_dir(args.out)
    refuse_finished(out / "run.json", "--out", args.overwrite)
    names = write_ego_motion(out, run)
    m = summary(run)
    write_json(out / "metrics.json", m)
    atomic_write_text(out / "config.toml", to_toml(config))
    write_json(out / "run.json", {"recording": str(args.recording), "mode": "ego-motion from Doppler",
                                  "version": __version__, "argv": sys.argv, "notes": rec.notes,
                                  "t0_ns": rec.t0_ns, "wall_seconds": time.perf_counter() - t0})
    names += ["metrics.json", "config.toml", "run.json"]
    print(f"radarslam run --recording (ego-motion from Doppler): {m['scans']} scans, velocity for "
          f"{m['valid_scans']} ({100 * m['valid_fraction']:.1f}%), {m['at_rest_scans']} at rest, median speed "
          f"while moving {m['moving_speed_median_mps'] or float('nan'):.2f} m/s")
    print(f"wrote {Path(out)}/ ({', '.join(names)})")
    return 0


def add_parsers(sub) -> None:
    p = sub.add_parser("convert", help="write a bag (or a plain recording) in the plain format (CSV or NPZ)")
    add_recording_args(p, run=False)
    p.add_argument("--out", required=True, metavar="DIR_OR_FILE.npz",
                   help="a directory for CSV files, or an .npz file")
    p.add_argument("--overwrite", action="store_true", help="replace the files already there")
    p.set_defaults(func=convert_cmd)
    e = sub.add_parser("export", help="write a simulated car-park trial as a ROS bag and the plain format, with truth")
    e.add_argument("--seed", type=int, default=1, help="trial seed (default 1)")
    add_config_args(e)
    e.add_argument("--format", choices=("mcap", "sqlite3", "ros1"), default="mcap",
                   help="bag storage: ROS 2 MCAP (default), ROS 2 sqlite3 or a ROS 1 .bag")
    e.add_argument("--mount", nargs=3, type=float, metavar=("X_M", "Y_M", "YAW_DEG"),
                   help="write the detections in the frame of a radar mounted here (and /tf_static)")
    e.add_argument("--out", required=True, metavar="DIR", help="output directory (a new or empty one)")
    e.add_argument("--overwrite", action="store_true", help="replace an earlier export in --out")
    e.set_defaults(func=export_cmd)


def convert_cmd(args: argparse.Namespace) -> int:
    """``radarslam convert --recording BAG --radar-topic T [--radar-topic T2 ...] [--odom-topic T] --out DIR|FILE.npz``
    (several radar topics: a rig, written with its sensors.csv)."""
    from pathlib import Path

    from radarslam.io.recording import is_plain
    from radarslam.io.recording.plain import write_plain
    from radarslam.io.results import prepare_out_dir

    out = Path(args.out)
    if not is_plain(args.recording) and not radar_topics(args):
        raise InputError(f"--recording {args.recording}: a bag needs --radar-topic")
    target = out if out.suffix == ".npz" else out / "detections.csv"
    if target.exists() and not args.overwrite:
        raise InputError(f"--out: {target} already exists; pass --overwrite to replace it, or choose another path")
    if args.odom_topic is None and not is_plain(args.recording):
        from radarslam.io.recording.bag import read_bag

        rec = read_bag(args.recording, topic_arg(args), None, args.truth_topic, doppler_field=args.doppler_field)
        for note in rec.notes:
            print(f"radarslam: warning: {note}", file=sys.stderr)
    else:
        rec = _read(args)
    if out.suffix != ".npz":
        prepare_out_dir(out)
    else:
        prepare_out_dir(out.parent)
    files = write_plain(rec, out)
    print(f"radarslam convert: {rec.scan_times().size} scans, {rec.det_t.size} detections "
          f"(channels: {', '.join(rec.channels) or 'none'}), {rec.odo_t.size} odometry rows"
          + (f", {rec.truth_t.size} truth poses" if rec.truth is not None else "")
          + (f"; times from {rec.t0_ns} ns" if rec.t0_ns else ""))
    print(f"wrote {', '.join(str(f) for f in files)}")
    return 0


def export_cmd(args: argparse.Namespace) -> int:
    """``radarslam export --seed N --out DIR``: the simulated trial as a bag + plain files + truth."""
    from radarslam.runs.recording import export_simulation
    from radarslam.simulation.trial import check_simulation_config
    from radarslam.core.mounting import Mounting
    from radarslam.io.results import prepare_out_dir

    if args.seed < 0:
        raise InputError(f"--seed: expected an integer >= 0, got {args.seed}")
    config = check_simulation_config(config_from_args(args))
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise InputError("export: writing bags needs the 'ros' extra (pip install \"radarslam[ros]\")") from None
    m = Mounting(args.mount[0], args.mount[1], math.radians(args.mount[2]), "--mount") if args.mount else None
    out = prepare_out_dir(args.out)
    existing = [p for p in ("bag", "bag.bag", "plain", "config.toml") if (out / p).exists()]
    if existing:
        if not args.overwrite:
            raise InputError(f"--out: {out} already holds an export ({', '.join(existing)}); pass --overwrite "
                             "to replace it, or choose another directory")
        import shutil

        for p in existing:
            (shutil.rmtree if (out / p).is_dir() else (lambda q: q.unlink()))(out / p)
    from radarslam.compiling.first_run import choose

    plan = choose(config.filter.backend, simulation=True, config=config)   # the one compile policy: a trial's kind
    paths = export_simulation(config, args.seed, out, fmt=args.format, mounting=m, compiled=plan.simulation_compiled)
    print(f"radarslam export: seed {args.seed}, {config.trajectory.n_steps} scans; wrote {paths['bag']} "
          f"({args.format}; topics /radar/points, /odom, /truth, /tf_static), {paths['plain']}/, {paths['truth']}, "
          f"{paths['config']}")
    return 0


