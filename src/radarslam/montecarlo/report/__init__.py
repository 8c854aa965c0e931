"""The Monte Carlo report: seed Table 1, seed Fig. 3, APSIPA Table II and pose NEES (docs/method.md f),
for every variant of the run.

- :mod:`.paper`   the papers' published values and their sources
- :mod:`.tables`  the tables as dicts (pure computation on :func:`~..montecarlo.load_results`)
- :mod:`.render`  their Markdown and CSV text
- :mod:`.write`   :func:`write_report`, the only part that touches files (figures from
  :mod:`radarslam.viz.report` when matplotlib is installed)

The trial bootstrap and the RMSE over defined values are generic statistics of
:mod:`radarslam.metrics.statistics`, re-exported here for existing callers.
"""

from radarslam.montecarlo.report.paper import PAPER_FIG3, PAPER_SOURCES, PAPER_TABLE1, PAPER_TABLE2
from radarslam.montecarlo.report.render import (gwd_csv, gwd_markdown, nees_csv, nees_markdown, nis_csv, nis_markdown,
                                                 report_markdown,
                                                 table1_csv, table1_markdown, table2_csv, table2_markdown,
                                                 trial_ranges, variants_markdown)
from radarslam.montecarlo.report.tables import (ESTIMATORS, GWD_KEY_STEPS, GWD_SETTLED_FROM, REPORT_CONVENTIONS,
                                                 TABLE1_METRICS, gwd_curves, landmark_table, nees_summary, nis_summary,
                                                 table1,
                                                 variant_labels)
from radarslam.montecarlo.report.write import FIG2_VARIANT, write_report
from radarslam.metrics.statistics import bootstrap_avg_rmse, bootstrap_counts, percentile_interval, rmse_over_defined

__all__ = [
    "ESTIMATORS", "FIG2_VARIANT", "GWD_KEY_STEPS", "GWD_SETTLED_FROM", "PAPER_FIG3", "PAPER_SOURCES", "PAPER_TABLE1",
    "PAPER_TABLE2", "REPORT_CONVENTIONS", "TABLE1_METRICS", "bootstrap_avg_rmse", "bootstrap_counts", "gwd_csv",
    "gwd_curves", "gwd_markdown", "landmark_table", "nees_csv", "nees_markdown", "nees_summary", "nis_csv", "nis_markdown", "nis_summary",
    "percentile_interval", "report_markdown", "rmse_over_defined", "table1", "table1_csv", "table1_markdown",
    "table2_csv", "table2_markdown", "trial_ranges", "variant_labels", "variants_markdown", "write_report",
]
