"""Full-run sensitivity of the Victoria Park result to the victoria-park profile's values.

Each variant overrides a few keys of the profile and runs all 7,230 scans (about 2 min each with
the numba backend); the table prints the GPS-aligned RMSE, the maximum error and the landmark count.

    python scripts/victoria_park_sensitivity.py [--path DIR] [--jobs 2] [--scans N] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from radarslam.config import from_dict, profile_config, to_dict

DEFAULT_PATH = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"
SENSOR_R = {"range_std_m": 0.05, "azimuth_std_deg": 0.5}

#: name -> (overrides, loader options)
VARIANTS: dict[str, tuple[dict, dict]] = {
    "profile": ({}, {}),
    "R x0.5": ({"filter": {"range_std_m": 0.075, "azimuth_std_deg": 0.5}}, {}),
    "R x2": ({"filter": {"range_std_m": 0.3, "azimuth_std_deg": 2.0}}, {}),
    "R = sensor": ({"filter": SENSOR_R}, {}),
    "U x0.5": ({"filter": {"speed_std_mps": 0.05, "steering_std_deg": 1.0}}, {}),
    "U x2": ({"filter": {"speed_std_mps": 0.2, "steering_std_deg": 4.0}}, {}),
    "alpha 60": ({"landmarks": {"alpha": 60.0}}, {}),
    "laser time -80 ms": ({}, {"laser_time_offset": -0.08}),
    "with extent": ({"extent": {"use_in_slam": True}}, {}),
    "with extent, R = sensor": ({"filter": SENSOR_R, "extent": {"use_in_slam": True}}, {}),
    "with extent, R = sensor, no contour sifting": (
        {"filter": SENSOR_R, "extent": {"use_in_slam": True, "contour_sifting": False}}, {}),
}


def _one(args) -> dict:
    from radarslam.experiments.dataset import evaluate_against_gps, run_dataset

    name, path, scans, backend = args
    over, loader = VARIANTS[name]
    d = to_dict(profile_config("victoria-park"))
    d["filter"]["backend"] = backend
    for sec, kv in over.items():
        d[sec].update(kv)
    run = run_dataset("victoria-park", path, from_dict(d), n_scans=scans, progress=False, loader_options=loader)
    ev = evaluate_against_gps(run)
    return {"variant": name, "rmse_m": ev["rmse_m"], "max_m": ev["max_m"], "landmarks": int(run.final_map.ids.size),
            "filter_seconds": run.seconds}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--path", type=Path, default=DEFAULT_PATH)
    ap.add_argument("--scans", type=int, default=None)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--backend", choices=("python", "numba"), default="numba")
    ap.add_argument("--only", nargs="*", choices=sorted(VARIANTS), default=None)
    ap.add_argument("--json", type=Path, default=None, help="also write the rows to this file")
    a = ap.parse_args()
    names = a.only or list(VARIANTS)
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(_one, [(n, a.path, a.scans, a.backend) for n in names]))
    print("| variant | GPS-aligned RMSE (m) | max (m) | landmarks |\n|---|---|---|---|")
    for r in rows:
        print(f"| {r['variant']} | {r['rmse_m']:.2f} | {r['max_m']:.1f} | {r['landmarks']} |")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
