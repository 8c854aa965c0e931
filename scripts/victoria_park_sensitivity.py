"""Full-run sensitivity of the Victoria Park result to its profile's values, in either input mode.

Every variant scales or overrides a few keys of the mode's profile (``victoria-park`` for the raw
laser, ``victoria-park-trees`` for ACFR's tree detections) and runs the whole recording from the
published start (the first GPS fix, in the GPS frame). One run gives both figures: the
published-protocol RMSE (no alignment, every scan within 25 ms of a fix; docs/method.md v.4) and the
GPS-aligned RMSE (EKF-SLAM is invariant to a rigid change of the world frame, so the start does not
change the aligned figure), the published RMSE over the scans before and from ``HALF`` (3600: the
first half, on which parameters are chosen, and the second), the NIS inside its 95% band and the
fraction of scans whose GPS error lies within the filter's 2-sigma bound (docs/method.md v.7). The
robustness rule: no variant may give more than 1.5 times the profile's published RMSE;
the last column says whether it does, and the last line gives the worst row's ratio.

``--config FILE.toml`` lays a candidate's keys over the profile before every variant scales it (the
variants then perturb the candidate, not the profile), and ``--scans 3600`` restricts the table to
the first half, the part of the run on which a candidate may be chosen (docs/method.md c.11.7).

    python scripts/victoria_park_sensitivity.py --input trees [--path DIR] [--jobs 2] [--scans N]
        [--config FILE.toml] [--only NAME ...] [--json FILE]
"""

from __future__ import annotations

import argparse
import copy
import json
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from radarslam.config import from_dict, merge_tables, profile_config, read_toml, to_dict
from radarslam.io.datasets.victoria_park import INPUT_PROFILES as PROFILES

#: The first scan of the second half (the first half, scans 0-3599, is where parameters are chosen).
HALF = 3600
#: A variant fails the robustness rule above this multiple of the profile's published RMSE.
LIMIT = 1.5
DEFAULT_PATH = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"


def _scale(section: str, keys: tuple[str, ...], factor: float):
    def change(d: dict) -> dict:
        for k in keys:
            d[section][k] = d[section][k] * factor
        return d
    return change


def _set(section: str, **kv):
    def change(d: dict) -> dict:
        d[section].update(kv)
        return d
    return change


def _standard_jacobians(d: dict) -> dict:
    """JCBB evaluates its Jacobians at the estimate (its orchestrated form refuses first estimates,
    docs/method.md c.2.1): a candidate with ``filter.jacobians = "fej"`` runs its JCBB row with the
    standard ones."""
    d["filter"]["jacobians"] = "standard"
    return d


#: name -> (change of the profile's dict, loader options)
VARIANTS = {
    "profile": (lambda d: d, {}),
    "R x0.5": (_scale("filter", ("range_std_m", "azimuth_std_deg"), 0.5), {}),
    "R x2": (_scale("filter", ("range_std_m", "azimuth_std_deg"), 2.0), {}),
    "U x0.5": (_scale("filter", ("speed_std_mps", "steering_std_deg"), 0.5), {}),
    "U x2": (_scale("filter", ("speed_std_mps", "steering_std_deg"), 2.0), {}),
    "alpha x0.5": (_scale("landmarks", ("alpha",), 0.5), {}),
    "alpha x2": (_scale("landmarks", ("alpha",), 2.0), {}),
    "laser time -50 ms": (lambda d: d, {"laser_time_offset": -0.05}),
    "laser time +50 ms": (lambda d: d, {"laser_time_offset": 0.05}),
    "associator nearest-neighbour": (_set("landmarks", associator="nearest-neighbour"), {}),
    "associator batch": (_set("landmarks", associator="batch"), {}),
    "associator jcbb": (lambda d: _standard_jacobians(_set("landmarks", associator="jcbb")(d)), {}),
}


