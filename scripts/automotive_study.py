"""A car's radar: SLAM on the shared nuScenes scenes against the car's own dead reckoning.

For each scene and each prediction mode -- wheel speed + gyro + radar (``filter.odometry`` odometer),
the same with the rig's Doppler velocity fused into the prediction (``both``, c.10.5), Doppler speed + gyro (``doppler``, ``yaw_rate`` gyro) and the radar alone (``doppler``, ``yaw_rate``
doppler) -- the ``automotive`` profile runs with the mountings as given and with the side radars'
yaw calibrated from the static world's Doppler (``radarslam calibrate``, docs/method.md c.12.5; the
calibration of each scene from that scene). Each row gives the position and heading RMSE over the
scans (as evo's APE, no alignment) of SLAM and of dead reckoning (odometry.csv integrated from the
truth's first pose at the same scans) and their ratio. Prints a Markdown table.

    python scripts/automotive_study.py [--data ../shared/data/nuscenes_radar] [--scenes scene-0061 ...]

The recordings are read from ``--data`` and never copied (CC BY-NC-SA 4.0, SOURCE.md).
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from radarslam.config import profile_config, validate
from radarslam.egomotion.calibrate import calibrate_yaw
from radarslam.runs.recording import run_recording
from radarslam.egomotion.rig import read_rig
from radarslam.io.recording import read_recording
from radarslam.io.recording.mounting import Mounting

# the profile's filter.odometry "auto" is "with its Doppler" on these scenes (c.10.5.2)
MODES = {"wheels + gyro + radar": {"odometry": "odometer"}, "wheels + gyro + radar with its Doppler": {"odometry": "both", "yaw_rate": "gyro"},
         "Doppler + gyro": {"odometry": "doppler", "yaw_rate": "gyro"},
         "radar alone": {"odometry": "doppler", "yaw_rate": "doppler"}}
SCENES = ("scene-0061", "scene-0103", "scene-0655", "scene-0916")


def calibrated(rec, path: Path):
    """``rec`` with each sensor's yaw replaced by its Doppler calibration (c.12.5) where one was found."""
    cal = calibrate_yaw(read_rig(path), np.random.default_rng(0))
    sensors = dict(rec.sensors)
    for sid, off in zip(cal.sensor_ids.tolist(), cal.offset.tolist()):
        if np.isfinite(off):
            m = sensors[sid]
            sensors[sid] = Mounting(m.x, m.y, m.yaw + off, "calibrated", m.sensor_id, m.name, m.max_range_m, m.fov_rad)
    return dataclasses.replace(rec, sensors=sensors)


def doppler_dead_reckoning(rec, path: Path) -> dict:
    """The radar alone without a map: the rig's Doppler fit (v_x, v_y, omega; c.12) at every sweep
    integrated from the truth's first pose, a window without a fit holding the last one; its errors
    at the truth's times (what "radar alone" is compared with)."""
    from radarslam.egomotion.rig import rig_ego_velocity
    from radarslam.egomotion.rig_odometry import rig_of
    from radarslam.runs.recording import truth_at
    from radarslam.metrics.trajectory import trajectory_errors

    series = rig_ego_velocity(rig_of(rec), np.random.default_rng(0))
    t, theta = series.t, series.theta.copy()
    for k in range(1, t.size):                                 # hold the last valid fit
        if not np.all(np.isfinite(theta[k])):
            theta[k] = theta[k - 1]
    theta = np.nan_to_num(theta)
    tt = rec.truth_t
    # start at the first sweep within the truth, from the truth interpolated there (not
    # the next truth sample, which is up to one truth interval, 20 ms at 9 m/s = 0.18 m, further on)
    k0 = int(np.searchsorted(t, tt[0]))
    t, theta = t[k0:], theta[k0:]
    pose = truth_at(t[:1], tt, rec.truth)[0]
    pose[2] = np.interp(t[0], tt, np.unwrap(rec.truth[:, 2]))
    poses = np.empty((t.size, 3))
    poses[0] = pose
    for k in range(1, t.size):
        dt = t[k] - t[k - 1]
        vx, vy, w = theta[k - 1]
        c, s = np.cos(pose[2] + 0.5 * w * dt), np.sin(pose[2] + 0.5 * w * dt)
        pose = pose + np.array([c * vx - s * vy, s * vx + c * vy, w]) * dt
        poses[k] = pose
    ok = (t >= tt[0]) & (t <= tt[-1])
    truth = np.column_stack([np.interp(t[ok], tt, rec.truth[:, 0]), np.interp(t[ok], tt, rec.truth[:, 1]),
                             np.interp(t[ok], tt, np.unwrap(rec.truth[:, 2]))])
    return trajectory_errors(poses[ok], truth)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", default=str(Path(__file__).resolve().parents[2] / "shared/data/nuscenes_radar"))
    ap.add_argument("--scenes", nargs="+", default=list(SCENES))
    args = ap.parse_args()
    print("| scene | mountings | mode | SLAM pos. RMSE (m) | DR pos. RMSE (m) | ratio | SLAM heading RMSE (deg) "
          "| DR heading RMSE (deg) | landmarks | run (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    ratios: dict = {}
    doppler_dr: dict = {}
    alone: dict = {}
    for scene in args.scenes:
        path = Path(args.data) / scene
        given = read_recording(path)
        doppler_dr[scene] = doppler_dead_reckoning(given, path)["position_rmse_m"]
        for label, rec in (("as given", given), ("calibrated", calibrated(given, path))):
            for mode, f in MODES.items():
                cfg = profile_config("automotive")
                cfg = validate(dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, **f)))
                t0 = time.perf_counter()
                m = run_recording(rec, cfg).metrics
                dr, r = m["dead_reckoning"], m["ratio_to_dead_reckoning"]["position_rmse"]
                ratios.setdefault((label, mode), []).append(r)
                if mode == "radar alone":
                    alone[(label, scene)] = m["position_rmse_m"]
                print(f"| {scene} | {label} | {mode} | {m['position_rmse_m']:.3f} | {dr['position_rmse_m']:.3f} | "
                      f"{r:.2f} | {m['heading_rmse_deg']:.3f} | {dr['heading_rmse_deg']:.3f} | "
                      f"{m['landmarks_final']} | {time.perf_counter() - t0:.1f} |", flush=True)
    print("\n| mountings | mode | mean ratio to dead reckoning (position) | scenes below 1 |")
    print("|---|---|---|---|")
    for (label, mode), rs in ratios.items():
        print(f"| {label} | {mode} | {np.mean(rs):.2f} | {sum(x < 1 for x in rs)} of {len(rs)} |")
    print("\n| scene | the rig's Doppler dead reckoning, no map: pos. RMSE (m) | radar alone / it, as given "
          "| radar alone / it, calibrated |")
    print("|---|---|---|---|")
    for scene, v in doppler_dr.items():
        print(f"| {scene} | {v:.3f} | {alone[('as given', scene)] / v:.2f} | {alone[('calibrated', scene)] / v:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
