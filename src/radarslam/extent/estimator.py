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
from types import SimpleNamespace
from typing import Any, NamedTuple, Protocol

import numpy as np

from radarslam.core.arrays import grown_inner
from radarslam.extent.buffering import TAKE, buffered_scatter
from radarslam.extent.measurement import _scan_W
from radarslam.extent.measurement import _converted_measurement_covs
from radarslam.extent.rows import ExtentRows, empty_rows
from radarslam.extent.ellipse import trunk_diameter
from radarslam.extent.sifting import chi2_2dof_quantile, literal_contour, literal_inside, measurement_contour


class ExtentEstimator(Protocol):
    """What the filter needs from an extent estimator of the user's own (slam/fused/own.py) (per-landmark states are opaque)."""

    #: True: the update uses the landmark's posterior centroid of this scan; False: the prior (h.4).
    posterior_centroid: bool
    #: False: :meth:`step` does nothing this run (``extent.track = false``), so the filter
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
        covariance ``centroid_covs[j]``). The filter calls it when present, else :meth:`step`."""

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

    #: The detections held before the extent is initialised (a.3), and after it under
    #: ``efa_mode = "sliding"`` the sliding EFA's window: rows ``0 .. n_buffered - 1``.
    buffer: np.ndarray = field(default_factory=lambda: np.empty((0, 2)))
    n_buffered: int = 0
    X: np.ndarray | None = None
    alpha: float = 0.0
    X_efa: np.ndarray | None = None
    initialized_at: int | None = None

    @property
    def initialized(self) -> bool:
        return self.X is not None


class ScanRows(NamedTuple):
    """A scan as the extent step over array-held states takes it (:mod:`radarslam.extent.rows`):
    landmark ``j``'s detections are rows ``arow[aoff[old[j]]:aoff[old[j] + 1]]``."""

    old: np.ndarray        #: (N,) int64, each landmark's association row
    aoff: np.ndarray       #: (N + 1,) int64
    arow: np.ndarray       #: (a,) int64
    polar: np.ndarray      #: (m, 2) the scan's detections, sensor frame
    xy: np.ndarray         #: (m, 2) the same in the world frame of the updated pose
    cents: np.ndarray      #: (N, 2) the centroids the update is about
    ccovs: np.ndarray      #: (N, 2, 2) their covariances
    pose: np.ndarray       #: (3,)
    pose_cov: np.ndarray   #: (3, 3)
    W: np.ndarray          #: (N, 2, 2) the scans' W when given (w_given), else (0, 2, 2)
    w_given: bool
    dt: float


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
                return buffered_scatter(st.buffer, st.n_buffered)
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
        """The objects ``states`` gathered into an :class:`~radarslam.extent.rows.ExtentRows`
        (:meth:`_gather`), the extent step over array-held states that the fused engine runs too
        (a.3 by :func:`~radarslam.extent.rows.initialise_rows`, then :meth:`_born`, :meth:`_scan`
        and :meth:`_after`, a subclass's; under ``efa_mode = "sliding"`` the EFA baseline by
        :func:`~radarslam.extent.rows.sliding_efa_rows` after), and the rows written back
        (:meth:`_scatter`). The fused engine's extent step calls the same kernels."""
        ec, N = self.c, len(states)
        if not ec.track or N == 0:
            return
        aoff = np.zeros(N + 1, dtype=np.int64)
        aoff[1:] = np.cumsum([len(a) for a in assoc])
        polar = np.ascontiguousarray(polar, dtype=float).reshape(-1, 2)
        pose, pose_cov = np.asarray(pose, dtype=float), np.asarray(pose_cov, dtype=float)
        w_given = ec.w_mode != "max_trace"
        W = np.zeros((N, 2, 2)) if w_given else _NO_W
        for j in range(N if w_given else 0):
            if assoc[j]:
                W[j] = _scan_W(pose, pose_cov, polar[assoc[j]], self.R_extent, ec.w_mode)
        s = ScanRows(np.arange(N, dtype=np.int64), aoff, np.array([i for a in assoc for i in a], dtype=np.int64),
                     polar, np.ascontiguousarray(pts, dtype=float).reshape(-1, 2),
                     np.ascontiguousarray(centroids, dtype=float).reshape(-1, 2),
                     np.ascontiguousarray(centroid_covs, dtype=float).reshape(-1, 2, 2), pose, pose_cov, W, w_given, dt)
        kern = self._kernels
        E = self._gather(states)
        ready, born = E.einit.copy(), np.zeros(N, dtype=np.int64)
        if not ready.all():                              # a.3 for the landmarks without an extent
            need = kern.buffer_need(E, ready, N, s.old, s.aoff)
            if need > E.buf.shape[1]:
                E = E._replace(buf=grown_inner(E.buf, need))
            kern.initialise_rows(E, ready, born, N, s.old, s.aoff, s.arow, s.xy, ec.n_init, ec.spread_factor,
                                 ec.alpha0)
            self._born(E, born)
        sliding = ec.efa_mode == "sliding"
        self._scan(E, ready, s, not sliding)
        self._after(E, states, s)
        if sliding:                                      # Decision 5's EFA of the last efa_window detections
            E = E._replace(buf=grown_inner(E.buf, ec.efa_window))
            kern.sliding_efa_rows(E, ready, born, N, s.old, s.aoff, s.arow, s.polar, s.xy, pose, pose_cov,
                                  self.R_extent, s.W, s.w_given, ec.efa_window, ec.spread_factor,
                                  not ec.efa_noise_correct)
        self._scatter(E, states, born, k)

    # The hooks of the extent step over array-held states (:meth:`_rows_step`), for the subclasses.
    def _born(self, E: ExtentRows, born: np.ndarray) -> None:
        """What a landmark whose extent was initialised now (``born[j] > 0``) starts with besides."""

    def _scan(self, E: ExtentRows, ready: np.ndarray, s: ScanRows, efa: bool) -> None:
        """The scan's step of the landmarks ``ready``: a.4-a.5 and the EFA of Decision 5."""
        ec = self.c
        self._kernels.rma_efa_rows(E, ready, len(ready), s.old, s.aoff, s.arow, s.polar, s.xy, s.cents, s.ccovs,
                                   s.pose, s.pose_cov, self.R_extent, s.W, s.w_given, s.dt, ec.tau_s, ec.spread_factor,
                                   ec.eig_floor_m2, not ec.efa_noise_correct, efa)

    def _after(self, E: ExtentRows, states: list, s: ScanRows) -> None:
        """A further step of every landmark after :meth:`_scan` (a subclass's own estimate)."""

    def _gather(self, states: list[RmaEfaState]) -> ExtentRows:
        """The states as the rows of one record (new arrays)."""
        Xs = [st.X for st in states]
        nb = [st.n_buffered for st in states]
        E = empty_rows(len(states), max(nb, default=0))
        if states:
            E.einit[:] = [X is not None for X in Xs]
            E.alpha[:] = [st.alpha for st in states]
            E.nbuf[:] = nb
            E.X[:] = [_ZERO2 if X is None else X for X in Xs]
            E.Xefa[:] = [_ZERO2 if st.X_efa is None else st.X_efa for st in states]
        for j, n in enumerate(nb):
            if n:
                E.buf[j, :n] = states[j].buffer[:n]
        return E

    def _scatter(self, E: ExtentRows, states: list[RmaEfaState], born: np.ndarray, k: int) -> None:
        """The rows written back into ``states`` (as views of the record's rows: a record is made
        for one step and not changed after); a landmark initialised now (``born[j]`` detections
        fitted) records the scan ``k``. Under ``efa_mode = "sliding"`` an initialised landmark's
        buffer holds the sliding EFA's window (:func:`~radarslam.extent.rows.sliding_efa_rows`)."""
        nbuf, alpha, einit, fitted = E.nbuf.tolist(), E.alpha.tolist(), E.einit.tolist(), born.tolist()
        for j, st in enumerate(states):
            n = nbuf[j]
            if fitted[j]:
                st.initialized_at = k
            if n or st.n_buffered:
                st.n_buffered, st.buffer = n, E.buf[j, :n]
            if einit[j]:
                st.X, st.alpha, st.X_efa = E.X[j], alpha[j], E.Xefa[j]

    #: The partial view's shapes take part in a merge (:func:`~radarslam.extent.rows.merge_rows`).
    _merges_view = False

    def merge(self, survivor: RmaEfaState, gone: RmaEfaState) -> RmaEfaState:
        """c.9 [PROP] by :func:`~radarslam.extent.rows.merge_rows`, the function the fused engine
        calls: the surviving landmark keeps its own extent; it takes the other's when it has none
        yet, and two uninitialised landmarks pool their buffered detections."""
        E = self._gather([survivor, gone])
        E = E._replace(buf=grown_inner(E.buf, survivor.n_buffered + gone.n_buffered))
        if self._kernels.merge_rows(E, 0, 1, self._merges_view) == TAKE:
            survivor.initialized_at = gone.initialized_at
        self._scatter(E, [survivor], np.zeros(1, dtype=np.int64), -1)
        return survivor


