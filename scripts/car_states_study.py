"""The car's errors as states online (docs/method.md c.11.12, c.13.1) on the given nuScenes scenes, with
and without the other drive's calibration.

    python scripts/car_states_study.py --data ../shared/data/nuscenes_radar

Per scene, ``--profile automotive`` (wheels + gyro + radar) as it is ("base"), with the thrust-angle
state alone ("thrust": ``filter.odometry_bias = "states"``, ``bias_thrust = true``, the speed scale's
and the gyro offset's priors and drifts 0: the two other states held at 0) and with each radar's yaw
offset too ("thrust+yaw": ``radar_yaw_states = true``, their mean held at 0), with each radar's time offset
alone ("time": ``radar_time_states = true``, the odometry's bias states held at 0, c.13.2), with the thrust
state ("thrust+time"), and without the part in view's offset ("no view offset": ``extent.view_offset =
"none"``, c.17, the profile's before it), each without a calibration and with
the calibration of the other scene of the same car (``radarslam calibrate --reference truth`` on that
scene: 0061 <-> 0916, 0103 <-> 0655). Prints SLAM's and the wheels' and gyro's dead reckoning's (DR,
uncalibrated) position RMSE, their ratio, the heading RMSE, the final thrust estimate with its std and
the final yaw and time offsets (the time offsets with their stds; with a calibration, whose time offsets
already move the stamps, the states estimate what is left).
Nothing is chosen here.
"""

from __future__ import annotations

import argparse
import copy
import math
from pathlib import Path

import numpy as np

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.egomotion.car_calibration import calibrate_car
from radarslam.egomotion.rig import read_rig
from radarslam.io.recording import read_recording
from radarslam.runs.recording import run_recording

PAIRS = {"scene-0061": "scene-0916", "scene-0916": "scene-0061", "scene-0103": "scene-0655", "scene-0655": "scene-0103"}
THRUST_ALONE = {"odometry_bias": "states", "bias_thrust": True, "bias_scale_std": 0.0, "bias_scale_drift_per_rt_s": 0.0,
                "bias_turn_rate_std_deg_s": 0.0, "bias_turn_rate_drift_deg_s_per_rt_s": 0.0,
                "online_car_states": "allow"}     # the study runs what the profile refuses (c.13.3)
#: The bias block with every odometry state held at 0 (priors and drifts 0): the time offsets alone (c.13.2).
HELD = {"odometry_bias": "states", "online_car_states": "allow", "bias_scale_std": 0.0, "bias_scale_drift_per_rt_s": 0.0,
        "bias_turn_rate_std_deg_s": 0.0, "bias_turn_rate_drift_deg_s_per_rt_s": 0.0}
#: Each variant's overlay of the profile, by section.
VARIANTS = {"base": {}, "thrust": {"filter": THRUST_ALONE},
            "thrust+yaw": {"filter": {**THRUST_ALONE, "radar_yaw_states": True}},
            "time": {"filter": {**HELD, "radar_time_states": True}},
            "thrust+time": {"filter": {**THRUST_ALONE, "radar_time_states": True}},
            "no view offset": {"extent": {"view_offset": "none"}}}


def config(variant: str):
    d = to_dict(profile_config("automotive"))
    for section, overlay in VARIANTS[variant].items():
        d[section] = {**d[section], **overlay}
    return from_dict(copy.deepcopy(d))


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    a.add_argument("--data", default="../shared/data/nuscenes_radar")
    a.add_argument("--variants", nargs="+", choices=list(VARIANTS), default=list(VARIANTS))
    a.add_argument("--no-calibration-runs", action="store_true", help="only the runs without a calibration")
    args = a.parse_args(argv)
    data = Path(args.data)
    cals = {}
    for scene in PAIRS:
        r = read_recording(data / scene)
        cals[scene] = calibrate_car(read_rig(data / scene), np.random.default_rng(0), source=scene,
                                    truth=(r.truth_t, r.truth))
    ratios = {}
    print("| scene | calibration | variant | SLAM (m) | DR (m) | ratio | heading SLAM / DR (deg) | thrust (deg) "
          "| yaw offsets (deg) | time offsets (ms) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for scene, other in PAIRS.items():
        rec = read_recording(data / scene)
        dr = None
        for cal in (None,) if args.no_calibration_runs else (None, other):
            for variant in args.variants:
                run = run_recording(rec, config(variant), calibration=None if cal is None else cals[cal])
                m = run.metrics
                dr = dr or m["dead_reckoning"]            # the car's own DR of the run without calibration
                ob = m.get("odometry_bias") or {}
                thrust = "" if "thrust_angle" not in ob else \
                    f"{math.degrees(ob['thrust_angle']['final']):+.2f} +- {math.degrees(ob['thrust_angle']['final_std']):.2f}"
                yaws = ", ".join(f"{math.degrees(v['final']):+.2f}" for k, v in ob.items() if k.startswith("yaw_offset"))
                times = ", ".join(f"{k[len('time_offset_'):]}: {1e3 * v['final']:+.1f} +- {1e3 * v['final_std']:.1f}"
                                  for k, v in ob.items() if k.startswith("time_offset"))
                ratio = m["position_rmse_m"] / dr["position_rmse_m"]
                ratios.setdefault((cal is not None, variant), []).append(ratio)
                print(f"| {scene} | {cal or 'none'} | {variant} | {m['position_rmse_m']:.3f} | {dr['position_rmse_m']:.3f} "
                      f"| {ratio:.2f} | {m['heading_rmse_deg']:.2f} / {dr['heading_rmse_deg']:.2f} | {thrust} | {yaws} | {times} |",
                      flush=True)
    for (cal, variant), rr in ratios.items():
        print(f"| mean | {'other scene' if cal else 'none'} | {variant} | | | {np.mean(rr):.2f} | | | | |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
