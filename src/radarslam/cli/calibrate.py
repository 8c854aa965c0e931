"""``radarslam calibrate --recording DIR --out DIR``: each radar's yaw offset from the static world's
Doppler against the odometry (docs/method.md c.12.5), and the ego-motion of the rig from every
radar's Doppler (c.12.4)."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

from radarslam import __version__


def add_parser(sub) -> None:
    p = sub.add_parser("calibrate", help="each radar's yaw offset of a multi-radar recording from its Doppler "
                       "(calibration.csv, sensors_calibrated.csv, ego_velocity.csv)")
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
    p.add_argument("--seed", type=int, default=0, help="seed of RANSAC's draws (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace the results already in --out")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from radarslam.core.errors import InputError
    from radarslam.egomotion.calibrate import MIN_SPEED_MPS, calibrate_yaw, write_calibration
    from radarslam.egomotion.rig import compare_with_odometry, read_rig, rig_ego_velocity, write_ego_velocity_csv
    from radarslam.io.results import prepare_out_dir, refuse_finished, write_json

    t0 = time.perf_counter()
    min_speed = MIN_SPEED_MPS if args.min_speed is None else args.min_speed
    if not (math.isfinite(min_speed) and min_speed > 0):
        raise InputError(f"--min-speed: expected a speed > 0 m/s, got {args.min_speed}")
    refuse_finished(Path(args.out) / "calibration.csv", "--out", args.overwrite)
    rig = read_rig(args.recording, *_chosen_rig(args))
    rng = np.random.default_rng(args.seed)
    cal = calibrate_yaw(rig, rng, min_speed_mps=min_speed)
    ego = rig_ego_velocity(rig, rng, mount=cal.mount(rig))
    out = prepare_out_dir(args.out)
    names = write_calibration(out, rig, cal)
    write_ego_velocity_csv(out / "ego_velocity.csv", ego)
    summary = {"recording": str(args.recording), "version": __version__, "argv": sys.argv, "seed": args.seed,
               "min_speed_mps": min_speed, "wall_seconds": time.perf_counter() - t0,
               "ego_velocity_vs_odometry": compare_with_odometry(ego, rig.odometry)}
    write_json(out / "calibration.json", summary)
    names += ["ego_velocity.csv", "calibration.json"]
    print("sensor  name          yaw offset (deg)   static residual RMS (m/s) before -> after")
    for j, sid in enumerate(cal.sensor_ids):
        print(f"{int(sid):>6}  {cal.names[j]:<12}  {math.degrees(cal.offset[j]):+7.3f} +- {math.degrees(cal.std[j]):.3f}"
              f"    {cal.rms_before[j]:.3f} -> {cal.rms_after[j]:.3f}")
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
