"""Where the consistent variant's NEES excess sits: the position (2 dof) and heading (1 dof) parts.

    python scripts/nees_decomposition.py --trials 100 --seed 777

Runs the variants of ``scripts/nees_study.py`` (fixed, drawn, drawn + FEJ) trial by trial in this
process (the Monte Carlo store keeps the 3-dof NEES only, not the pose covariances) and prints, per
variant, the average over trials of the position NEES e_t^T P_tt^-1 e_t (consistent: 2) and of the
heading NEES e_theta^2 / P_theta_theta (consistent: 1) over k <= 15, k >= 56 and all scans, and the
fraction of scans inside each one's two-sided 95% band of the average of N trials. Training seeds
only (seed 1 refused).
"""

from __future__ import annotations

import argparse
import sys

import nees_study
import numpy as np
from scipy import stats

from radarslam.config import profile_config
from radarslam.core.angles import wrap_pi
from radarslam.montecarlo.trials import trial_seed, variant_config
from radarslam.slam.driver import run_filter
from radarslam.simulation.trial import with_initial_estimate
from radarslam.simulation.scenario import generate_scenario


def decompose(n: int, seed: int, profile: str = "apsipa") -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """``{variant: (position NEES (K,), heading NEES (K,))}``, each averaged over ``n`` trials."""
    cfg = profile_config(profile)
    out: dict[str, tuple[list, list]] = {v.name: ([], []) for v in nees_study.study_variants()}
    for t in range(1, n + 1):
        ss = trial_seed(seed, t)
        sc = generate_scenario(cfg, np.random.default_rng(ss))
        for v in nees_study.study_variants():
            rec = run_filter(with_initial_estimate(variant_config(cfg, v), sc, ss), sc.events)
            e = rec.poses - sc.truth.poses
            e[:, 2] = wrap_pi(e[:, 2])
            P = rec.pose_covs
            out[v.name][0].append(np.einsum("ki,kij,kj->k", e[:, :2], np.linalg.inv(P[:, :2, :2]), e[:, :2]))
            out[v.name][1].append(e[:, 2] ** 2 / P[:, 2, 2])
    return {k: (np.mean(p, axis=0), np.mean(h, axis=0)) for k, (p, h) in out.items()}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--trials", type=int, default=100)
    p.add_argument("--seed", type=int, default=777)
    a = p.parse_args(argv)
    if a.seed == 1:
        print("nees_decomposition: --seed 1 is the reporting seed; use a training seed", file=sys.stderr)
        return 2
    late = nees_study.LATE_FROM - 1
    print(f"{a.trials} trials, seed {a.seed}: average NEES k<=15 / k>={late + 1} / all, inside its 95% band")
    for name, (pos, head) in decompose(a.trials, a.seed).items():
        cells = []
        for what, x, dof in (("position (2)", pos, 2), ("heading (1)", head, 1)):
            lo, hi = stats.chi2.ppf([0.025, 0.975], dof * a.trials) / a.trials
            cells.append(f"{what} {x[:15].mean():.2f} / {x[late:].mean():.2f} / {x.mean():.2f}, "
                         f"inside {100 * np.mean((x >= lo) & (x <= hi)):.0f}% above {100 * np.mean(x > hi):.0f}%")
        print(f"{name}: " + "; ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
