"""Layout of the augmented state ``x = [x, y, theta, b_1 .. b_m, p1x, p1y, ..., pNx, pNy]`` (docs/method.md a.1, c.11).

The one place that knows where landmark ``j`` (0-based) lives in ``x`` and ``P``; everything else
(the pure EKF functions, the compiled kernels, :class:`~radarslam.slam.state.SlamState`) asks here.

The state opens with the *platform block*: the pose ``[x, y, theta]`` and, under
``filter.odometry_bias = "states"``, the motion model's ``m`` odometry-bias states (c.11). Its size
``platform = POSE_DIM + m`` is a property of the configuration that the state carries
(:attr:`~radarslam.slam.state.SlamState.platform_dim`); every function here takes it, defaulting to
the pose alone.
"""

from __future__ import annotations

#: Size of the platform pose block ``[x, y, theta]`` at the head of the state.
POSE_DIM = 3
#: Size of one landmark's block ``[px, py]``.
LANDMARK_DIM = 2


def landmark_index(j, platform=POSE_DIM):
    """First state index of landmark ``j`` after a platform block of ``platform`` entries:
    ``x[landmark_index(j) : landmark_index(j) + 2]``. A kernel (numba compiles it)."""
    return platform + LANDMARK_DIM * j


def n_landmarks(n_state, platform=POSE_DIM):
    """Number of landmarks in a state of ``n_state`` entries with a platform block of ``platform``."""
    return (n_state - platform) // LANDMARK_DIM
