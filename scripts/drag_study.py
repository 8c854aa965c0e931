"""Do long objects seen in part drag the pose along the road? (docs/results.md).

    python scripts/drag_study.py --data ../shared/data/nuscenes_radar

On each given nuScenes scene (`--profile automotive`, mountings as given), the position error of
SLAM against the truth split into its along-track part (along the truth's direction of motion:
a landmark that slides with the car pulls the pose along the road) and its cross-track part, and
the heading's drift (the slope of the heading error over the drive, deg per 10 s), with the
extents' default estimator, with the partial-view model (docs/method.md a.12), which explains
each scan's detections by the part of the object in view, and with the part in view centred
anywhere on its object (``extent.view_offset = "uniform"``, c.17). Nothing here is tuned.
"""

from __future__ import annotations

import argparse
import copy
from pathlib import Path

import numpy as np

from radarslam.config import from_dict, profile_config, to_dict
from radarslam.io.recording import read_recording
from radarslam.runs.recording import run_recording

SCENES = ("scene-0061", "scene-0103", "scene-0655", "scene-0916")
MODELS = {"default extents": {}, "partial view": {"extent": {"estimator": "partial-view"}},
          "view offset": {"extent": {"view_offset": "uniform"}}}


def config_of(overlay: dict):
    d = to_dict(profile_config("automotive"))
    for section, kv in overlay.items():
        d[section] = {**d[section], **kv}
    return from_dict(copy.deepcopy(d))


def split_errors(poses: np.ndarray, truth: np.ndarray, times: np.ndarray) -> dict:
    """Along- and cross-track error (m; mean, RMSE) and the heading error's drift (deg / 10 s)."""
    ok = np.all(np.isfinite(truth), axis=1)
    p, q, t = poses[ok], truth[ok], times[ok]
    d = np.gradient(q[:, :2], axis=0)                    # the direction of motion (by index: repeated stamps)
    u = d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-9)
    e = p[:, :2] - q[:, :2]
    along = np.einsum("ij,ij->i", e, u)
    cross = u[:, 0] * e[:, 1] - u[:, 1] * e[:, 0]
    head = np.degrees(np.angle(np.exp(1j * (p[:, 2] - q[:, 2]))))
    drift = float(np.polyfit(t - t[0], head, 1)[0] * 10.0) if t.size > 2 else float("nan")
    return {"along_mean_m": float(along.mean()), "along_rmse_m": float(np.sqrt(np.mean(along ** 2))),
            "cross_mean_m": float(cross.mean()), "cross_rmse_m": float(np.sqrt(np.mean(cross ** 2))),
            "heading_drift_deg_per_10s": drift}


def main(argv=None) -> int:
    a = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    a.add_argument("--data", default="../shared/data/nuscenes_radar")
    args = a.parse_args(argv)
    lines = ["| scene | extents | along-track mean / RMSE (m) | cross-track mean / RMSE (m) | heading drift (deg / 10 s) |",
             "|---|---|---|---|---|"]
    for scene in SCENES:
        rec = read_recording(Path(args.data) / scene)
        for name, overlay in MODELS.items():
            run = run_recording(rec, config_of(overlay))
            s = split_errors(run.record.poses, run.truth, run.times)
            lines.append(f"| {scene} | {name} | {s['along_mean_m']:+.3f} / {s['along_rmse_m']:.3f} | "
                         f"{s['cross_mean_m']:+.3f} / {s['cross_rmse_m']:.3f} | {s['heading_drift_deg_per_10s']:+.2f} |")
            print(lines[-1], flush=True)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
