"""Angle wrapping."""

from __future__ import annotations

import math

import numpy as np

TWO_PI = 2.0 * math.pi


def wrap_pi(angle):
    """Wrap to ``(-pi, pi]``. Works on floats and arrays; idempotent."""
    a = np.mod(np.asarray(angle, dtype=np.float64) + math.pi, TWO_PI) - math.pi
    # np.mod maps +pi to -pi; the convention here is the half-open (-pi, pi].
    a = np.where(a <= -math.pi, a + TWO_PI, a)
    return float(a) if np.ndim(a) == 0 else a


def wrap_pi_scalar(a: float) -> float:
    """Scalar :func:`wrap_pi` for the inner loops (no array round trip). A kernel: numba compiles it."""
    a = math.fmod(a + math.pi, TWO_PI)
    if a <= 0.0:
        a += TWO_PI
    return a - math.pi


def wrap_2pi_scalar(a: float) -> float:
    """Wrap to ``[0, 2 pi)``, the heading convention of the state (docs/method.md a.1).

    A kernel: numba compiles it as it is (:mod:`radarslam.slam._numba`)."""
    a = math.fmod(a, TWO_PI)
    if a < 0.0:
        a += TWO_PI
    return 0.0 if a >= TWO_PI else a
