"""Ego-motion from every radar's Doppler on the shared recordings (docs/method.md c.12.4, c.12.6):
reading, the fit over the whole recording (the full model and the no-sideslip one) and its agreement
with the odometry; pure numpy + scipy.sparse, so there is no compile time.

    PYTHONPATH=src python benchmarks/bench_rig_velocity.py [../shared/data/radarscenes/sequence_105 ...]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import _common  # noqa: F401  (one BLAS thread)
import numpy as np

from radarslam.egomotion.rig import compare_with_odometry, read_rig, rig_ego_velocity

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"
DEFAULT = [SHARED / "nuscenes_radar" / f"scene-{s}" for s in ("0061", "0103", "0655", "0916")] + [
    SHARED / "radarscenes" / "sequence_105"]


def main(paths=None, repeats: int = 3) -> dict:
    out = {}
    for p in map(Path, paths or DEFAULT):
        t0 = time.perf_counter()
        rig = read_rig(p)
        read_s = time.perf_counter() - t0
        for lateral in (True, False):
            best = np.inf
            for _ in range(repeats):
                t0 = time.perf_counter()
                s = rig_ego_velocity(rig, np.random.default_rng(0), lateral=lateral)
                best = min(best, time.perf_counter() - t0)
            c = compare_with_odometry(s, rig.odometry)
            v, w = c["speed_mps"], c["yaw_rate_deg_s"]
            model = "v_x, v_y, omega" if lateral else "no sideslip"
            print(f"{p.name}: {rig.t.size} detections, {c['windows']} windows ({c['valid']} valid), {model}: "
                  f"read {read_s:.2f} s, fit {best:.2f} s (best of {repeats}); speed RMSE {v['rmse']:.3f} m/s "
                  f"(mean {v['mean']:+.3f}, std {v['std']:.3f}); yaw rate RMSE {w['rmse']:.2f} deg/s "
                  f"(mean {w['mean']:+.2f}, std {w['std']:.2f})")
            out[(p.name, model)] = {"read_s": read_s, "fit_s": best, **c}
    return out


if __name__ == "__main__":
    main(sys.argv[1:] or None)
