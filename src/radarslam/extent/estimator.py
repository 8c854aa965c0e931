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

from radarslam.core.arrays import grown, grown_inner
from radarslam.core.registry import EXTENT_ESTIMATORS
from radarslam.extent.buffering import POOL, TAKE, merge_outcome
from radarslam.extent.ellipse_fit import _fit_ellipse
from radarslam.extent.measurement import _scan_W
from radarslam.extent.measurement import _converted_measurement_covs
from radarslam.extent.rows import ExtentRows
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
        self._kernels = _row_kernels(backend)
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
        baseline (Decision 5) for one landmark and one scan: :meth:`step_all` on it alone."""
        self._rows_step([st], polar, pts, [list(range(polar.shape[0]))], np.asarray(centroid)[None],
                        np.asarray(centroid_cov)[None], pose, pose_cov, dt, k)

    def step_all(self, states: list[RmaEfaState], polar: np.ndarray, pts: np.ndarray, assoc: list[list[int]],
                 centroids: np.ndarray, centroid_covs: np.ndarray, pose: np.ndarray, pose_cov: np.ndarray,
                 dt: float, k: int) -> None:
        """:meth:`step` for every landmark of the scan. A subclass that overrides :meth:`step` is
        stepped landmark by landmark; otherwise the scan goes through the extent step over
        array-held states (:mod:`radarslam.extent.rows`, compiled under the numba backend), the
        same functions the fused engine calls."""
        if type(self).step is not RmaEfaEstimator.step:
            for j, st in enumerate(states):
                a = assoc[j]
                self.step(st, polar[a], pts[a], centroids[j], centroid_covs[j], pose, pose_cov, dt, k)
            return
        self._rows_step(states, polar, pts, assoc, centroids, centroid_covs, pose, pose_cov, dt, k)

    def _rows_step(self, states, polar, pts, assoc, centroids, centroid_covs, pose, pose_cov, dt, k) -> None:
        """The objects ``states`` gathered into an :class:`~radarslam.extent.rows.ExtentRows`, a.3
        and a.4-a.5 by :func:`~radarslam.extent.rows.initialise_rows` and
        :func:`~radarslam.extent.rows.rma_efa_rows`, and the rows written back. The options the
        fused engine has not (``w_mode`` other than ``max_trace``: the scan's ``W`` given;
        ``efa_mode = "sliding"``: the EFA of :meth:`_efa_baseline` after) are handled here."""
        ec, N = self.c, len(states)
        if not ec.track or N == 0:
            return
        kern = self._kernels
        E = _gather(states)
        old = np.arange(N, dtype=np.int64)
        aoff = np.zeros(N + 1, dtype=np.int64)
        aoff[1:] = np.cumsum([len(a) for a in assoc])
        arow = np.array([i for a in assoc for i in a], dtype=np.int64)
        polar = np.ascontiguousarray(polar, dtype=float).reshape(-1, 2)
        pts = np.ascontiguousarray(pts, dtype=float).reshape(-1, 2)
        ready = E.einit.copy()
        born = np.zeros(N, dtype=np.int64)
        E = E._replace(buf=grown_inner(E.buf, kern.buffer_need(E, ready, N, old, aoff)))
        kern.initialise_rows(E, ready, born, N, old, aoff, arow, pts, ec.n_init, ec.spread_factor, ec.alpha0)
        w_given = ec.w_mode != "max_trace"
        W = np.zeros((N if w_given else 0, 2, 2))
        if w_given:
            for j in np.flatnonzero(ready).tolist():
                if assoc[j]:
                    W[j] = _scan_W(pose, pose_cov, polar[assoc[j]], self.R_extent, ec.w_mode)
        sliding = ec.efa_mode == "sliding"
        kern.rma_efa_rows(E, ready, N, old, aoff, arow, polar, pts, np.ascontiguousarray(centroids, dtype=float),
                          np.ascontiguousarray(centroid_covs, dtype=float), np.asarray(pose, dtype=float),
                          np.asarray(pose_cov, dtype=float), self.R_extent, W, w_given, dt, ec.tau_s,
                          ec.spread_factor, ec.eig_floor_m2, not ec.efa_noise_correct, not sliding)
        _scatter(E, states, born, k, ec.efa_window)
        if sliding:
            for j in np.flatnonzero(ready).tolist():
                if assoc[j]:
                    a = assoc[j]
                    Wj = _scan_W(pose, pose_cov, polar[a], self.R_extent, ec.w_mode) if ec.efa_noise_correct else None
                    self._efa_baseline(states[j], pts[a], Wj)

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

    def _buffer(self, st: RmaEfaState, pts: np.ndarray, k: int) -> None:
        """a.3 for one landmark (:func:`~radarslam.extent.rows.initialise_rows` on it alone):
        buffer detections; once more than ``n_init`` are held, initialise X by EFA (upper bound)
        with ``alpha_0``; a degenerate fit keeps only the newest ``n_init`` and waits."""
        ec, kern = self.c, self._kernels
        E = _gather([st])
        one = np.zeros(2, dtype=np.int64)
        one[1] = pts.shape[0]
        zero, ready, born = np.zeros(1, dtype=np.int64), np.zeros(1, dtype=np.bool_), np.zeros(1, dtype=np.int64)
        E = E._replace(buf=grown_inner(E.buf, kern.buffer_need(E, ready, 1, zero, one)))
        kern.initialise_rows(E, ready, born, 1, zero, one, np.arange(pts.shape[0], dtype=np.int64),
                             np.ascontiguousarray(pts, dtype=float).reshape(-1, 2), ec.n_init, ec.spread_factor,
                             ec.alpha0)
        _scatter(E, [st], born, k, ec.efa_window)

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


def _row_kernels(backend: str):
    """The extent step's kernels over array-held states (:mod:`radarslam.extent.rows`): as Python,
    or compiled under the numba backend (:mod:`radarslam.extent._compiled`)."""
    if backend == "numba":
        from radarslam.extent import _compiled as kernels
    else:
        from radarslam.extent import rows as kernels
    return kernels


def _gather(states: list[RmaEfaState]) -> ExtentRows:
    """The RMA/EFA states of ``states`` as the rows of one record (new arrays)."""
    n = len(states)
    zero = np.zeros((2, 2))
    B = max([s.n_buffered for s in states], default=0)
    E = ExtentRows(einit=np.array([s.initialized for s in states], dtype=np.bool_),
                   X=np.array([zero if s.X is None else s.X for s in states], dtype=float).reshape(n, 2, 2),
                   alpha=np.array([s.alpha for s in states], dtype=float),
                   Xefa=np.array([zero if s.X_efa is None else s.X_efa for s in states], dtype=float).reshape(n, 2, 2),
                   nbuf=np.array([s.n_buffered for s in states], dtype=np.int64), buf=np.zeros((n, B, 2)))
    for j, s in enumerate(states):
        E.buf[j, :s.n_buffered] = s.buffer[:s.n_buffered]
    return E


def _scatter(E: ExtentRows, states: list[RmaEfaState], born: np.ndarray, k: int, efa_window: int) -> None:
    """The rows of ``E`` written back into ``states``; a landmark initialised now (``born[j]``
    detections fitted) records the scan ``k`` and starts the sliding EFA's buffer with them."""
    for j, s in enumerate(states):
        n = int(born[j])
        if n:
            s.initialized_at = k
            s.efa_buffer = [E.buf[j, :n][-efa_window:].copy()]
            s.buffer, s.n_buffered = np.empty((0, 2)), 0
        elif not E.einit[j]:
            s.n_buffered = int(E.nbuf[j])
            s.buffer = E.buf[j, :s.n_buffered].copy()
        if E.einit[j]:
            s.X, s.alpha, s.X_efa = E.X[j].copy(), float(E.alpha[j]), E.Xefa[j].copy()


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
