"""EKF-SLAM: pure functions on ``(x, P)`` (:mod:`.ekf`) and the orchestrator (:mod:`.filter`)."""
