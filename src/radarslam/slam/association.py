"""Data association components (docs/method.md c.4, c.6; docs/architecture.md "Associator").

An associator takes the scan's candidate detections (those that passed sifting), decides which
landmark each belongs to and applies the EKF updates to the state; it also answers the alpha
test's question "how far, in log distance, is this detection from the map?". The default is the
paper's sequential nearest-neighbour scheme: each candidate in scan order is scored against its
``N_s`` Euclidean-nearest landmarks by the log distance of APSIPA eq. (9) and, when the smallest
is below ``beta``, updates the state at once (the next candidate sees the updated state).

Each scheme is one kernel of :mod:`._numba` (score the candidates, then update), the one the fused
engine's step 4 calls. An associator object runs it compiled (``backend = "numba"``, the default) or
the same code in the interpreter (``"python"``, the reference: :func:`radarslam.core.jit.uncompiled`).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from radarslam.core.errors import InputError
from radarslam.slam._numba import associate_scan, batch_associate_scan, joint_batch_associate_scan, min_log_distance
from radarslam.slam.state import SlamState

__all__ = ["Associator", "BatchAssociator", "CompiledBatchAssociator", "CompiledJointBatchAssociator",
           "CompiledNearestNeighbourAssociator", "JointBatchAssociator", "NearestNeighbourAssociator", "Spreads",
           "kernel_form", "make_batch", "make_batch_joint", "make_nearest_neighbour"]


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


@functools.cache
def _python_form(kernel):
    from radarslam.core.jit import uncompiled

    return uncompiled(kernel)


def kernel_form(kernel, backend: str):
    """``kernel`` (a numba dispatcher) as ``backend`` runs it: itself for ``"numba"``, its code in the
    interpreter for ``"python"`` (:func:`~radarslam.core.jit.uncompiled`, built once per kernel)."""
    return kernel if backend == "numba" else _python_form(kernel)


class NearestNeighbourAssociator:
    """Sequential nearest-neighbour association by the log distance (APSIPA eq. 9): the kernel
    :func:`~radarslam.slam._numba.associate_scan`, the alpha test
    :func:`~radarslam.slam._numba.min_log_distance`.

    Parameters
    ----------
    beta : float
        Association threshold on the log distance.
    n_nearest : int
        ``N_s``: landmarks scored per detection.
    n_nearest_new : int
        ``N_a``: landmarks scored by the alpha test.
    backend : {"python", "numba"}
        How the kernels run (module docstring); the class's own by default.
    """

    name = "nearest-neighbour"
    backend = "python"
    #: Evaluates its Jacobians at ``state.linearisation(j)`` (first-estimates Jacobians, c.2.1).
    fej = True
    #: Fuses a landmark's detections into their mean (a.7.3), taking ``Spreads.offset_k`` (c.17).
    batch = False
    kernel = staticmethod(associate_scan)

    def __init__(self, beta: float, n_nearest: int, n_nearest_new: int, backend: str | None = None):
        self.beta = float(beta)
        self.n_nearest = int(n_nearest)
        self.n_nearest_new = int(n_nearest_new)
        if backend is not None:
            if backend not in ("python", "numba"):
                raise InputError(f"backend: expected 'python' or 'numba', got {backend!r}")
            self.backend = backend

    def associate(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
                  spreads: Spreads) -> tuple[np.ndarray, np.ndarray]:
        if not state.n_landmarks:
            return np.full(candidates.shape[0], -1, dtype=int), np.empty(0)
        args = (state.x, state.P, polar, candidates.astype(np.int64), R, spreads.gX, spreads.has, self.n_nearest,
                self.beta, state.platform_dim, state.linearisation_all())
        scan = kernel_form(type(self).kernel, self.backend)
        x, P, out, nis = scan(*args, float(spreads.offset_k)) if self.batch else scan(*args)
        state.set(x, P)
        return out, nis

    def min_log_distance(self, state: SlamState, s: np.ndarray, R: np.ndarray) -> float:
        return float(kernel_form(min_log_distance, self.backend)(state.x, state.P, float(s[0]), float(s[1]),
                                                                 self.n_nearest_new, R, state.platform_dim))


class BatchAssociator(NearestNeighbourAssociator):
    """Per-landmark batch update (docs/method.md a.7.3; :func:`~radarslam.slam._numba.batch_associate_scan`):
    one EKF update per landmark per scan.

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
    batch = True
    kernel = staticmethod(batch_associate_scan)


class JointBatchAssociator(BatchAssociator):
    """The batch scheme with all landmarks of the scan in one update (docs/method.md a.7.4;
    :func:`~radarslam.slam._numba.joint_batch_associate_scan`).

    Scoring and grouping are :class:`BatchAssociator`'s; then the L landmarks' mean detections are
    stacked into one measurement of 2L rows, linearised at the state before the scan's updates,
    with the block-diagonal noise of :func:`~radarslam.slam.ekf.batch_noise`, and applied as one
    pass over the n x n covariance per scan instead of one per landmark. For a linear model this is
    the same update as the L sequential ones (tested); here it differs from them only by where each
    landmark's measurement is linearised (the sequential form relinearises after every landmark)."""

    name = "batch-joint"
    kernel = staticmethod(joint_batch_associate_scan)


class CompiledNearestNeighbourAssociator(NearestNeighbourAssociator):
    """:class:`NearestNeighbourAssociator`, its kernels compiled (``filter.backend = "numba"``)."""

    backend = "numba"


class CompiledBatchAssociator(BatchAssociator):
    """:class:`BatchAssociator`, its kernels compiled."""

    backend = "numba"


class CompiledJointBatchAssociator(JointBatchAssociator):
    """:class:`JointBatchAssociator`, its kernels compiled."""

    backend = "numba"


def _factory(cls):
    def make(config):
        """From the ``landmarks`` section: ``beta``, ``n_nearest_assoc``, ``n_nearest_new``."""
        lc = config.landmarks
        return cls(lc.beta, lc.n_nearest_assoc, lc.n_nearest_new)
    return make


# The factories core.registry.BUILT_INS names, per backend.
make_nearest_neighbour = _factory(NearestNeighbourAssociator)
make_batch = _factory(BatchAssociator)
make_batch_joint = _factory(JointBatchAssociator)
make_compiled_nearest_neighbour = _factory(CompiledNearestNeighbourAssociator)
make_compiled_batch = _factory(CompiledBatchAssociator)
make_compiled_batch_joint = _factory(CompiledJointBatchAssociator)
