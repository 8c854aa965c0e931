"""The seed papers' published values the report sets its results beside (docs/method.md f.1, f.2, f.4).

Each constant is keyed by the report's metric names; where a paper compares "No extent" and
"With extent" the keys are the names of :data:`~radarslam.config.variants.DEFAULT_VARIANTS`.
"""

from __future__ import annotations

#: Seed Table 1 (1000 runs), docs/method.md f.1: platform avg. RMSE without and with extents.
PAPER_TABLE1 = {"position_avg_rmse_m": {"noext": 1.21, "ext": 1.09},
                "heading_avg_rmse_deg": {"noext": 3.48, "ext": 3.24}}

#: Seed Fig. 3 read off the arXiv figure (+-0.01), docs/method.md f.2; k=20 is the 13-20 minimum/ramp.
#: RMSE of the average GWD (m) of the "With extent" run, ground-truth convention ``full`` (h.9).
PAPER_FIG3 = {"rma": {5: 2.32, 10: 2.28, 20: 2.26, 30: 2.35, 40: 2.345, 60: 2.49, 80: 2.50, 100: 2.53, 120: 2.52},
              "efa": {5: 2.345, 10: 2.45, 20: 2.57, 30: 2.66, 40: 2.69, 60: 2.92, 80: 2.93, 100: 2.96, 120: 2.97}}

#: APSIPA Table II (100 runs, landmark management only), docs/method.md f.4: (low clutter, high clutter).
PAPER_TABLE2 = {"position_avg_rmse_m": (0.81, 0.90), "heading_avg_rmse_deg": (3.26, 3.50),
                "landmark_mae_m": (1.23, 1.34), "mean_inclusion_delay": (2.45, 3.22),
                "mean_removal_delay": (10.85, 11.00), "mean_false": (0.13, 3.02), "max_false": (4, 7),
                "mean_missed": (0.2, 0.23), "max_missed": (4, 5)}

#: Where each constant comes from.
PAPER_SOURCES = {
    "PAPER_TABLE1": "seed paper, Table 1 (1000 Monte Carlo runs); docs/method.md f.1",
    "PAPER_FIG3": "seed paper, Fig. 3, read off the arXiv figure to +-0.01 m; docs/method.md f.2",
    "PAPER_TABLE2": "APSIPA paper, Table II (100 runs, low / high clutter); docs/method.md f.4",
}
