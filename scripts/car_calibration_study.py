"""The car calibrated on one drive, run on another drive of the same car (docs/method.md c.16).

    python scripts/car_calibration_study.py --data ../shared/data/nuscenes_radar --out runs/car_calibration

For each pair (0061 <-> 0916, the Singapore car; 0103 <-> 0655, the Boston car) ``radarslam calibrate``
runs on one scene and its file is applied to the other, never to itself. Per scene and mode
(wheels + gyro + radar, Doppler + gyro): the position and heading RMSE of SLAM, the wheels' and gyro's
own dead reckoning (DR, uncalibrated: the car's own odometry) and the ratio, without and with the other
scene's calibration; and the calibration's values. Nothing is chosen here: the profile
(``--profile automotive``) and the calibration's priors are fixed beforehand.
"""

from __future__ import annotations

import argparse
import copy
import json
import math
from pathlib import Path

import numpy as np

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.egomotion.car_calibration import calibrate_car, write_car_calibration
from radarslam.egomotion.rig import read_rig
from radarslam.io.recording import read_recording
from radarslam.runs.recording import run_recording

PAIRS = {"scene-0061": "scene-0916", "scene-0916": "scene-0061", "scene-0103": "scene-0655", "scene-0655": "scene-0103"}
# the profile's filter.odometry "auto" is "wheels+doppler+gyro+radar" on these scenes (c.10.5.2)
MODES = {"wheels+gyro+radar": {"filter": {"odometry": "odometer"}}, "doppler+gyro": {"filter": {"odometry": "doppler", "yaw_rate": "gyro"}},
         # the wheel speed fused with the rig's Doppler velocity in the prediction (c.10.5 "both")
         "wheels+doppler+gyro+radar": {"filter": {"odometry": "both", "yaw_rate": "gyro"}},
         # the radar alone: the rig's (v_x, v_y, omega) from its Doppler, no wheels, no gyro (c.10.5.1, c.12.2)
         "radar-alone": {"filter": {"odometry": "doppler", "yaw_rate": "doppler"}}}


def mode_config(name: str):
    d = to_dict(profile_config("automotive"))
    for section, kv in MODES[name].items():
        d[section] = {**d[section], **kv}
    return from_dict(copy.deepcopy(d))


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    a.add_argument("--data", default="../shared/data/nuscenes_radar")
    a.add_argument("--out", default="runs/car_calibration")
    a.add_argument("--modes", default=",".join(MODES))
    a.add_argument("--reference", choices=("rig", "truth"), default="truth",
                   help="what fixes the car's axis in the calibration drive (radarslam calibrate --reference)")
    args = a.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cals = {}
    for scene in PAIRS:
        truth = None
        if args.reference == "truth":
            r = read_recording(Path(args.data) / scene)
            truth = (r.truth_t, r.truth)
        cal = calibrate_car(read_rig(Path(args.data) / scene), np.random.default_rng(0), source=scene, truth=truth)
        write_car_calibration(out / f"{scene}_{args.reference}.json", cal)
        cals[scene] = cal
    rows = []
    for scene, other in PAIRS.items():
        rec = read_recording(Path(args.data) / scene)
        for mode in args.modes.split(","):
            cfg = mode_config(mode)
            base = run_recording(rec, cfg).metrics
            withc = run_recording(rec, cfg, calibration=cals[other]).metrics
            dr = base["dead_reckoning"]
            rows.append({"scene": scene, "calibration_from": other, "mode": mode,
                         "slam_m": base["position_rmse_m"], "slam_cal_m": withc["position_rmse_m"],
                         "dr_m": dr["position_rmse_m"], "dr_cal_m": withc["dead_reckoning"]["position_rmse_m"],
                         "slam_deg": base["heading_rmse_deg"], "slam_cal_deg": withc["heading_rmse_deg"],
                         "dr_deg": dr["heading_rmse_deg"]})
            r = rows[-1]
            print(f"{scene} {mode:<18} SLAM {r['slam_m']:.3f} -> {r['slam_cal_m']:.3f} m (cal. from {other}); DR "
                  f"{r['dr_m']:.3f} m (calibrated DR {r['dr_cal_m']:.3f}); ratio {r['slam_m'] / r['dr_m']:.2f} -> "
                  f"{r['slam_cal_m'] / r['dr_m']:.2f}; heading {r['slam_deg']:.2f} -> {r['slam_cal_deg']:.2f} deg "
                  f"(DR {r['dr_deg']:.2f})", flush=True)
    lines = ["| scene | calibration from | mode | SLAM (m) | SLAM calibrated (m) | DR (m) | ratio | ratio calibrated | "
             "heading SLAM cal. / DR (deg) |", "|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['scene']} | {r['calibration_from']} | {r['mode']} | {r['slam_m']:.3f} | {r['slam_cal_m']:.3f} "
                     f"| {r['dr_m']:.3f} | {r['slam_m'] / r['dr_m']:.2f} | {r['slam_cal_m'] / r['dr_m']:.2f} | "
                     f"{r['slam_cal_deg']:.2f} / {r['dr_deg']:.2f} |")
    for mode in args.modes.split(","):
        rr = [r for r in rows if r["mode"] == mode]
        lines.append(f"| mean | | {mode} | | | | {np.mean([r['slam_m'] / r['dr_m'] for r in rr]):.2f} | "
                     f"{np.mean([r['slam_cal_m'] / r['dr_m'] for r in rr]):.2f} | |")
    lines += ["", "| calibration of | thrust (deg) | wheel scale | gyro bias (deg/s) | yaw offsets (deg) | time offsets (ms) |",
              "|---|---|---|---|---|---|"]
    for scene, c in cals.items():
        lines.append(f"| {scene} | {math.degrees(c.thrust_angle_rad):+.2f} +- {math.degrees(c.thrust_angle_std):.2f} | "
                     f"{c.wheel_scale:.4f} +- {c.wheel_scale_std:.4f} | {math.degrees(c.gyro_bias_rad_s):+.2f} +- "
                     f"{math.degrees(c.gyro_bias_std):.2f} | "
                     f"{', '.join(f'{math.degrees(e):+.2f}' for e in c.yaw_offset_rad)} | "
                     f"{', '.join(f'{1e3 * e:+.0f}' for e in c.time_offset_s)} |")
    text = "\n".join(lines)
    print(text)
    (out / f"car_calibration_study_{args.reference}.md").write_text(text + "\n")
    (out / f"car_calibration_study_{args.reference}.json").write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
