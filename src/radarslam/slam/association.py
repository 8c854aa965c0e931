"""Data association components (docs/method.md c.4, c.6; docs/architecture.md "Associator").

An associator takes the scan's candidate detections (those that passed sifting), decides which
landmark each belongs to and applies the EKF updates to the state; it also answers the alpha
test's question "how far, in log distance, is this detection from the map?". The default is the
paper's sequential nearest-neighbour scheme: each candidate in scan order is scored against its
``N_s`` Euclidean-nearest landmarks by the log distance of APSIPA eq. (9) and, when the smallest
is below ``beta``, updates the state at once (the next candidate sees the updated state).

Two implementations of the same scheme are registered under ``"nearest-neighbour"``: this module's
(``filter.backend = "python"``, the reference) and the compiled one of :mod:`._numba`
(``"numba"``). Both run the kernels of :mod:`.ekf`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from radarslam.slam import ekf
from radarslam.slam.layout import POSE_DIM
from radarslam.slam.state import SlamState



@dataclass(frozen=True)
class Spreads:
    """What the extent contributes to the measurement noise (docs/method.md a.7.2).

    ``gX[j]`` is landmark ``j``'s ``gamma_z X_j`` where ``has[j]``; ``R_eff = R + H_p gX_j H_p^T``.
    """

    gX: np.ndarray  # (N, 2, 2)
    has: np.ndarray  # (N,) bool
    #: Under the partial view (docs/method.md a.12): every landmark's shape X (N, 2, 2) for the
    #: visible-arc model, and the model-error covariance Q_v (2, 2) of a landmark's mean detection.
    shapes: np.ndarray | None = None
    model_error: np.ndarray | None = None
    #: With extent.view_shape_uncertainty: every landmark's log-matrix shape (N, 3) and its
    #: covariance (N, 3, 3), whose effect on the predicted mean joins the model error (a.12.5).
    log_shapes: np.ndarray | None = None
    shape_covs: np.ndarray | None = None
    #: The part in view's offset (docs/method.md c.17): the batch associators add ``offset_k gX_j``
    #: to a landmark's mean detection's noise, undivided by the number of detections (0: none).
    offset_k: float = 0.0

    @classmethod
    def none(cls, n: int) -> "Spreads":
        return cls(np.zeros((n, 2, 2)), np.zeros(n, dtype=np.bool_))


class Associator(Protocol):
    """What the filter needs from an associator of the user's own (slam/fused/own.py)."""

    def associate(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
                  spreads: Spreads) -> tuple[np.ndarray, np.ndarray]:
        """Associate ``polar[candidates]`` and update ``state`` (in place, or through ``state.set``).

        Returns the landmark position ``j`` of each candidate, ``-1`` where none (shape
        ``candidates.shape``), and the normalised innovation squared of every update applied
        (2 degrees of freedom each).
        """

    def min_log_distance(self, state: SlamState, s: np.ndarray, R: np.ndarray) -> float:
        """The smallest log distance of detection ``s = [r, phi]`` to the map (the alpha test of
        c.6, with the plain ``R``); ``inf`` without landmarks."""


def nearest_landmarks(xs: list[float], s, count: int, platform: int = POSE_DIM) -> list[int]:
    """Positions of the ``count`` landmarks Euclidean-nearest to detection ``s`` seen from the pose
    of ``xs`` (the state as a list, its platform block of ``platform`` entries), nearest first,
    ties by position."""
    a = xs[2] + s[1]
    zx, zy = xs[0] + s[0] * math.cos(a), xs[1] + s[0] * math.sin(a)
    d2 = [(lx - zx) ** 2 + (ly - zy) ** 2 for lx, ly in zip(xs[platform::2], xs[platform + 1::2])]
    return sorted(range(len(d2)), key=d2.__getitem__)[:count]


class NearestNeighbourAssociator:
    """Sequential nearest-neighbour association by the log distance (APSIPA eq. 9), Python.

    Parameters
    ----------
    beta : float
        Association threshold on the log distance.
    n_nearest : int
        ``N_s``: landmarks scored per detection.
    n_nearest_new : int
        ``N_a``: landmarks scored by the alpha test.
    """

    name = "nearest-neighbour"
    backend = "python"
    #: Evaluates its Jacobians at ``state.linearisation(j)`` (first-estimates Jacobians, c.2.1).
    fej = True

    def __init__(self, beta: float, n_nearest: int, n_nearest_new: int):
        self.beta = float(beta)
        self.n_nearest = int(n_nearest)
        self.n_nearest_new = int(n_nearest_new)

    def best_match(self, state: SlamState, s: np.ndarray, count: int, R: np.ndarray,
                   spreads: Spreads | None = None):
        """The landmark of smallest log distance among the ``count`` nearest, with its update terms.

        Returns ``(j, D, e, Hs, idx, R_j)``; ``j = -1`` and ``D = inf`` without landmarks.
        """
        if not state.n_landmarks:
            return (-1, math.inf, None, None, None, None)
        xs, p = state.x.tolist(), state.platform_dim
        js = nearest_landmarks(xs, s, count, p)
        gX = None
        if spreads is not None and spreads.has.any():
            gX = [spreads.gX[j].tolist() if spreads.has[j] else None for j in js]
        j, D, e = ekf.score_landmarks(state.x, state.P, s, js, R, gX, xs, p)
        if j < 0:
            return (-1, math.inf, None, None, None, None)
        Hs, idx = ekf.sparse_jacobian(state.linearisation(j), j, p)   # first estimates under FEJ (c.2.1)
        Rj = ekf.r_eff(R, Hs, spreads.gX[j]) if spreads is not None and spreads.has[j] else R
        return (j, D, np.array(e), Hs, idx, Rj)

    def associate(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
                  spreads: Spreads) -> tuple[np.ndarray, np.ndarray]:
        out = np.full(candidates.shape[0], -1, dtype=int)
        nis = []
        for c, i in enumerate(candidates.tolist()):
            j, D, e, Hs, idx, Rj = self.best_match(state, polar[i], self.n_nearest, R, spreads)
            if j >= 0 and D < self.beta:
                q = ekf.joseph_update_inplace(state.x, state.P, e, Hs, idx, Rj)
                nis.append(q)
                out[c] = j
        return out, np.array(nis)

    def min_log_distance(self, state: SlamState, s: np.ndarray, R: np.ndarray) -> float:
        return self.best_match(state, s, self.n_nearest_new, R)[1]


