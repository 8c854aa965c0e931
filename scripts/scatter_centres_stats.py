"""Counts and spread factor of each radar spread model along the car park's true trajectory
(docs/method.md b.4.2, a.11): the numbers behind the ``scatter-centres`` defaults and its gamma_z.

For ``--trials`` seeded true paths of a profile's car park, every car within range of every true
pose gets its detections drawn by ``vehicle_points`` (before the sensor noise, which the estimators
model apart). Printed per model:

- the mean kept detections per car in range per scan, and the median range of those cars;
- gamma_z, the spread factor: the detections' second moment about the car's centre, pooled over
  the scans, in the car's frame, against the car's extent matrix X = diag(L^2, W^2) / 3 (the moment
  ellipse, Decision 7), as sqrt(det) (the geometric mean of the two per-axis ratios, printed too).
  Uniform on the rectangle this gives 1/4 exactly and uniform on its outline 0.49 for 4.5 x 1.8 m,
  the factors of a.11.

``python scripts/scatter_centres_stats.py [--trials 5] [--seed 1000] [--profile apsipa]`` (seconds).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from radarslam.config import profile_config
from radarslam.simulation import generate_scenario
from radarslam.simulation.radar import vehicle_points

MODELS = ("surface", "contour", "visible-faces", "scatter-centres")


def measure(cfg, model: str, trials: int, seed: int) -> dict:
    """Mean count per car per scan, median range, per-axis and pooled spread factors of ``model``."""
    radar = replace(cfg.radar, spread_model=model)
    counts, ranges = [], []
    moments: dict[int, list[np.ndarray]] = {}
    for t in range(trials):
        truth = generate_scenario(cfg, np.random.default_rng(seed + t)).truth
        rng = np.random.default_rng([seed + t, 1])
        for k, pose in enumerate(truth.poses, start=1):
            for v in truth.vehicles:
                d = math.hypot(*(v.center - pose[:2]))
                if not v.present(k) or d > radar.max_range_m:
                    continue
                p = vehicle_points(v, radar, rng, pose[:2]) - v.center
                if v.size_x < v.size_y:          # the car's frame: x along its length
                    p = p[:, ::-1]
                counts.append(p.shape[0])
                ranges.append(d)
                moments.setdefault(v.index, []).append(p)
    ratios = []
    for i, ps in moments.items():
        v = truth.vehicles[i]
        p = np.concatenate(ps)
        second = p.T @ p / max(p.shape[0], 1)
        ratios.append(np.diag(second) / (np.array([v.length, v.width]) ** 2 / 3.0))
    r = np.mean(ratios, axis=0)
    return {"count": float(np.mean(counts)), "range_m": float(np.median(ranges)), "gamma_axes": r,
            "gamma": float(math.sqrt(r[0] * r[1]))}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=5)
    ap.add_argument("--seed", type=int, default=1000)
    ap.add_argument("--profile", default="apsipa")
    a = ap.parse_args(argv)
    cfg = profile_config(a.profile)
    print(f"profile {a.profile}, {a.trials} true paths from seed {a.seed}")
    print(f"{'model':16s} {'count/car/scan':>14s} {'median range':>12s} {'gamma_z (L, W)':>18s} {'gamma_z':>8s}")
    for model in MODELS:
        m = measure(cfg, model, a.trials, a.seed)
        g = m["gamma_axes"]
        print(f"{model:16s} {m['count']:14.2f} {m['range_m']:10.1f} m {g[0]:8.3f} {g[1]:8.3f}  {m['gamma']:8.3f}")


if __name__ == "__main__":
    main()
