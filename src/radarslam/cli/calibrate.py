"""``radarslam calibrate --recording DIR --out DIR``: the car's fixed errors from one drive by batch
least squares on the rig's Doppler (docs/method.md c.16): the thrust angle, the wheel-speed scale,
the gyro's bias, each radar's yaw offset (referenced to the rig) and time offset, written as
``car_calibration.json`` for ``radarslam run --calibration``; the per-radar table, the calibrated
``sensors.csv`` and the ego-motion of the rig from every radar's Doppler (c.12.4)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from radarslam import __version__


def add_parser(sub) -> None:
    p = sub.add_parser("calibrate", help="the car's thrust angle, wheel scale, gyro bias and each radar's yaw and "
                       "time offset from one drive's Doppler (car_calibration.json for run --calibration, "
                       "calibration.csv, sensors_calibrated.csv, ego_velocity.csv)")
    p.add_argument("--recording", metavar="DIR", required=True,
                   help="a plain recording directory with detections.csv (doppler_mps, sensor_id), sensors.csv and "
                        "odometry.csv")
    p.add_argument("--out", metavar="DIR", required=True, help="output directory")
    p.add_argument("--sensors", metavar="FILE.csv", help="each radar's mounting from this sensors.csv instead of "
                   "the recording's (and of the config's [[sensors]])")
    p.add_argument("--config", metavar="FILE.toml", help="a config whose [[sensors]] rig replaces the recording's "
                   "sensors.csv (docs/recordings.md \"A rig in the config\"); nothing else of it is used")
    p.add_argument("--min-speed", type=float, default=None, metavar="M/S",
                   help="sweeps whose sensor moves slower are left out (default 2.0)")
    p.add_argument("--fix", action="append", default=[], metavar="NAME",
                   help="leave this quantity at its prior (0, or 1 for the scale); repeatable; one of thrust_angle, "
                        "wheel_scale, gyro_bias, yaw_offsets, time_offsets")
    p.add_argument("--reference", choices=("rig", "truth"), default="rig",
                   help="what fixes the car's axis: the rig (the radars' yaw offsets sum to zero; default) or the "
                        "drive's truth.csv (its direction of motion gives the thrust angle, its speed the wheel scale)")
    p.add_argument("--seed", type=int, default=0, help="seed of RANSAC's draws (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace the results already in --out")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from radarslam.core.errors import InputError
    from radarslam.egomotion.calibrate import MIN_SPEED_MPS, write_calibration
    from radarslam.egomotion.rig import compare_with_odometry, read_rig, rig_ego_velocity, write_ego_velocity_csv
    from radarslam.io.results import prepare_out_dir, refuse_finished, write_json

    t0 = time.perf_counter()
    min_speed = MIN_SPEED_MPS if args.min_speed is None else args.min_speed
    if not (math.isfinite(min_speed) and min_speed > 0):
        raise InputError(f"--min-speed: expected a speed > 0 m/s, got {args.min_speed}")
    refuse_finished(Path(args.out) / "calibration.csv", "--out", args.overwrite)
    from radarslam.egomotion.car_calibration import ESTIMATES, calibrate_car, write_car_calibration, yaw_table

    bad = sorted(set(args.fix) - set(ESTIMATES))
    if bad:
        raise InputError(f"--fix: expected some of {', '.join(ESTIMATES)}, got {', '.join(bad)}")
    rig = read_rig(args.recording, *_chosen_rig(args))
    # the first line at once (<= 3 s), before the sweeps' fits and the least squares
    print(f"calibrate: {rig.t.size} detections of {rig.sensor_ids.size} radar(s) from {args.recording}; fitting "
          f"every sweep, then the car's errors (reference: the {args.reference})", file=sys.stderr, flush=True)
    rng = np.random.default_rng(args.seed)
    truth = _truth(args.recording) if args.reference == "truth" else None
    car = calibrate_car(rig, rng, estimate=tuple(e for e in ESTIMATES if e not in args.fix), min_speed_mps=min_speed,
                        source=str(args.recording), truth=truth)
    cal = yaw_table(car, rig)
    ego = rig_ego_velocity(rig, rng, mount=cal.mount(rig))
    out = prepare_out_dir(args.out)
    write_car_calibration(out / "car_calibration.json", car)
    names = ["car_calibration.json"] + write_calibration(out, rig, cal)
    write_ego_velocity_csv(out / "ego_velocity.csv", ego)
    summary = {"recording": str(args.recording), "version": __version__, "argv": sys.argv, "seed": args.seed,
               "min_speed_mps": min_speed, "fixed": sorted(args.fix), "wall_seconds": time.perf_counter() - t0,
               "ego_velocity_vs_odometry": compare_with_odometry(ego, rig.odometry)}
    write_json(out / "calibration.json", summary)
    names += ["ego_velocity.csv", "calibration.json"]
    deg = math.degrees
    print(f"thrust angle {deg(car.thrust_angle_rad):+.3f} +- {deg(car.thrust_angle_std):.3f} deg, wheel scale "
          f"{car.wheel_scale:.4f} +- {car.wheel_scale_std:.4f}, gyro bias {deg(car.gyro_bias_rad_s):+.3f} +- "
          f"{deg(car.gyro_bias_std):.3f} deg/s ({car.n_sweeps} sweeps; reference: the {car.reference})"
          + (f", Doppler scale {car.doppler_scale:.4f}" if car.reference == "truth" else ""))
    print("sensor  name          yaw offset (deg)   time offset (ms)   velocity residual RMS (m/s) before -> after")
    for j, sid in enumerate(car.sensor_ids):
        print(f"{int(sid):>6}  {cal.names[j]:<12}  {deg(car.yaw_offset_rad[j]):+7.3f} +- {deg(car.yaw_offset_std[j]):.3f}"
              f"   {1e3 * car.time_offset_s[j]:+6.1f} +- {1e3 * car.time_offset_std[j]:.1f}"
              f"     {car.sensor_rms_before[j]:.3f} -> {car.sensor_rms_after[j]:.3f}")
    print(f"wrote {out}/ ({', '.join(names)}) in {time.perf_counter() - t0:.1f} s")
    return 0


def _chosen_rig(args: argparse.Namespace) -> tuple:
    """``read_rig``'s ``(sensors, origin)`` by ``run --recording``'s precedence: ``--sensors FILE``, else
    the ``--config``'s ``[[sensors]]``, else ``(None, "sensors.csv")`` (the recording's own)."""
    from radarslam.cli.recording import chosen_rig
    from radarslam.config import load_config

    config = load_config(args.config) if args.config else None
    sensors, origin = chosen_rig(args, config)
    return sensors, (f"--sensors {args.sensors}" if args.sensors else origin or "sensors.csv")


def _truth(recording: str):
    """``(t, poses)`` of the recording's ``truth.csv`` (``--reference truth``), refused in one line without one."""
    from radarslam.core.errors import InputError
    from radarslam.io.recording import read_recording

    rec = read_recording(recording)
    if rec.truth is None:
        raise InputError(f"--reference truth: expected {recording}/truth.csv (t_s, x_m, y_m, yaw_rad), got none")
    return rec.truth_t, rec.truth
