"""Choosing the partial-view model's parameters on training seeds (docs/method.md a.12.5, a.12.7).

    python scripts/partial_view_sweep.py --seed 777 --trials 60 --out runs/pv-sweep-777

Simulates the car park under ``--spread-model`` (visible-faces by default) and runs, on the same
data, the consistent pipeline under the partial view with each parameter of a small grid changed
on its own around the defaults (``extent.view_model_error_m``, ``view_spread_rel_error``,
``view_prior_std``, ``view_prior_radius_m``; the first rounds, before that key existed, varied ``prior_extent_radius_m``, which then set the same prior), and the full view as the reference. Prints the
ablation table (position, heading, NEES, NIS). Refuses the reporting seed 1: the values shipped in
``config/sections.py`` were chosen from this script's output on seeds 777 and 778.
"""

from __future__ import annotations

import argparse
import copy
import sys

from _montecarlo_table import run_under_spread_model

from radarslam.config.variants import CONSISTENT, Variant

GRID = {
    "view_model_error_m": (0.3, 0.7),
    "view_spread_rel_error": (0.15, 0.6),
    "view_prior_std": (0.5, 1.5),
    "view_prior_radius_m": (1.25, 1.5, 2.0, 2.5),
    "view_shape_data": ("spread",),
}
#: Pairs changed together (the second round, after the first showed r0 and the shape data matter most).
WALK = (0.05, 0.1, 0.2, 0.4)
PAIRS = [{"view_prior_radius_m": r, "view_shape_data": d, "view_model_error_m": q}
         for r in (1.0, 1.25) for d in ("mean-spread", "spread") for q in (0.2, 0.3)]


def sweep_variants(grid: bool = True, pairs: bool = True) -> list[Variant]:
    def cons(name, label, **extent):
        ov = copy.deepcopy(CONSISTENT.overlay)
        ov["extent"].update(extent)
        return Variant(name, label, ov)
    out = [cons("full", "consistent, full view", view_model="full"),
           cons("partial", "consistent, partial view (defaults)", view_model="partial")]
    for key, values in (GRID.items() if grid and pairs else ()):
        for v in values:
            out.append(cons(f"{key.replace('_', '-')}-{v}".replace(".", "p"), f"partial, {key} = {v}",
                            view_model="partial", **{key: v}))
    for i, pair in enumerate(PAIRS if pairs and grid is not None else ()):
        out.append(cons(f"pair-{i}", "partial, " + ", ".join(f"{k} = {v}" for k, v in pair.items()),
                        view_model="partial", **pair))
    return out


def walk_variants() -> list[Variant]:
    base = sweep_variants(True, False)
    return base + [Variant(f"walk-{str(q).replace('.', 'p')}", f"partial, view_walk_m2_per_rad = {q}",
                           {**base[1].overlay, "extent": {**base[1].overlay["extent"], "view_walk_m2_per_rad": q}})
                   for q in WALK]


def uncertainty_variants() -> list[Variant]:
    base = sweep_variants(True, False)
    ext = base[1].overlay["extent"]
    return base + [Variant(f"shape-unc-{str(q).replace('.', 'p')}",
                           f"partial, view_shape_uncertainty, view_model_error_m = {q}",
                           {**base[1].overlay, "extent": {**ext, "view_shape_uncertainty": True, "view_model_error_m": q}})
                   for q in (0.2, 0.3)]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=60)
    p.add_argument("--seed", type=int, default=777)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--spread-model", default="visible-faces")
    p.add_argument("--out", default="runs/pv-sweep")
    p.add_argument("--pairs-only", action="store_true", help="the second round only (PAIRS)")
    p.add_argument("--defaults-only", action="store_true", help="the full view and the shipped defaults only")
    p.add_argument("--walk", action="store_true", help="the view random walk q_w (WALK) around the defaults")
    p.add_argument("--shape-uncertainty", action="store_true",
                   help="extent.view_shape_uncertainty on, with the model error at 0.2 and 0.3 m")
    a = p.parse_args(argv)
    if a.seed == 1:
        print("partial_view_sweep: --seed 1 is the reporting seed; choose parameters on other seeds", file=sys.stderr)
        return 2
    if a.shape_uncertainty:
        variants = uncertainty_variants()
    else:
        variants = walk_variants() if a.walk else sweep_variants(not a.pairs_only, not a.defaults_only)
    run_under_spread_model(variants, a.spread_model, a.seed, a.trials, a.out, a.jobs, "sweep")
    return 0


if __name__ == "__main__":
    sys.exit(main())
