"""The partial-view shape estimator (``extent.estimator = "partial-view"``; docs/method.md a.12.7).

Under a partial view the random-matrix update (seed eqs. 8-20) is biased: it reads the spread of
the detections about the centroid as the object's extent, while the detections of a car seen from
one side lie on that side only, off the centroid. This estimator explains each scan's detections
of a landmark by the visible-arc model of a.12 instead: with the landmark's centroid ``p`` from the
SLAM state, the sensor at ``t`` and a shape ``X``, the scan's sample mean ``zbar`` and sample
covariance ``C`` of its ``m`` detections have the expectations

    E[zbar - p] = g(t - p, X),        E[C] = S(t - p, X) + W_s,

where ``g`` and ``S`` are the visible arc's mean offset and source covariance (a.12.1-a.12.3) and
``W_s`` the sensor's own noise in the world frame (the pose's error is common to the scan's
detections and leaves ``C`` unchanged). As the sensor moves, the arc in view turns round the
object, and the offsets and spreads seen from several sides fix the shape.

The shape is the symmetric log-matrix ``A`` of ``X = expm(A)``, ``xi = (A11, A12, A22)``: every
``xi`` is a valid ellipse and a circle is a regular point, so the filter needs no constraint and
no orientation wrap. Each landmark carries ``xi`` and its covariance, born at the circular prior
``X0 = r0^2 I`` (``extent.view_prior_radius_m``) with ``extent.view_prior_std`` on each log
entry, and a small random walk per scan (``extent.view_process_std``). Each scan with detections
makes one iterated EKF update (Gauss-Newton on the posterior, ``VIEW_ITERATIONS`` steps) of the
measurement ``y = [zbar - p; vech C]`` with the noise

- mean: ``(S + W_s) / m + P_pp + Q_v`` (the centroid's covariance and the model error of a.12.5);
- spread: the Wishart covariance of a sample covariance with ``m - 1`` degrees of freedom about
  ``S + W_s``, plus a relative model error ``(extent.view_spread_rel_error * entry)^2`` (the outline
  is a rectangle's, not an ellipse's);

and the Jacobian analytic (a.12.9, :mod:`.partial_view_jac`) or, with ``extent.view_jacobian =
"central-difference"``, by central differences on ``xi`` (the kernels are smooth in ``X``). Scans
with fewer than 3 detections update with the mean alone.

The random-matrix and EFA estimates are kept underneath (this class extends
:class:`~.estimator.RmaEfaEstimator`): the RMA is the :meth:`baseline` the report compares with.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from radarslam.extent.estimator import RmaEfaEstimator, RmaEfaState

from radarslam.extent.view_kernels import (  # noqa: F401  (this module's kernels until they moved)
    FD_STEP, KERNELS, VIEW_ITERATIONS, arc_rows, exp_sym2, predicted_rows, put_arc_row, rows_and_jacobian,
    sift_spreads, view_rows, view_scan_data, view_update)

def log_matrix_to_X(xi: np.ndarray) -> np.ndarray:
    """``X = expm(A)`` of the symmetric ``A = [[xi0, xi1], [xi1, xi2]]``, ``(2, 2)`` (:func:`exp_sym2`)."""
    X11, X12, X22 = exp_sym2(float(xi[0]), float(xi[1]), float(xi[2]))
    return np.array([[X11, X12], [X12, X22]])


def X_to_log_matrix(X: np.ndarray) -> np.ndarray:
    """``xi`` of ``A = logm(X)`` for an SPD ``X``."""
    w, V = np.linalg.eigh(X)
    A = (V * np.log(np.maximum(w, 1e-12))) @ V.T
    return np.array([A[0, 0], A[0, 1], A[1, 1]])


@dataclass
class PartialViewState(RmaEfaState):
    """:class:`~.estimator.RmaEfaState` plus the log-matrix shape ``xi (3,)``, its covariance
    ``P_xi (3, 3)`` and the number of scans that updated it."""

    xi: np.ndarray = field(default_factory=lambda: np.zeros(3))
    P_xi: np.ndarray = field(default_factory=lambda: np.eye(3))
    n_view: int = 0

    @property
    def X_view(self) -> np.ndarray:
        return log_matrix_to_X(self.xi)


class PartialViewEstimator(RmaEfaEstimator):
    """Shapes from the visible arcs (module docstring); RMA/EFA underneath as the baseline."""

    name = "partial-view"
    baseline_name = "rma"
    #: A merge keeps the shape of the two updated by more scans (extent.rows.merge_rows).
    _merges_view = True

    def __init__(self, extent_config, R_extent: np.ndarray, backend: str = "python"):
        super().__init__(extent_config, R_extent, backend)
        ec = extent_config
        self.xi0 = X_to_log_matrix(ec.view_prior_radius_m ** 2 * np.eye(2))
        #: gamma_z X0 of the partial view's own prior shape (a.12.6), in place of the full view's.
        self.prior_spread = ec.spread_factor * ec.view_prior_radius_m ** 2 * np.eye(2)
        s = ec.view_prior_std
        self.P0 = np.diag([s * s, 0.5 * s * s, s * s])
        q = ec.view_process_std
        self.Q = np.diag([q * q, 0.5 * q * q, q * q])
        self.Qv = ec.view_model_error_m ** 2 * np.eye(2)
        self.rel = ec.view_spread_rel_error
        self.shape_mode = ec.view_shape
        self.spread_only = ec.view_shape_data == "spread"
        self.qv2 = ec.view_model_error_m ** 2
        #: Central-difference step of the shape's Jacobians, 0 for the analytic ones (a.12.9).
        self.shape_step = 0.0 if ec.view_jacobian == "analytic" else FD_STEP

    def new(self) -> PartialViewState:
        return PartialViewState(xi=self.xi0.copy(), P_xi=self.P0.copy())

    # ------------------------------------------------------------------ what SLAM asks
    def view_shape(self, st: PartialViewState) -> np.ndarray:
        """The shape the partial-view measurement uses (``extent.view_shape``): this estimator's,
        the RMA's (the prior before it exists) or the prior's (ablations, a.12.8)."""
        if self.shape_mode == "rma":
            return st.X if st.X is not None else log_matrix_to_X(self.xi0)
        if self.shape_mode == "prior":
            return log_matrix_to_X(self.xi0)
        return st.X_view

    def view_shapes(self, states: list[PartialViewState]) -> np.ndarray:
        """``(N, 2, 2)``: :meth:`view_shape` of every landmark."""
        return np.array([self.view_shape(s) for s in states]).reshape(-1, 2, 2)

    def view_shape_covs(self, states: list[PartialViewState]):
        """``(xi (N, 3), P_xi (N, 3, 3))`` of the shapes the arc model uses; None for the RMA's and
        the prior's (ablations), which are taken as given (the model error is then ``Q_v`` alone,
        as with zero covariances)."""
        if self.shape_mode != "estimated":
            return None
        n = len(states)
        return (np.array([s.xi for s in states]).reshape(n, 3), np.array([s.P_xi for s in states]).reshape(n, 3, 3))

    def prior_shape(self) -> np.ndarray:
        """The shape of a newborn landmark, ``X0 = r0^2 I``."""
        return log_matrix_to_X(self.xi0)

    def sift(self, states, points, polar, centroids, centroid_covs, pose, pose_cov):
        """a.7.1 about the predicted detection means ``mu`` with the arcs' spreads ``S`` and the
        means' covariances ``B P_pp B^T`` (a.12.5), for every landmark (each has a shape)."""
        if not (self.in_slam and self.c.contour_sifting and states) or points.shape[0] == 0:
            return None
        from radarslam.extent._compiled import arc_rows as rows, sift_spreads as spreads
        mu, B, S = rows(float(pose[0]), float(pose[1]), np.ascontiguousarray(centroids, dtype=float),
                        self.view_shapes(states))
        spread, covs = spreads(B, S, np.ascontiguousarray(centroid_covs, dtype=float), self.Qv)
        inside = self._contour(points, polar, pose, pose_cov, self.R_extent, mu, spread, covs, self.gate)
        return inside, np.ones(len(states), dtype=np.bool_)

    def matrix(self, st: PartialViewState) -> np.ndarray | None:
        return st.X_view

    def baseline(self, st: PartialViewState) -> np.ndarray | None:
        return st.X

    def round_diameter(self, X: np.ndarray) -> np.ndarray:
        """Diameters (m) of round objects with these outline shapes: ``2 sqrt(lambda_max)``."""
        return 2.0 * np.sqrt(np.maximum(np.linalg.eigvalsh(np.asarray(X, dtype=float))[..., -1], 0.0))

    def baseline_round_diameter(self, X: np.ndarray) -> np.ndarray:
        return super().round_diameter(X)

    # ------------------------------------------------------------------ life cycle
    def _after(self, E, states: list[PartialViewState], s) -> None:
        """The shapes' scan (module docstring, a.12.7) by :func:`view_rows`, the function the fused
        engine calls (compiled under the numba backend), after the RMA/EFA step."""
        self._kernels.view_rows(E, len(states), s.old, s.aoff, s.arow, s.polar, s.xy, s.cents, s.ccovs, s.pose,
                                self.R_extent, self.Q, self.qv2, self.rel, self.spread_only, self.shape_step)

    def _gather(self, states: list[PartialViewState]):
        E = super()._gather(states)
        if states:
            E.xi[:], E.Pxi[:] = [st.xi for st in states], [st.P_xi for st in states]
            E.nview[:] = [st.n_view for st in states]
        return E

    def _scatter(self, E, states: list[PartialViewState], born, k: int) -> None:
        super()._scatter(E, states, born, k)
        nview = E.nview.tolist()
        for j, st in enumerate(states):
            st.xi, st.P_xi, st.n_view = E.xi[j], E.Pxi[j], nview[j]


