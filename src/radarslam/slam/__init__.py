"""EKF-SLAM: pure functions on ``(x, P)`` (:mod:`.ekf`) and the orchestrator (:mod:`.filter`)."""

from radarslam.slam.filter import EkfSlam, MapSnapshot, ScanReport

__all__ = ["EkfSlam", "MapSnapshot", "ScanReport"]
