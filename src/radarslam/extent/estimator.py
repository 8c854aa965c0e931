"""Extent-estimator components (docs/method.md a.3-a.7; docs/architecture.md "Extent estimator").

An extent estimator owns every landmark's extent state and its life cycle: a fresh state when the
landmark is born (:meth:`~ExtentEstimator.new`), buffering and initialisation, prediction and
update with the detections associated in a scan (:meth:`~ExtentEstimator.step`), and the fusion
of two states when landmarks merge (:meth:`~ExtentEstimator.merge`). It answers what SLAM needs
from an extent: the sifting shapes (a.7.1), the spread ``gamma_z X`` that inflates the
measurement noise (a.7.2), and a 2 x 2 matrix for snapshots and the GWD (plus a baseline matrix,
EFA for the default).

The default, ``"rma-efa"``, is the seed paper's random-matrix approach (RMA) initialised by ellipse
fitting, with the per-scan EFA baseline tracked beside it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from radarslam.core.arrays import grown
from radarslam.core.registry import EXTENT_ESTIMATORS
from radarslam.extent.buffering import POOL, READY, TAKE, buffer_and_fit, merge_outcome
from radarslam.extent.ellipse_fit import _fit_ellipse
from radarslam.extent.measurement import _scan_W
from radarslam.extent.measurement import _converted_measurement_covs
from radarslam.extent.random_matrix import _rm_predict, _rm_update
from radarslam.extent.ellipse import trunk_diameter
from radarslam.extent.sifting import chi2_2dof_quantile, literal_contour, literal_inside, measurement_contour


class ExtentEstimator(Protocol):
    """What the orchestrator needs from an extent estimator (per-landmark states are opaque)."""

    #: True: the update uses the landmark's posterior centroid of this scan; False: the prior (h.4).
    posterior_centroid: bool
    #: False: :meth:`step` does nothing this run (``extent.track = false``), so the orchestrator
    #: skips the per-landmark loop. Optional; an estimator without it is always stepped.
    active: bool

    def new(self) -> Any:
        """The extent state of a newborn landmark."""

    def step(self, st: Any, polar: np.ndarray, pts: np.ndarray, centroid: np.ndarray, centroid_cov: np.ndarray,
             pose: np.ndarray, pose_cov: np.ndarray, dt: float, k: int) -> None:
        """One scan for one landmark: ``polar`` its associated detections (m, 2), ``pts`` the same in
        the world frame (updated pose), ``dt`` the time since the last scan (0 at the first)."""

    def step_all(self, states: list[Any], polar: np.ndarray, pts: np.ndarray, assoc: list[list[int]],
                 centroids: np.ndarray, centroid_covs: np.ndarray, pose: np.ndarray, pose_cov: np.ndarray,
                 dt: float, k: int) -> None:
        """Optional: :meth:`step` for every landmark of the scan at once (landmark ``j`` has the
        detections ``assoc[j]`` of ``polar``/``pts``, the centroid ``centroids[j]`` and its
        covariance ``centroid_covs[j]``). The orchestrator calls it when present, else :meth:`step`."""

    def merge(self, survivor: Any, gone: Any) -> Any:
        """The extent state of the landmark that survives a merge (c.9)."""

    def sift(self, states: list[Any], points: np.ndarray, polar: np.ndarray, centroids: np.ndarray,
             centroid_covs: np.ndarray, pose: np.ndarray, pose_cov: np.ndarray):
        """The extent-aware sifting test of a.7.1: ``(inside (m, N), has (N,))``, or None when the
        radius test applies to every landmark. ``points`` are the detections ``polar`` in the world
        frame of the predicted ``pose``."""

    def spreads(self, states: list[Any]) -> tuple[np.ndarray, np.ndarray]:
        """``(gamma_z X (N, 2, 2), has (N,))``: the extent part of R_eff (a.7.2); has all False: R."""

    def initial_spread(self) -> np.ndarray | None:
        """The detection spread (2, 2) a newborn landmark's centroid may be off by (its prior
        extent's ``gamma_z X0``), for the cluster initialisation of c.8; None: no prior."""

    def matrix(self, st: Any) -> np.ndarray | None:
        """The estimated extent (2, 2), or None before initialisation."""

    def baseline(self, st: Any) -> np.ndarray | None:
        """A second estimate for comparison (EFA for the default), or None."""


