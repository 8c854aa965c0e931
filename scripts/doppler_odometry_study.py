"""Odometry from Doppler and a gyro (docs/method.md c.10.5): odometer vs doppler vs both.

    python scripts/doppler_odometry_study.py --trials 50 --seed 777 --jobs 1 --out runs/doppler_odometry

The car park is simulated with ``radar.doppler = true`` in the base configuration (the Doppler
channel and the gyro of c.10.5; every variant runs on the same data), and "No extent" and the
consistent variant each run with ``filter.odometry`` odometer, doppler and both. Prints position /
heading avg. RMSE with 95% bootstrap CIs, NEES and NIS (the table of ``ablation_consistent.py``).
Seed 777 is a training seed; the reporting seed 1 is refused without ``--report``.
"""

from __future__ import annotations

import argparse
import copy
import sys
from dataclasses import replace


from _montecarlo_table import run_ablation_table

from radarslam.config import profile_config
from radarslam.experiments.variants import CONSISTENT, PAPER_VARIANTS, Variant

MODES = ("odometer", "doppler", "both")


def study_variants() -> list[Variant]:
    """"No extent" and the consistent variant, each under the three ``filter.odometry`` settings."""
    out = []
    for base in (PAPER_VARIANTS[0], CONSISTENT):
        for mode in MODES:
            overlay = copy.deepcopy(base.overlay)
            overlay.setdefault("filter", {})["odometry"] = mode
            out.append(Variant(f"{base.name}-{mode}", f"{base.label}, odometry {mode}", overlay))
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=50)
    p.add_argument("--seed", type=int, default=777)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--profile", default="apsipa")
    p.add_argument("--out", default="runs/doppler_odometry")
    p.add_argument("--report", action="store_true",
                   help="the final run on the reporting seed 1, every parameter fixed on training seeds")
    a = p.parse_args(argv)
    if a.seed == 1 and not a.report:
        print("doppler_odometry_study: --seed 1 is the reporting seed; study on training seeds "
              "(--report for the final run, parameters fixed)", file=sys.stderr)
        return 2
    cfg = profile_config(a.profile)
    cfg = replace(cfg, radar=replace(cfg.radar, doppler=True))
    run_ablation_table(cfg, study_variants(), a.seed, a.trials, a.out, a.jobs, "doppler_odometry",
                       "Doppler and gyro odometry (c.10.5)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