class BatchAssociator(NearestNeighbourAssociator):
    """Per-landmark batch update (docs/method.md a.7.3): one EKF update per landmark per scan.

    Every candidate is scored against its ``N_s`` nearest landmarks by the log distance of APSIPA
    eq. (9) at the state before the scan's updates (with ``R_eff``), exactly as the sequential
    scheme would score it first. The detections of each landmark are then fused into their mean in
    the sensor's Cartesian frame, ``zbar = mean_i (r_i cos phi_i, r_i sin phi_i)``, whose covariance
    about the predicted centroid is ``(Rot(-theta) gamma_z X Rot(-theta)^T + mean_i J_i R J_i^T) / m``
    (the detections scatter independently about the centroid with the extent's spread plus the
    sensor's noise), and one Joseph update with ``h = Rot(-theta) (p - t)`` is applied per
    landmark, landmarks in order. For m detections of a linear model this is the same update as m
    sequential ones (tested); it costs one n x n update per landmark instead of one per detection.
    """

    name = "batch"

    def scores(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
               spreads: Spreads) -> np.ndarray:
        """The landmark of each candidate (-1 for none), all scored at the current state."""
        out = np.full(candidates.shape[0], -1, dtype=int)
        for c, i in enumerate(candidates.tolist()):
            j, D = self.best_match(state, polar[i], self.n_nearest, R, spreads)[:2]
            if j >= 0 and D < self.beta:
                out[c] = j
        return out

    def associate(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
                  spreads: Spreads) -> tuple[np.ndarray, np.ndarray]:
        out = self.scores(state, polar, candidates, R, spreads)
        nis = []
        for j in np.unique(out[out >= 0]).tolist():
            dets = candidates[out == j]
            pts, R_xy = ekf.polar_to_sensor_xy(polar[dets], R)
            noise = ekf.batch_noise(state.x[2], spreads.gX[j], spreads.has[j], R_xy, dets.size, spreads.offset_k)
            h, Hs, idx = ekf.sensor_xy_measurement(state.x, j, state.platform_dim)
            if state.lin_pose is not None:        # first-estimates Jacobian (c.2.1), h at the estimate
                Hs = ekf.sensor_xy_measurement(state.linearisation(j), j, state.platform_dim)[1]
            q = ekf.joseph_update_inplace(state.x, state.P, pts.mean(axis=0) - h, Hs, idx, noise)
            nis.append(q)
        return out, np.array(nis)


class JointBatchAssociator(BatchAssociator):
    """The batch scheme with all landmarks of the scan in one update (docs/method.md a.7.4).

    Scoring and grouping are :class:`BatchAssociator`'s; then the L landmarks' mean detections are
    stacked into one measurement of 2L rows, linearised at the state before the scan's updates,
    with the block-diagonal noise of :func:`~radarslam.slam.ekf.batch_noise`, and applied by
    :func:`~radarslam.slam.ekf.joint_update_inplace`: one pass over the n x n covariance per scan
    instead of one per landmark. For a linear model this is the same update as the L sequential
    ones (tested); here it differs from them only by where each landmark's measurement is
    linearised (the sequential form relinearises after every landmark)."""

    name = "batch-joint"

    def associate(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
                  spreads: Spreads) -> tuple[np.ndarray, np.ndarray]:
        out = self.scores(state, polar, candidates, R, spreads)
        seen = np.unique(out[out >= 0]).tolist()
        if not seen:
            return out, np.empty(0)
        n = state.x.shape[0]
        e, H, Rb = np.empty(2 * len(seen)), np.zeros((2 * len(seen), n)), np.zeros((2 * len(seen), 2 * len(seen)))
        for a, j in enumerate(seen):
            dets = candidates[out == j]
            pts, R_xy = ekf.polar_to_sensor_xy(polar[dets], R)
            h, Hs, idx = ekf.sensor_xy_measurement(state.x, j, state.platform_dim)
            if state.lin_pose is not None:        # first-estimates Jacobian (c.2.1)
                Hs = ekf.sensor_xy_measurement(state.linearisation(j), j, state.platform_dim)[1]
            e[2 * a:2 * a + 2] = pts.mean(axis=0) - h
            H[2 * a:2 * a + 2, idx] = Hs
            Rb[2 * a:2 * a + 2, 2 * a:2 * a + 2] = ekf.batch_noise(state.x[2], spreads.gX[j], spreads.has[j], R_xy,
                                                                   dets.size, spreads.offset_k)
        return out, ekf.joint_update_inplace(state.x, state.P, e, H, Rb)


def _factory(cls):
    def make(config):
        """From the ``landmarks`` section: ``beta``, ``n_nearest_assoc``, ``n_nearest_new``."""
        lc = config.landmarks
        return cls(lc.beta, lc.n_nearest_assoc, lc.n_nearest_new)
    return make


# The factories core.registry.BUILT_INS names.
make_nearest_neighbour = _factory(NearestNeighbourAssociator)
make_batch = _factory(BatchAssociator)
make_batch_joint = _factory(JointBatchAssociator)
