"""The compiled associators (``filter.backend = "numba"``): each wraps one njit scan of
:mod:`radarslam.slam._numba` (score the candidates, then update) behind the
:class:`~radarslam.slam.association.Associator` protocol, and the factories
``core.registry.BUILT_INS`` names."""

from __future__ import annotations

import numpy as np

from radarslam.slam._numba import (associate_scan, batch_associate_scan, joint_batch_associate_scan,
                                   min_log_distance)
from radarslam.slam.association import Spreads
from radarslam.slam.state import SlamState

__all__ = ["CompiledBatchAssociator", "CompiledJointBatchAssociator", "CompiledNearestNeighbourAssociator",
           "make_batch", "make_batch_joint", "make_nearest_neighbour"]


class _CompiledAssociator:
    """A compiled associator: ``scan`` is the njit function ``(x, P, polar, cand, R, gX, has_gX,
    n_nearest, beta, platform, xlin) -> (x, P, out, nis)`` that does the work."""

    name = ""
    backend = "numba"
    #: Evaluates its Jacobians at the first estimates when ``state.lin_pose`` is set (c.2.1).
    fej = True
    batch = False   #: fuses a landmark's detections into their mean (a.7.3), taking ``Spreads.offset_k`` (c.17)

    def __init__(self, beta: float, n_nearest: int, n_nearest_new: int):
        self.beta = float(beta)
        self.n_nearest = int(n_nearest)
        self.n_nearest_new = int(n_nearest_new)

    @staticmethod
    def scan(x, P, polar, cand, R, gX, has_gX, n_nearest, beta, platform, xlin):  # pragma: no cover - abstract
        raise NotImplementedError

    def associate(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
                  spreads: Spreads) -> tuple[np.ndarray, np.ndarray]:
        if not state.n_landmarks:
            return np.full(candidates.shape[0], -1, dtype=int), np.empty(0)
        args = (state.x, state.P, polar, candidates.astype(np.int64), R, spreads.gX, spreads.has, self.n_nearest,
                self.beta, state.platform_dim, state.linearisation_all())
        x, P, out, nis = self.scan(*args, float(spreads.offset_k)) if self.batch else self.scan(*args)
        state.set(x, P)
        return out, nis

    def min_log_distance(self, state: SlamState, s: np.ndarray, R: np.ndarray) -> float:
        return float(min_log_distance(state.x, state.P, float(s[0]), float(s[1]), self.n_nearest_new, R,
                                      state.platform_dim))


class CompiledNearestNeighbourAssociator(_CompiledAssociator):
    """:class:`~radarslam.slam.association.NearestNeighbourAssociator`, compiled."""

    name = "nearest-neighbour"
    scan = staticmethod(associate_scan)


class CompiledBatchAssociator(_CompiledAssociator):
    """:class:`~radarslam.slam.association.BatchAssociator`, compiled."""

    name = "batch"
    batch = True
    scan = staticmethod(batch_associate_scan)


class CompiledJointBatchAssociator(_CompiledAssociator):
    """:class:`~radarslam.slam.association.JointBatchAssociator`, compiled."""

    name = "batch-joint"
    batch = True
    scan = staticmethod(joint_batch_associate_scan)


def _factory(cls):
    def make(config):
        """From the ``landmarks`` section: ``beta``, ``n_nearest_assoc``, ``n_nearest_new``."""
        lc = config.landmarks
        return cls(lc.beta, lc.n_nearest_assoc, lc.n_nearest_new)
    return make


# The factories core.registry.BUILT_INS names (filter.backend "numba").
make_nearest_neighbour = _factory(CompiledNearestNeighbourAssociator)
make_batch = _factory(CompiledBatchAssociator)
make_batch_joint = _factory(CompiledJointBatchAssociator)
