"""How honest the rig's ego-motion is (docs/method.md c.12.3 step 5b, c.12.7): from a
run's ``ego_velocity.csv`` and the recording's ``odometry.csv``, per sweep the error of ``(v_x, omega)``
against the odometry (interpolated at the sweep's time) and its Mahalanobis distance under the fit's
covariance. Prints the share within the 95% ellipse (chi2_2(0.95) = 5.99), speed and yaw-rate RMSE,
the sweeps beyond 5 standard deviations (m^2 > 25) and how many of them are not flagged, over every
fitted sweep and over the unflagged ones; and the same with the reference's own error added to the
covariance (the profile's ``speed_std_mps``, ``turn_rate_std_deg_s``: the wheels' and gyro's error
against the truth on nuScenes, c.14; not chosen on the recording measured).

    radarslam run --recording ../shared/data/radarscenes/sequence_105 --profile automotive --out /tmp/rs105
    PYTHONPATH=src python benchmarks/bench_ego_honesty.py --run /tmp/rs105 \\
        --recording ../shared/data/radarscenes/sequence_105
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path

import numpy as np

CHI2_2_95 = 5.991464547107979      # scipy.stats.chi2.ppf(0.95, 2)


def read_ego(path: Path) -> dict:
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    if not rows or "status" not in rows[0]:
        raise SystemExit(f"{path}: expected ego_velocity.csv with a status column")
    f = lambda c: np.array([float(r[c]) if r[c] != "" else math.nan for r in rows])
    return {"t": f("t_s"), "vx": f("vx_mps"), "wz": f("yaw_rate_rad_s"), "cxx": f("cov_vx_vx"),
            "cxw": f("cov_vx_wz"), "cww": f("cov_wz_wz"), "status": np.array([r["status"] for r in rows])}


def figures(e: dict, odo: np.ndarray, sel: np.ndarray, ref_var: tuple[float, float]) -> dict:
    t = e["t"][sel]
    err = np.column_stack([e["vx"][sel] - np.interp(t, odo[:, 0], odo[:, 1]),
                           e["wz"][sel] - np.interp(t, odo[:, 0], odo[:, 2])])
    C = np.stack([np.column_stack([e["cxx"][sel] + ref_var[0], e["cxw"][sel]]),
                  np.column_stack([e["cxw"][sel], e["cww"][sel] + ref_var[1]])], axis=1)
    m2 = np.einsum("ki,ki->k", err, np.linalg.solve(C, err[..., None])[..., 0])
    beyond5 = m2 > 25.0
    return {"sweeps": int(sel.sum()), "within_95_ellipse": float(np.mean(m2 <= CHI2_2_95)),
            "speed_rmse_mps": float(np.sqrt(np.mean(err[:, 0] ** 2))),
            "yaw_rate_rmse_deg_s": float(np.degrees(np.sqrt(np.mean(err[:, 1] ** 2)))),
            "median_sd_vx_mps": float(np.median(np.sqrt(C[:, 0, 0]))),
            "median_sd_wz_deg_s": float(np.degrees(np.median(np.sqrt(C[:, 1, 1])))),
            "beyond_5_sigma": int(beyond5.sum()),
            "beyond_5_sigma_unflagged": int(np.sum(beyond5 & (e["status"][sel] == "ok")))}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--run", required=True, type=Path, help="a radarslam run's output directory")
    p.add_argument("--recording", required=True, type=Path, help="the recording (its odometry.csv)")
    p.add_argument("--speed-std", type=float, default=0.12, help="reference speed std (m/s; automotive profile)")
    p.add_argument("--turn-std-deg", type=float, default=0.35, help="reference yaw-rate std (deg/s; the profile)")
    a = p.parse_args(argv)
    e = read_ego(a.run / "ego_velocity.csv")
    odo = np.loadtxt(a.recording / "odometry.csv", delimiter=",", skiprows=1, ndmin=2)
    fitted = np.isfinite(e["vx"]) & np.isfinite(e["cxx"]) & (e["t"] >= odo[0, 0]) & (e["t"] <= odo[-1, 0])
    unflagged = fitted & (e["status"] == "ok")
    counts = {s: int(np.sum(e["status"] == s)) for s in np.unique(e["status"])}
    ref = (a.speed_std ** 2, math.radians(a.turn_std_deg) ** 2)
    out = {"windows": int(e["t"].size), "status": counts,
           "fit covariance": {"all fitted": figures(e, odo, fitted, (0.0, 0.0)),
                              "unflagged": figures(e, odo, unflagged, (0.0, 0.0))},
           "fit + reference noise": {"all fitted": figures(e, odo, fitted, ref),
                                     "unflagged": figures(e, odo, unflagged, ref)}}
    metrics = a.run / "metrics.json"
    if metrics.is_file():
        out["run_metrics_ego_velocity"] = json.loads(metrics.read_text()).get("ego_velocity")
    json.dump(out, sys.stdout, indent=1)
    print()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
