"""The rig's Doppler ego-motion against the car's own odometry (docs/method.md c.12.2-c.12.8): for
each recording given, the fit as a ``radarslam run --profile automotive`` writes it
(``egomotion.rig.checked_rig_velocity``: the model the rig's geometry observes) and the full model
``(v_x, v_y, omega)`` beside it, and for each the four figures of ``egomotion/ego_accuracy.py``:

1. the speed error RMS of the sweeps marked ok (m/s),
2. their yaw-rate error RMS (deg/s),
3. the share of them inside their own 95% ellipse of ``(v_x, omega)`` (with the band of that share at
   the sweeps' effective number, and the share of each component within 1.96 sd),
4. how many of them are off by more than 20 deg/s in yaw rate (and the largest error),

against the odometry at each sweep's stamp (as the run's ``metrics.json`` compares) and at the
radars' clock offset fitted on the other half of the drive (the reference's alignment, c.12.8).

    PYTHONPATH=src python benchmarks/rig_ego_accuracy.py ../shared/data/radarscenes/sequence_105 [...]
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import _common  # noqa: F401  (one BLAS thread)
import numpy as np

from radarslam.config import profile_config
from radarslam.egomotion.ego_accuracy import ego_accuracy
from radarslam.egomotion.rig import checked_rig_velocity, filter_series, read_rig


def measure(path: Path, profile: str = "automotive") -> dict:
    """The figures of both models on the recording at ``path`` (module docstring)."""
    t0 = time.perf_counter()
    rig = read_rig(path)
    if rig.odometry is None:
        raise SystemExit(f"{path}: no odometry.csv to compare with")
    t1 = time.perf_counter()
    series = checked_rig_velocity(rig, profile_config(profile).filter, np.random.default_rng(0),
                                  lateral=rig.sensor_ids.size >= 2)
    t2 = time.perf_counter()
    out = {"recording": str(path), "read_s": t1 - t0, "fit_s": t2 - t1,
           "model": getattr(series, "model", "v_x, omega (no sideslip: one radar)"),
           "yaw_rate_vif": getattr(series, "yaw_rate_vif", math.nan)}
    comp = getattr(series, "compliance", None)
    if comp is not None:
        out["cornering_compliance_deg_per_g"] = [math.degrees(c) * 9.80665 for c in comp]
    out["written"] = ego_accuracy(series, rig.odometry)
    if filter_series(series) is not series:
        out["full model"] = ego_accuracy(filter_series(series), rig.odometry)
    return out


def _line(name: str, f: dict) -> str:
    return (f"{name:26s} speed RMS {f['speed_rms_mps']:.4f} m/s | yaw rate RMS {f['yaw_rate_rms_deg_s']:.3f} deg/s "
            f"(mean {f['yaw_rate_mean_deg_s']:+.2f}) | in 95% ellipse {100 * f['within_95_ellipse']:.1f}% "
            f"(band at n_eff {f['n_eff']:.0f}: {100 * f['band_n_eff'][0]:.0f}-{100 * f['band_n_eff'][1]:.0f}%; "
            f"v_x {100 * f['vx_within_1.96_sd']:.1f}%, omega {100 * f['yaw_rate_within_1.96_sd']:.1f}% within "
            f"1.96 sd) | beyond 20 deg/s {f['beyond_20_deg_s']} (max {f['max_abs_yaw_rate_error_deg_s']:.2f})")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("recordings", nargs="+", type=Path, help="plain recording directories (sensors.csv, odometry.csv)")
    p.add_argument("--profile", default="automotive", help="the profile whose [filter] the fit takes")
    p.add_argument("--json", action="store_true", help="print every figure as JSON")
    a = p.parse_args(argv)
    for path in a.recordings:
        out = measure(path, a.profile)
        if a.json:
            json.dump(out, sys.stdout, indent=1, default=float)
            print()
            continue
        comp = out.get("cornering_compliance_deg_per_g")
        print(f"{path}: model {out['model']} (VIF of omega {out['yaw_rate_vif']:.1f}"
              + (f", rear cornering compliance {comp[0]:.2f} +- {comp[1]:.2f} deg/g" if comp else "")
              + f"); read {out['read_s']:.1f} s, fit {out['fit_s']:.1f} s")
        for name in ("full model", "written"):
            if name not in out:
                continue
            r = out[name]
            al = r["aligned"]
            print(f"  {name} ({r['ok_sweeps']} ok sweeps of {r['sweeps']}; reference noise "
                  f"{r['reference_noise']['speed_mps']:.4f} m/s, {r['reference_noise']['yaw_rate_deg_s']:.3f} deg/s)")
            print("    " + _line("as stamped", r["as_stamped"]))
            print("    " + _line(f"aligned ({1e3 * al['clock_offset_s'][0]:+.0f}/{1e3 * al['clock_offset_s'][1]:+.0f} ms)",
                              al))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