@dataclass
class RmaEfaState:
    """Extent of one landmark: the buffer before initialisation; afterwards ``X``/``alpha`` (RMA)
    and ``X_efa`` (the EFA baseline)."""

    #: The detections held before the extent is initialised (a.3): rows ``0 .. n_buffered - 1``.
    buffer: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    n_buffered: int = 0
    X: np.ndarray | None = None
    alpha: float = 0.0
    X_efa: np.ndarray | None = None
    efa_buffer: list[np.ndarray] = field(default_factory=list)
    initialized_at: int | None = None

    @property
    def initialized(self) -> bool:
        return self.X is not None


class RmaEfaEstimator:
    """Random-matrix extents (seed eqs. 4-5; a.3-a.5) initialised by EFA, with the EFA baseline.

    Parameters
    ----------
    extent_config : ExtentConfig
        The ``extent`` section.
    R_extent : ndarray (2, 2)
        Detection noise of the extent step (``ExtentConfig.R``: the sensor's own).
    backend : {"python", "numba"}
        ``filter.backend``: ``"numba"`` runs the sifting test compiled (the same arithmetic).
    """

    name = "rma-efa"

    def __init__(self, extent_config, R_extent: np.ndarray, backend: str = "python"):
        self.c = extent_config
        self._contour = _contour_test(backend)
        self._literal = _literal_kernel(backend)
        # The compiled scan step covers this class's own step() with the default EFA and W options;
        # a subclass that overrides step(), or other options, run step() per landmark.
        self._batched = (backend == "numba" and type(self).step is RmaEfaEstimator.step
                         and extent_config.efa_mode == "per_scan" and extent_config.w_mode == "max_trace")
        self.R_extent = R_extent
        self.posterior_centroid = bool(extent_config.use_posterior_landmark)
        self.in_slam = bool(extent_config.use_in_slam)
        self.active = bool(extent_config.track)
        self.gate = chi2_2dof_quantile(extent_config.gate_probability)
        #: gamma_z X0 of the circular prior extent X0 = r^2 I ([PROP], docs/method.md a.7.3).
        self.prior_spread = extent_config.spread_factor * extent_config.prior_extent_radius_m ** 2 * np.eye(2)

    @classmethod
    def from_config(cls, config):
        """From the ``extent`` section, with the extent step's noise from ``extent`` or ``filter``
        (the registered factory of this class and its subclasses)."""
        return cls(config.extent, config.extent.R(config.filter.R), config.filter.backend)

    def new(self) -> RmaEfaState:
        return RmaEfaState()

    # ------------------------------------------------------------------ what SLAM asks
    def sift(self, states: list[RmaEfaState], points: np.ndarray, polar: np.ndarray, centroids: np.ndarray,
             centroid_covs: np.ndarray, pose: np.ndarray, pose_cov: np.ndarray):
        """a.7.1: the measurement contour (the gate of ``gamma_z X + W(z) + P^n``) or the literal
        ``X`` ellipse, for landmarks with an initialised extent; None when sifting is by radius."""
        if not (self.in_slam and self.c.contour_sifting and states):
            return None
        has = np.array([s.initialized for s in states])
        if not has.any() or points.shape[0] == 0:
            return None
        X = np.array([s.X if s.initialized else np.eye(2) for s in states])
        if self.c.sifting_mode == "literal":
            return literal_contour(points, centroids, X, self.c.kappa, has, self._literal), has
        return self._contour(points, polar, pose, pose_cov, self.R_extent, centroids, self.c.spread_factor * X,
                             centroid_covs, self.gate), has

    def _pre_init_spread(self, st: RmaEfaState) -> np.ndarray | None:
        """The spread of a landmark without an extent ([PROP] ``extent.pre_init_spread``)."""
        mode = self.c.pre_init_spread
        if mode == "prior":
            return self.prior_spread
        if mode == "scatter":
            if st.n_buffered >= 3:
                return np.cov(st.buffer[:st.n_buffered].T)
            return self.prior_spread
        return None

    def spreads(self, states: list[RmaEfaState]) -> tuple[np.ndarray, np.ndarray]:
        n = len(states)
        gX, has = np.zeros((n, 2, 2)), np.zeros(n, dtype=np.bool_)
        if self.in_slam and self.c.inflate_noise:
            for j, s in enumerate(states):
                spread = self.c.spread_factor * s.X if s.X is not None else self._pre_init_spread(s)
                if spread is not None:
                    gX[j] = spread
                    has[j] = True
        return gX, has

    def initial_spread(self) -> np.ndarray | None:
        return self.prior_spread if self.in_slam and self.c.pre_init_spread != "none" else None

    def matrix(self, st: RmaEfaState) -> np.ndarray | None:
        return st.X

    def baseline(self, st: RmaEfaState) -> np.ndarray | None:
        return st.X_efa

    #: What :meth:`baseline` is, for reports.
    baseline_name = "efa"

    def round_diameter(self, X: np.ndarray) -> np.ndarray:
        """Diameters (m) of round objects seen by a laser whose RMA extents are ``X (..., 2, 2)``
        (the laser-arc reading with this estimator's ``gamma_z``; docs/method.md v.4)."""
        return trunk_diameter(X, self.c.spread_factor)

    def baseline_round_diameter(self, X: np.ndarray) -> np.ndarray:
        """The same for the EFA baseline, ``X_EFA = C / gamma_z`` (``4 C`` for the surface model,
        Decision 4; a.11)."""
        return trunk_diameter(X, self.c.spread_factor)

    # ------------------------------------------------------------------ life cycle
    def step(self, st: RmaEfaState, polar: np.ndarray, pts: np.ndarray, centroid: np.ndarray,
             centroid_cov: np.ndarray, pose: np.ndarray, pose_cov: np.ndarray, dt: float, k: int) -> None:
        """a.3 (buffer, then EFA initialisation), a.4 (RM prediction), a.5 (RM update) and the EFA
        baseline (Decision 5) for one landmark and one scan."""
        if not self.c.track:
            return
        if not st.initialized:
            self._buffer(st, pts, k)
            return
        ec = self.c
        if dt > 0.0:
            st.X, st.alpha = _rm_predict(st.X, st.alpha, dt, ec.tau_s)
        if polar.shape[0] == 0:
            return
        W = _scan_W(pose, pose_cov, polar, self.R_extent, ec.w_mode)  # seed eq. (5), h.3
        st.X, st.alpha = _rm_update(st.X, st.alpha, centroid, centroid_cov, pts, W, ec.spread_factor, ec.eig_floor_m2)
        self._efa_baseline(st, pts, W)

    def _efa_baseline(self, st: RmaEfaState, pts: np.ndarray, W: np.ndarray | None) -> None:
        """The EFA baseline of the scan (Decision 5, d.3): the fit of this scan's detections (or of
        the sliding buffer), with the spread factor of a.11; ``W`` (the scan's, seed eq. 5) is used
        only by the noise-corrected fit. Kept when the fit fails."""
        ec = self.c
        if ec.efa_mode == "sliding":
            data = np.concatenate(st.efa_buffer + [pts])[-ec.efa_window:]
            st.efa_buffer = [data]
        else:
            data = pts
        if data.shape[0] >= 3:
            fit = _fit_ellipse(data, not ec.efa_noise_correct, W if ec.efa_noise_correct else None, ec.spread_factor)
            if fit:
                st.X_efa = fit[1]

    def step_all(self, states: list[RmaEfaState], polar: np.ndarray, pts: np.ndarray, assoc: list[list[int]],
                 centroids: np.ndarray, centroid_covs: np.ndarray, pose: np.ndarray, pose_cov: np.ndarray,
                 dt: float, k: int) -> None:
        """:meth:`step` for every landmark of the scan. With ``filter.backend = "numba"`` the
        initialised landmarks go through one compiled call
        (:func:`radarslam.extent._compiled.rma_efa_step`, the same kernels compiled); the ones still
        buffering (a.3) are handled here as in :meth:`step`."""
        if not self._batched:
            for j, st in enumerate(states):
                a = assoc[j]
                self.step(st, polar[a], pts[a], centroids[j], centroid_covs[j], pose, pose_cov, dt, k)
            return
        if not self.c.track:
            return
        ready = []
        for j, st in enumerate(states):
            if st.initialized:
                ready.append(j)
            else:
                self._buffer(st, pts[assoc[j]], k)
        if not ready:
            return
        from radarslam.extent._compiled import rma_efa_step

        ec = self.c
        rows = [i for j in ready for i in assoc[j]]
        offsets = np.zeros(len(ready) + 1, dtype=np.int64)
        offsets[1:] = np.cumsum([len(assoc[j]) for j in ready])
        X, alpha, efa, ok = rma_efa_step(
            np.array([states[j].X for j in ready]), np.array([states[j].alpha for j in ready]),
            centroids[ready], centroid_covs[ready], offsets, polar[rows].reshape(-1, 2), pts[rows].reshape(-1, 2),
            pose, pose_cov, self.R_extent, dt, ec.tau_s, ec.spread_factor, ec.eig_floor_m2, not ec.efa_noise_correct)
        for l, (j, fit) in enumerate(zip(ready, ok.tolist())):
            st = states[j]
            st.X, st.alpha = X[l], float(alpha[l])
            if fit:
                st.X_efa = efa[l]

    def _buffer(self, st: RmaEfaState, pts: np.ndarray, k: int) -> None:
        """a.3 (:func:`~radarslam.extent.buffering.buffer_and_fit`): buffer detections; once more
        than ``n_init`` are held, initialise X by EFA (upper bound) with ``alpha_0``; a degenerate
        fit keeps only the newest ``n_init`` and waits."""
        ec = self.c
        st.buffer = grown(st.buffer, st.n_buffered + pts.shape[0])
        outcome, n, e11, e12, e22 = buffer_and_fit(st.buffer, st.n_buffered, pts, ec.n_init, ec.spread_factor)
        if outcome != READY:
            st.n_buffered = n
            return
        st.X = np.array(((e11, e12), (e12, e22)))
        st.alpha = ec.alpha0
        st.X_efa = st.X.copy()
        st.initialized_at = k
        st.efa_buffer = [st.buffer[:n][-ec.efa_window:].copy()]
        st.buffer, st.n_buffered = np.empty((0, 2)), 0

    def merge(self, survivor: RmaEfaState, gone: RmaEfaState) -> RmaEfaState:
        """c.9 [PROP] (:func:`~radarslam.extent.buffering.merge_outcome`): the surviving landmark
        keeps its own extent; it takes the other's when it has none yet, and two uninitialised
        landmarks pool their buffered detections."""
        outcome = merge_outcome(survivor.initialized, gone.initialized)
        if outcome == TAKE:
            return gone
        if outcome == POOL:
            n = survivor.n_buffered + gone.n_buffered
            survivor.buffer = grown(survivor.buffer, n)
            survivor.buffer[survivor.n_buffered:n] = gone.buffer[:gone.n_buffered]
            survivor.n_buffered = n
        return survivor


def _reference_contour(points, polar, pose, pose_cov, R, centroids, spreads, centroid_covs, gate):
    """The measurement-contour test of a.7.1 with every detection's ``W`` (seed eq. 5)."""
    W = _converted_measurement_covs(pose, pose_cov, polar, R)
    return measurement_contour(points, W, centroids, spreads, centroid_covs, gate)


def _contour_test(backend: str):
    """The measurement-contour test of ``backend``: the reference above, or the same arithmetic
    compiled (:func:`radarslam.extent._compiled.measurement_contour`)."""
    if backend != "numba":
        return _reference_contour
    from radarslam.extent._compiled import measurement_contour as compiled

    def contour(points, polar, pose, pose_cov, R, centroids, spreads, centroid_covs, gate):
        return compiled(points, polar, float(pose[2]), pose_cov, R, centroids, spreads, centroid_covs, gate)
    return contour


def _literal_kernel(backend: str):
    """The literal contour's kernel in ``backend``: :func:`~.sifting.literal_inside` or its compiled form."""
    if backend != "numba":
        return literal_inside
    from radarslam.extent._compiled import literal_inside as compiled
    return compiled


EXTENT_ESTIMATORS.register("rma-efa", RmaEfaEstimator.from_config)
