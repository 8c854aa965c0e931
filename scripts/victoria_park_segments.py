"""Where a Victoria Park run's error comes from: the published-protocol error by time window.

Runs a mode's profile (``--input trees`` or ``laser``; ``--config FILE.toml`` laid over it) from
the published start and prints, per window of ``--window`` seconds, the RMSE at the fixes in it,
the filter's position and heading standard deviations at its end, the mean number of associated
detections per scan and the map size; then the share of the whole run's squared error that the
window ``--focus T0 T1`` (seconds) holds and the RMSE without it. The GPS's own faults in a window
(gaps over 3 s, jumps implying more than 8 m/s between fixes) are counted beside it, since the
published protocol keeps every fix (docs/method.md v.4, v.7).

    python scripts/victoria_park_segments.py --input trees [--path DIR] [--config C.toml]
        [--window 50] [--focus 995 1110]
"""

from __future__ import annotations

import argparse
import copy
from pathlib import Path

import numpy as np

from radarslam.config import from_dict, merge_tables, profile_config, read_toml, to_dict
from radarslam.io.datasets.victoria_park import INPUT_PROFILES as PROFILES, PUBLISHED_START

DEFAULT_PATH = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"


def gps_faults(t: np.ndarray, xy: np.ndarray, t0: float, t1: float) -> tuple[int, int]:
    """``(gaps over 3 s, jumps over 8 m/s)`` between consecutive fixes within ``[t0, t1)``."""
    m = (t >= t0) & (t < t1)
    tt, pp = t[m], xy[m]
    if tt.size < 2:
        return 0, 0
    dt = np.diff(tt)
    speed = np.hypot(*np.diff(pp, axis=0).T) / np.maximum(dt, 1e-9)
    return int(np.sum(dt > 3.0)), int(np.sum((dt <= 3.0) & (speed > 8.0)))


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--input", choices=sorted(PROFILES), default="trees")
    ap.add_argument("--path", type=Path, default=DEFAULT_PATH)
    ap.add_argument("--config", type=Path, default=None)
    ap.add_argument("--window", type=float, default=50.0)
    ap.add_argument("--focus", type=float, nargs=2, default=(995.0, 1110.0))
    a = ap.parse_args(argv)
    from radarslam.runs.dataset import evaluate_published, run_dataset, victoria_park_options

    d = copy.deepcopy(to_dict(profile_config(PROFILES[a.input])))
    if a.config is not None:
        d = merge_tables(d, read_toml(a.config))
    d["filter"]["initial_pose"] = list(PUBLISHED_START)
    cfg = from_dict(d)
    run = run_dataset("victoria-park", a.path, cfg, progress=False,
                      loader_options=victoria_park_options(cfg, a.input))
    pub = evaluate_published(run)
    t_fix, e = run.times[pub["index"]], pub["errors_m"]
    gt, gxy = np.asarray(run.gps.t), np.asarray(run.gps.xy)
    print(f"{a.input}: published RMSE {pub['rmse_m']:.2f} m over {e.size} fixes")
    print("| window (s) | RMSE (m) | pos std (m) | heading std (deg) | associated/scan | landmarks | GPS gaps | GPS jumps |")
    print("|---|---|---|---|---|---|---|---|")
    for t0 in np.arange(run.times[0], run.times[-1], a.window):
        t1 = t0 + a.window
        sel, scans = (t_fix >= t0) & (t_fix < t1), np.flatnonzero((run.times >= t0) & (run.times < t1))
        if scans.size == 0:
            continue
        k = scans[-1]
        rmse = f"{np.sqrt(np.mean(e[sel] ** 2)):.2f}" if sel.any() else "-"
        gaps, jumps = gps_faults(gt, gxy, t0, t1)
        print(f"| {t0:.0f}-{t1:.0f} | {rmse} | {np.sqrt(np.trace(run.pose_covs[k][:2, :2]) / 2):.2f} | "
              f"{np.degrees(np.sqrt(run.pose_covs[k][2, 2])):.2f} | {run.n_associated[scans].mean():.1f} | "
              f"{run.n_landmarks[k]} | {gaps} | {jumps} |")
    f = (t_fix >= a.focus[0]) & (t_fix < a.focus[1])
    print(f"window {a.focus[0]:.0f}-{a.focus[1]:.0f} s: {f.sum()} fixes ({f.mean():.1%}), RMSE "
          f"{np.sqrt(np.mean(e[f] ** 2)):.2f} m, {np.sum(e[f] ** 2) / np.sum(e ** 2):.1%} of the squared error; "
          f"RMSE without it {np.sqrt(np.mean(e[~f] ** 2)):.2f} m")


if __name__ == "__main__":
    main()
