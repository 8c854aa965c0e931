"""Layout of the augmented state ``x = [x, y, theta, p1x, p1y, ..., pNx, pNy]`` (docs/method.md a.1).

The one place that knows where landmark ``j`` (0-based) lives in ``x`` and ``P``; everything else
(the pure EKF functions, the compiled kernels, :class:`~radarslam.slam.state.SlamState`) asks here.
"""

from __future__ import annotations

#: Size of the platform pose block ``[x, y, theta]`` at the head of the state.
POSE_DIM = 3
#: Size of one landmark's block ``[px, py]``.
LANDMARK_DIM = 2


def landmark_index(j):
    """First state index of landmark ``j``: ``x[landmark_index(j) : landmark_index(j) + 2]``."""
    return POSE_DIM + LANDMARK_DIM * j


def n_landmarks(n_state):
    """Number of landmarks in a state of ``n_state`` entries."""
    return (n_state - POSE_DIM) // LANDMARK_DIM
