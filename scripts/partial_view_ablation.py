"""Ablation of the partial-view model (docs/method.md a.12.5-a.12.8): each part switched off in turn.

    python scripts/partial_view_ablation.py --trials 200 --seed 1 --jobs 2 --out runs/pv-ablation

Under ``--spread-model`` (visible-faces by default) every trial runs, on the same data, the
consistent pipeline with the full view (the reference), with the whole partial-view model, and
with the partial-view model less one part: the estimated shape replaced by the RMA's or by the
prior circle (the arc model with a poorer shape), no view correction of a new landmark's centroid,
no model error ``Q_v``, the shape from the spread alone, and the extent-aware sifting replaced by
the radius test. Prints position / heading avg. RMSE with 95% intervals, the NEES and NIS
figures. No parameter is chosen here.
"""

from __future__ import annotations

import argparse
import copy
import sys

from _montecarlo_table import run_under_spread_model

from radarslam.config.variants import CONSISTENT, Variant

PARTS = (
    ("shape-rma", "partial view, the RMA's shape in the arc model", {"extent": {"view_shape": "rma"}}),
    ("shape-prior", "partial view, the prior circle in the arc model", {"extent": {"view_shape": "prior"}}),
    ("no-init-correct", "partial view, no view correction of new centroids", {"extent": {"view_init_correct": False}}),
    ("no-model-error", "partial view, no model error Q_v", {"extent": {"view_model_error_m": 0.0}}),
    ("spread-only", "partial view, shape from the spread alone", {"extent": {"view_shape_data": "spread"}}),
    ("radius-sifting", "partial view, radius sifting", {"extent": {"contour_sifting": False}}),
)


def ablation_variants() -> list[Variant]:
    def cons(name, label, extra):
        ov = copy.deepcopy(CONSISTENT.overlay)
        for section, values in extra.items():
            ov.setdefault(section, {}).update(values)
        return Variant(name, label, ov)
    out = [cons("full", "consistent, full view", {"extent": {"view_model": "full"}}),
           cons("partial", "consistent, partial view (all parts)", {"extent": {"view_model": "partial"}})]
    return out + [cons(name, label, {"extent": {"view_model": "partial", **extra["extent"]}})
                  for name, label, extra in PARTS]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--spread-model", default="visible-faces")
    p.add_argument("--out", default="runs/pv-ablation")
    a = p.parse_args(argv)
    run_under_spread_model(ablation_variants(), a.spread_model, a.seed, a.trials, a.out, a.jobs, "ablation")
    return 0


if __name__ == "__main__":
    sys.exit(main())
