"""EKF-SLAM: pure functions on ``(x, P)`` (:mod:`.ekf`) , the fused engine (:mod:`.fused`) and the filter object over it (:mod:`.filter`)."""

from radarslam.slam.filter import EkfSlam, MapSnapshot, ScanReport

__all__ = ["EkfSlam", "MapSnapshot", "ScanReport"]
