"""Ablation of the consistent variant (docs/method.md a.7.3): each part switched off in turn.

    python scripts/ablation_consistent.py --trials 200 --seed 1 --jobs 2 --out runs/ablation

Prints, for "No extent", "With extent", the consistent variant and the consistent variant without
each of its parts: position / heading avg. RMSE with 95% bootstrap CIs, the fraction of scans whose
average pose NEES lies in its two-sided 95% chi-square band, the time-averaged NEES (3 for a
consistent filter) and the mean NIS of the updates (2 for a consistent filter).
"""

from __future__ import annotations

import copy
import sys

import _montecarlo_table
from _montecarlo_table import markdown, table  # noqa: F401  (the table, by its former home)

from radarslam.montecarlo.report import nees_summary
from radarslam.config.variants import CONSISTENT, DEFAULT_VARIANTS, Variant


def _without(name: str, label: str, section: str, key: str, value) -> Variant:
    overlay = copy.deepcopy(CONSISTENT.overlay)
    overlay.setdefault(section, {})[key] = value
    return Variant(name, label, overlay)


def ablation_variants() -> list[Variant]:
    return list(DEFAULT_VARIANTS) + [
        _without("no-pre-init-spread", "consistent without the pre-initialisation spread", "extent",
                 "pre_init_spread", "none"),
        _without("scatter-spread", "consistent, buffered scatter instead of the prior spread", "extent",
                 "pre_init_spread", "scatter"),
        _without("nearest-init", "consistent without the cluster-mean initialisation", "landmarks", "init", "nearest"),
        _without("sequential", "consistent without the batch update (sequential)", "landmarks", "associator",
                 "nearest-neighbour"),
    ]


def main(argv: list[str] | None = None) -> int:
    return _montecarlo_table.main(__doc__, ablation_variants(), table, lambda rows, res: markdown(rows, res['trials'].size, res['seed'], nees_summary(res)['band']), "ablation", trials=200, seed=1,
                                  out="runs/ablation", refuse_seed=None, argv=argv)


if __name__ == "__main__":
    sys.exit(main())
