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

and the Jacobian by central differences on ``xi`` (the kernels are smooth in ``X``). Scans with
fewer than 3 detections update with the mean alone.

The random-matrix and EFA estimates are kept underneath (this class extends
:class:`~.estimator.RmaEfaEstimator`): the RMA is the :meth:`baseline` the report compares with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from radarslam.core.registry import EXTENT_ESTIMATORS
from radarslam.extent.estimator import RmaEfaEstimator, RmaEfaState

#: Gauss-Newton steps of the iterated update.
VIEW_ITERATIONS = 3
#: Central-difference step on the log-matrix entries.
FD_STEP = 1e-4
#: Chi-square 99% quantiles (2 and 5 dof): a scan whose innovation lies beyond has its noise
#: scaled up by ``d^2 / gate`` (a Huber-type weight), so that one scan of another object's returns,
#: or of returns the arc model cannot produce, does not drag the shape.
ROBUST_GATE = {2: 9.210, 5: 15.086}


def log_matrix_to_X(xi: np.ndarray) -> np.ndarray:
    """``X = expm(A)`` of the symmetric ``A = [[xi0, xi1], [xi1, xi2]]``, ``(2, 2)``."""
    a, b, c = float(xi[0]), float(xi[1]), float(xi[2])
    m, d = 0.5 * (a + c), math.hypot(0.5 * (a - c), b)
    # expm of a 2 x 2 symmetric matrix: exp(m) (cosh d I + sinh(d)/d (A - m I))
    sh = math.sinh(d) / d if d > 1e-12 else 1.0
    e, ch = math.exp(m), math.cosh(d)
    return e * np.array([[ch + sh * (a - m), sh * b], [sh * b, ch + sh * (c - m)]])


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


def _wishart_vech_cov(Sig: np.ndarray, dof: int) -> np.ndarray:
    """Covariance of ``vech`` (entries 00, 01, 11) of a sample covariance with ``dof`` degrees of
    freedom about ``Sig``: ``cov(C_ij, C_kl) = (Sig_ik Sig_jl + Sig_il Sig_jk) / dof``."""
    pairs = ((0, 0), (0, 1), (1, 1))
    out = np.empty((3, 3))
    for a, (i, j) in enumerate(pairs):
        for b, (k, l) in enumerate(pairs):
            out[a, b] = (Sig[i, k] * Sig[j, l] + Sig[i, l] * Sig[j, k]) / dof
    return out