def run_variant(name: str, mode: str, path: Path, scans: int | None, backend: str,
                overlay: dict | None = None) -> dict:
    """One full run of variant ``name`` in input ``mode`` (the profile with ``overlay``, a config
    dict, laid over it first): its figures as a dict."""
    from radarslam.runs.dataset import (evaluate_against_gps, evaluate_published, nis_fraction, position_consistency, run_dataset, victoria_park_options)
    from radarslam.io.datasets.victoria_park import PUBLISHED_START

    change, loader = VARIANTS[name]
    d = change(merge_tables(copy.deepcopy(to_dict(profile_config(PROFILES[mode]))), overlay or {}))
    d["filter"]["backend"] = backend
    d["filter"]["initial_pose"] = list(PUBLISHED_START)
    cfg = from_dict(d)
    run = run_dataset("victoria-park", path, cfg, n_scans=scans, progress=False,
                      loader_options=victoria_park_options(cfg, mode, **loader))
    pub, ev = evaluate_published(run), evaluate_against_gps(run)
    first = pub["index"] < HALF
    half = [float(np.sqrt(np.mean(pub["errors_m"][m] ** 2))) if m.any() else float("nan") for m in (first, ~first)]
    return {"variant": name, "input": mode, "published_rmse_m": pub["rmse_m"], "published_max_m": pub["max_m"],
            "first_half_rmse_m": half[0], "second_half_rmse_m": half[1],
            "aligned_rmse_m": ev["rmse_m"], "landmarks": int(run.final_map.ids.size),
            "nis_inside": nis_fraction(run)["inside"], "inside_2sigma": position_consistency(run, pub)["inside_both"],
            "ms_per_scan": 1e3 * run.seconds / max(run.times.size, 1)}


def _one(args) -> dict:
    return run_variant(*args)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--input", choices=sorted(PROFILES), default="laser", help="the input mode (default laser)")
    ap.add_argument("--path", type=Path, default=DEFAULT_PATH)
    ap.add_argument("--scans", type=int, default=None, help="only the first N scans (default: the whole run)")
    ap.add_argument("--jobs", type=int, default=1, help="processes (timings are only meaningful with 1)")
    ap.add_argument("--backend", choices=("python", "numba"), default="numba")
    ap.add_argument("--only", nargs="*", choices=sorted(VARIANTS), default=None)
    ap.add_argument("--json", type=Path, default=None, help="also write the rows to this file")
    ap.add_argument("--config", type=Path, default=None,
                    help="a candidate's keys (TOML) laid over the profile before each variant's change")
    a = ap.parse_args()
    names = a.only or list(VARIANTS)
    overlay = read_toml(a.config) if a.config else None
    with ProcessPoolExecutor(a.jobs) as ex:
        rows = list(ex.map(_one, [(n, a.input, a.path, a.scans, a.backend, overlay) for n in names]))
    base = next((r["published_rmse_m"] for r in rows if r["variant"] == "profile"), None)
    print(f"input {a.input} (profile {PROFILES[a.input]}), {'all' if a.scans is None else a.scans} scans\n")
    print(f"| variant | published RMSE (m) | first half | second half | max (m) | GPS-aligned RMSE (m) | landmarks | "
          f"NIS inside 95% band | 2-sigma bound holds | ms/scan | > {LIMIT:g}x profile |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        worse = "" if base is None else ("yes" if r["published_rmse_m"] > LIMIT * base else "no")
        print(f"| {r['variant']} | {r['published_rmse_m']:.2f} | {r['first_half_rmse_m']:.2f} | "
              f"{r['second_half_rmse_m']:.2f} | {r['published_max_m']:.1f} | {r['aligned_rmse_m']:.2f} | "
              f"{r['landmarks']} | {r['nis_inside']:.3f} | {r['inside_2sigma']:.3f} | {r['ms_per_scan']:.1f} | {worse} |")
    if base is not None:
        worst = max(rows, key=lambda r: r["published_rmse_m"])
        print(f"\nworst row: {worst['variant']}, {worst['published_rmse_m']:.2f} m = "
              f"{worst['published_rmse_m'] / base:.2f}x the profile's {base:.2f} m")
    if a.json:
        a.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()