_ZERO2, _NO_W = np.zeros((2, 2)), np.zeros((0, 2, 2))


def _row_kernels(backend: str) -> SimpleNamespace:
    """The extent step's kernels over array-held states for ``backend``, the one place that
    chooses their form: the per-scan steps (:mod:`radarslam.extent.rows`, the visible arc's and the
    partial view's) compiled under numba (:mod:`radarslam.extent._compiled`), as Python otherwise;
    the bookkeeping that runs once in a landmark's life (a.3's buffering and initialisation, a
    merge) as Python under both, a handful of small loops that would cost a first run on a fresh
    machine seconds of compilation for microseconds of work."""
    from radarslam.extent import arc_kernels, rows, view_kernels

    if backend == "numba":
        from radarslam.extent import _compiled as scan
    else:
        scan = SimpleNamespace(rma_efa_rows=rows.rma_efa_rows, sliding_efa_rows=rows.sliding_efa_rows,
                               mem_ekf_rows=rows.mem_ekf_rows,
                               arc_widths_rows=arc_kernels.arc_widths_rows, view_rows=view_kernels.view_rows)
    return SimpleNamespace(buffer_need=rows.buffer_need, initialise_rows=rows.initialise_rows,
                           mem_ekf_initialise_rows=rows.mem_ekf_initialise_rows, merge_rows=rows.merge_rows,
                           rma_efa_rows=scan.rma_efa_rows, sliding_efa_rows=scan.sliding_efa_rows,
                           mem_ekf_rows=scan.mem_ekf_rows,
                           arc_widths_rows=scan.arc_widths_rows, view_rows=scan.view_rows)


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


