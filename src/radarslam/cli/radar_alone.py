"""``radarslam run --recording BAG --radar-topic T --imu-topic T`` with ``filter.odometry = "doppler"``:
EKF-SLAM on a 3-D radar recording without odometry (docs/recordings.md "A radar alone")."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from radarslam import __version__
from radarslam.core.errors import InputError


def radar_alone_cmd(args: argparse.Namespace, config) -> int:
    """Read the radar and the IMU, level, run the filter, write every output; the inputs are read
    and checked before ``--out`` is created."""
    from radarslam.cli.common import one_topic, stream_first_run
    from radarslam.runs.progress import Progress
    from radarslam.runs.radar_alone import Imu, check_radar_alone_config, run_radar_alone
    from radarslam.runs.radar_alone_report import (dead_reckoning, plot_map, plot_speed_yaw, summary, write_ego_velocity)
    from radarslam.runs.recording import write_recording_outputs
    from radarslam.io.recording.bag import read_bag, read_imu_samples
    from radarslam.io.results import prepare_out_dir, refuse_finished, write_json
    from radarslam.viz import have_matplotlib

    t0 = time.perf_counter()
    config = check_radar_alone_config(config)
    if not args.imu_topic:
        raise InputError("--imu-topic: filter.odometry 'doppler' on a recording without odometry needs the gyro "
                         "(a sensor_msgs/Imu topic), got none")
    topic = one_topic(args, "SLAM from a radar alone (filter.odometry 'doppler')")
    rec = read_bag(args.recording, topic, None, doppler_field=args.doppler_field)
    log_time = any("log time" in n for n in rec.notes)
    t_ns, gyro, accel, note = read_imu_samples(args.recording, args.imu_topic, log_time=log_time)
    notes = list(rec.notes) + ([note] if note else [])
    for n in notes:
        print(f"radarslam: warning: {n}", file=sys.stderr)
    imu = Imu((t_ns - rec.t0_ns) * 1e-9, gyro, accel)
    n = rec.scan_times().size
    first = stream_first_run(config, n, rec.det_t.size)      # the one compile policy (compiling/policy.py)
    bar = Progress(n, 0, unit="scans", enabled=sys.stderr.isatty() or first.expected_s > 10.0,
                   warm_up_unit=True)      # the first scan carries the reading and the setup: no rate from it
    run, lev = run_radar_alone(rec, imu, config, on_scan=bar.update, first_run=first)
    out = prepare_out_dir(args.out)
    refuse_finished(out / "run.json", "--out", args.overwrite)
    summ = summary(run, lev)
    run.metrics.update({k: summ[k] for k in ("checks", "trajectory", "gyro_dead_reckoning", "accel")})
    write_ego_velocity(out / "ego_velocity.csv", lev)
    write_json(out / "summary.json", summ)
    names = ["ego_velocity.csv", "summary.json"]
    if have_matplotlib():
        plot_speed_yaw(out / "speed_yaw.png", lev)
        plot_map(out / "map.png", run, lev, dead_reckoning(lev)["positions"])
        names += ["speed_yaw.png", "map.png"]
    run.recording.notes = notes + lev.notes
    names = names[:2] + write_recording_outputs(out, run, {
        "recording": str(args.recording), "mode": "SLAM from a radar alone (Doppler + gyro)", "version": __version__,
        "argv": sys.argv, "wall_seconds": time.perf_counter() - t0}) + names[2:]
    c, tr, dr = summ["checks"], summ["trajectory"], summ["gyro_dead_reckoning"]
    fmt = lambda v, f: "n/a" if v is None else format(v, f)  # noqa: E731
    walk, corr = fmt(c["walking_speed_median_mps"]["value"], ".2f"), fmt(c["accel_correlation"]["value"], ".3f")
    print(f"radarslam run --recording (SLAM, radar alone): {summ['scans']} scans, velocity for "
          f"{summ['scans_valid']}, {summ['scans_at_rest']} at rest, walking {walk} m/s, accel. correlation {corr}; "
          f"turn {tr['turn_deg']:+.1f} deg, end-start {tr['end_start_m']:.2f} m (dead reckoning "
          f"{dr['turn_deg']:+.1f} deg, {dr['end_start_m']:.2f} m); {summ['landmarks_final']} landmarks; "
          f"checks {'pass' if summ['all_pass'] else 'FAIL'}")
    print(f"wrote {Path(out)}/ ({', '.join(names)})")
    return 0
