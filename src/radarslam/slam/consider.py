"""The car's states considered, not estimated (docs/method.md c.13.4): a Schmidt-Kalman filter.

Under ``filter.car_states = "consider"`` every state of the platform block after the pose (the
odometry-bias states of c.11, the thrust angle of c.11.12, each radar's yaw and time offset of
c.13.1-c.13.2) keeps its prior mean and its own covariance block through every scan: the landmarks
never correct it (its rows of the gain are zero), while its uncertainty stays in the covariance of
the pose and of every landmark seen with it.

For an update whose Jacobian ``H`` has no column on the held states ``c`` (every update of a scan:
the landmarks' measurements are taken from the sensor's pose, into which c.13.1-c.13.2 moved the
offsets, and a merge's Jacobian is on landmarks only), the Joseph update with ``K_c = 0`` gives

    P_ss' = P_ss - K_s S K_s^T,   P_sc' = P_sc - K_s S K_c*^T,   P_cc' = P_cc,   x_c' = x_c,

with ``K_s`` and ``K_c* = P_cs H^T S^-1`` the optimal gain's rows, i.e. the optimal update's
``P_ss'`` and ``P_sc'``; and ``P_ss'``, ``P_sc'``, ``x_s'`` depend on ``P_cc`` and ``x_c`` only
through ``H``, which does not touch them. So a scan of ordinary updates followed by putting back the
held mean and block as they were before the scan (:func:`held`, :func:`restore`) is the
Schmidt-Kalman filter exactly, with no change to any update. Both are kernels, which the fused engine calls compiled (``slam/fused/sensor.py``).
"""

from __future__ import annotations

__all__ = ["held", "restore"]


def held(x, P, lo, hi):
    """Copies of the held states' mean ``x[lo:hi]`` and covariance block ``P[lo:hi, lo:hi]``
    (empty for ``lo == hi``: nothing held). A kernel."""
    return x[lo:hi].copy(), P[lo:hi, lo:hi].copy()


def restore(x, P, xc, Pcc, lo):
    """Put back (in place) the held mean ``xc`` and block ``Pcc`` from index ``lo`` (:func:`held`). A kernel."""
    hi = lo + xc.shape[0]
    x[lo:hi] = xc
    P[lo:hi, lo:hi] = Pcc
