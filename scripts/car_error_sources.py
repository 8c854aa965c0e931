"""Where the automotive filter's pose error and its overconfidence come from, on the given nuScenes
scenes (docs/method.md c.16.6).

    python scripts/car_error_sources.py --data ../shared/data/nuscenes_radar --out runs/car_error_sources

Per scene, ``--profile automotive`` (wheels + Doppler + gyro + radar, c.10.5.2) run in these forms:

- ``profile``: as it is, online, no calibration;
- ``prediction only``: no landmark is ever confirmed (``landmarks.confirm_points`` beyond any cluster,
  ``confirm_hits`` beyond ``confirm_window``), so the pose is the prediction's alone: what the filter
  knows of its error before a landmark moves it;
- ``own calibration``: the drive's own car calibration against its truth (``radarslam calibrate
  --reference truth`` on the same scene), applied to it. The truth sets the values here, so this is a
  bound, not a result: what the map gives once the car's fixed errors are known;
- ``own: yaw only``, ``own: clocks only``, ``own: car only``: that calibration with only the radars'
  yaw offsets, only their time offsets, or only the car's thrust angle, wheel scale and Doppler scale
  kept (the rest at the nominal values).

Prints the position RMSE, its ratio to the car's own uncalibrated wheel + gyro dead reckoning, the
heading's ratio, the time-averaged pose NEES (3 dof), the share of scans inside the per-scan 95% band,
and the 1-dof NEES along the track, across it and in heading (metrics.json ``pose_nees``). Nothing is
chosen here: every form runs with the profile's parameters.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
from pathlib import Path

import numpy as np

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.egomotion.car_calibration import calibrate_car
from radarslam.egomotion.rig import read_rig
from radarslam.io.recording import read_recording
from radarslam.runs.recording import run_recording

SCENES = ("scene-0061", "scene-0103", "scene-0655", "scene-0916")
#: No cluster confirms a landmark: Rule 1 needs more detections than any scan holds, Rule 2 more
#: hits than its window has scans (c.7).
NO_MAP = {"landmarks": {"confirm_points": 100_000, "confirm_window": 3, "confirm_hits": 4}}


def _config(overlay: dict | None = None):
    d = to_dict(profile_config("automotive"))
    for section, kv in (overlay or {}).items():
        d[section] = {**d[section], **kv}
    return from_dict(copy.deepcopy(d))


def _parts(cal) -> dict:
    """The calibration ``cal`` whole and with one group of its values kept (the others nominal)."""
    n = len(cal.sensor_ids)
    none_radar = {"yaw_offset_rad": (0.0,) * n, "time_offset_s": (0.0,) * n}
    none_car = {"thrust_angle_rad": 0.0, "wheel_scale": 1.0, "doppler_scale": 1.0}
    return {"own calibration": cal,
            "own: yaw only": dataclasses.replace(cal, **none_car, time_offset_s=(0.0,) * n),
            "own: clocks only": dataclasses.replace(cal, **none_car, yaw_offset_rad=(0.0,) * n),
            "own: car only": dataclasses.replace(cal, **none_radar)}


def _row(scene: str, form: str, m: dict, dr: dict) -> dict:
    pn, comp = m["pose_nees"], m["pose_nees"]["components"]
    return {"scene": scene, "form": form, "position_m": m["position_rmse_m"], "heading_deg": m["heading_rmse_deg"],
            "ratio": m["position_rmse_m"] / dr["position_rmse_m"],
            "heading_ratio": m["heading_rmse_deg"] / dr["heading_rmse_deg"],
            "nees": pn["time_average"], "inside": pn["share_inside_band"],
            "along": comp["along_track"]["time_average"], "across": comp["cross_track"]["time_average"],
            "nees_heading": comp["heading"]["time_average"]}


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    a.add_argument("--data", default="../shared/data/nuscenes_radar")
    a.add_argument("--out", default="runs/car_error_sources")
    a.add_argument("--scenes", default=",".join(SCENES))
    args = a.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    profile, no_map = _config(), _config(NO_MAP)
    rows = []
    for scene in args.scenes.split(","):
        path = Path(args.data) / scene
        rec = read_recording(path)
        cal = calibrate_car(read_rig(path), np.random.default_rng(0), source=scene, truth=(rec.truth_t, rec.truth))
        base = run_recording(rec, profile).metrics
        dr = base["dead_reckoning"]                       # the car's own wheels and gyro, uncalibrated
        rows.append(_row(scene, "profile", base, dr))
        rows.append(_row(scene, "prediction only", run_recording(rec, no_map).metrics, dr))
        for form, c in _parts(cal).items():
            rows.append(_row(scene, form, run_recording(rec, profile, calibration=c).metrics, dr))
        for r in rows[-6:]:
            print(f"{scene} {r['form']:<16} {r['position_m']:.3f} m  ratio {r['ratio']:.2f}  NEES {r['nees']:.1f}",
                  flush=True)
    lines = ["| scene | form | position RMSE (m) | ratio to DR | heading ratio | NEES (3 dof) | inside 95% | "
             "along | across | heading |", "|---|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['scene']} | {r['form']} | {r['position_m']:.3f} | {r['ratio']:.2f} | {r['heading_ratio']:.2f} | "
              f"{r['nees']:.1f} | {100 * r['inside']:.0f}% | {r['along']:.1f} | {r['across']:.1f} | "
              f"{r['nees_heading']:.1f} |" for r in rows]
    text = "\n".join(lines)
    print(text)
    (out / "car_error_sources.md").write_text(text + "\n")
    (out / "car_error_sources.json").write_text(json.dumps(rows, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
