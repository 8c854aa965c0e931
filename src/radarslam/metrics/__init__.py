"""Evaluation: pose errors and avg. RMSE, NEES, landmark-management metrics, extent metrics (GWD)."""
