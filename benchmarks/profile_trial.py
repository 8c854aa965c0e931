"""cProfile of complete trials: where the time goes."""

import argparse
import cProfile
import pstats

import _common  # noqa: F401

from radarslam.config import profile_config
from radarslam.montecarlo.trials import compute_trial


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--trials", type=int, default=5)
    ap.add_argument("--top", type=int, default=20)
    a = ap.parse_args()
    cfg = profile_config()
    compute_trial(cfg, 1, 1)
    prof = cProfile.Profile()
    prof.enable()
    for t in range(1, a.trials + 1):
        compute_trial(cfg, 1, t)
    prof.disable()
    pstats.Stats(prof).sort_stats("tottime").print_stats(a.top)


if __name__ == "__main__":
    main()