class PartialViewEstimator(RmaEfaEstimator):
    """Shapes from the visible arcs (module docstring); RMA/EFA underneath as the baseline."""

    name = "partial-view"
    baseline_name = "rma"

    def __init__(self, extent_config, R_extent: np.ndarray, backend: str = "python"):
        super().__init__(extent_config, R_extent, backend)
        ec = extent_config
        # The RMA/EFA step stays the compiled batch step where it would be (this class adds a
        # second step after it instead of overriding step()).
        self._batched = (backend == "numba" and ec.efa_mode == "per_scan" and ec.w_mode == "max_trace")
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

    def prior_shape(self) -> np.ndarray:
        """The shape of a newborn landmark, ``X0 = r0^2 I``."""
        return log_matrix_to_X(self.xi0)

    def sift(self, states, points, polar, centroids, centroid_covs, pose, pose_cov):
        """a.7.1 about the predicted detection means ``mu`` with the arcs' spreads ``S`` and the
        means' covariances ``B P_pp B^T`` (a.12.5), for every landmark (each has a shape)."""
        if not (self.in_slam and self.c.contour_sifting and states) or points.shape[0] == 0:
            return None
        from radarslam.extent._compiled import arc_moments_many
        X = self.view_shapes(states)
        g, G, S = arc_moments_many(np.ascontiguousarray(pose[:2] - centroids), X)
        B = np.eye(2) - G
        covs = B @ centroid_covs @ np.swapaxes(B, 1, 2)
        inside = self._contour(points, polar, pose, pose_cov, self.R_extent, np.ascontiguousarray(centroids + g),
                               np.ascontiguousarray(S + self.Qv), np.ascontiguousarray(covs), self.gate)
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
    def step(self, st, polar, pts, centroid, centroid_cov, pose, pose_cov, dt, k) -> None:
        super().step(st, polar, pts, centroid, centroid_cov, pose, pose_cov, dt, k)
        self.view_step(st, polar, pts, centroid, centroid_cov, pose)

    def step_all(self, states, polar, pts, assoc, centroids, centroid_covs, pose, pose_cov, dt, k) -> None:
        super().step_all(states, polar, pts, assoc, centroids, centroid_covs, pose, pose_cov, dt, k)
        for j, st in enumerate(states):
            a = assoc[j]
            self.view_step(st, polar[a], pts[a], centroids[j], centroid_covs[j], pose)

    def _moments(self, xi: np.ndarray, d: np.ndarray):
        from radarslam.extent._compiled import arc_moments
        X = log_matrix_to_X(xi)
        r = arc_moments(float(d[0]), float(d[1]), X[0, 0], X[0, 1], X[1, 1])
        return np.array(r[:2]), np.array([[r[6], r[7]], [r[7], r[8]]]), bool(r[9])

    def _predict_y(self, xi, d, Ws, spread: bool) -> np.ndarray:
        g, S, _ = self._moments(xi, d)
        if not spread:
            return g
        C = S + Ws
        return np.array([g[0], g[1], C[0, 0], C[0, 1], C[1, 1]])

    def view_step(self, st: PartialViewState, polar: np.ndarray, pts: np.ndarray, centroid: np.ndarray,
                  centroid_cov: np.ndarray, pose: np.ndarray) -> None:
        """One scan's iterated EKF update of the landmark's shape (module docstring, a.12.7)."""
        st.P_xi = st.P_xi + self.Q
        m = pts.shape[0]
        if m == 0 or not self.c.track:
            return
        d = pose[:2] - centroid
        zbar = pts.mean(axis=0)
        # the sensor's noise of each detection in the world frame, averaged (seed eq. 5 without P^m)
        a = pose[2] + polar[:, 1]
        c, s, r = np.cos(a), np.sin(a), polar[:, 0]
        R = self.R_extent
        J = np.stack([np.stack([c, -r * s], 1), np.stack([s, r * c], 1)], 1)        # (m, 2, 2)
        Ws = (J @ R @ np.swapaxes(J, 1, 2)).mean(axis=0)
        spread = m >= 3
        y = zbar - centroid
        if spread:
            C = np.cov(pts.T)
            y = np.array([y[0], y[1], C[0, 0], C[0, 1], C[1, 1]])
        xi0, P0 = st.xi.copy(), st.P_xi
        xi = xi0.copy()
        for _ in range(VIEW_ITERATIONS):
            h = self._predict_y(xi, d, Ws, spread)
            H = np.empty((h.size, 3))
            for i in range(3):
                dxi = np.zeros(3)
                dxi[i] = FD_STEP
                H[:, i] = (self._predict_y(xi + dxi, d, Ws, spread) - self._predict_y(xi - dxi, d, Ws, spread)) / (2 * FD_STEP)
            _, S, clamped = self._moments(xi, d)
            if clamped:
                return                                  # the sensor inside the outline: no arc to fit (a.12.3)
            Rn = np.zeros((h.size, h.size))
            Rn[:2, :2] = (S + Ws) / m + centroid_cov + self.Qv
            if self.spread_only and spread:
                Rn[:2, :2] += 1e6 * np.eye(2)      # extent.view_shape_data = "spread": no mean rows
            if spread:
                Sig = S + Ws
                v = np.array([Sig[0, 0], Sig[0, 1], Sig[1, 1]])
                Rn[2:, 2:] = _wishart_vech_cov(Sig, m - 1) + np.diag((self.rel * np.abs(v)) ** 2 + 1e-6)
            Sy = H @ P0 @ H.T + Rn
            r = y - h
            d2 = float(r @ np.linalg.solve(Sy, r))
            gate = ROBUST_GATE[h.size]
            if d2 > gate:                               # a scan the model cannot explain: down-weighted (a.12.7)
                Rn = Rn * (d2 / gate)
                Sy = H @ P0 @ H.T + Rn
            K = np.linalg.solve(Sy, H @ P0).T
            xi = xi0 + K @ (y - h - H @ (xi0 - xi))
        if not np.all(np.isfinite(xi)):
            return                                      # a failed update leaves the shape as it was
        I_KH = np.eye(3) - K @ H
        st.xi = xi
        st.P_xi = I_KH @ P0 @ I_KH.T + K @ Rn @ K.T
        st.n_view += 1

    def merge(self, survivor: PartialViewState, gone: PartialViewState) -> PartialViewState:
        """As :meth:`RmaEfaEstimator.merge`; the survivor keeps the better-known shape of the two."""
        xi, P, n = (gone.xi, gone.P_xi, gone.n_view) if gone.n_view > survivor.n_view else \
            (survivor.xi, survivor.P_xi, survivor.n_view)
        kept = super().merge(survivor, gone)
        kept.xi, kept.P_xi, kept.n_view = xi, P, n
        return kept


EXTENT_ESTIMATORS.register("partial-view", PartialViewEstimator.from_config)
