"""The EKF-SLAM orchestrator with APSIPA landmark management and landmark extents.

:class:`EkfSlam` holds the state and calls the pure functions of :mod:`radarslam.slam.ekf`,
:mod:`radarslam.landmarks` and :mod:`radarslam.extent` in the order of method.md a.8:

1. prediction with the odometer (:meth:`EkfSlam.predict`);
2-4. sifting, then sequential log-distance association and EKF point updates;
5. M/N windows and removal;
6. the extent step (RM prediction + update, EFA refit; or buffering until initialisation);
7. DBSCAN of the unsifted detections, alpha test;
8-9. Rule 2 / Rule 1 confirmation and state augmentation;
10. merging.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from radarslam.config import Config
from radarslam.core.angles import wrap_pi_scalar
from radarslam.core.errors import InputError
from radarslam.core.types import Odometry, Scan
from radarslam.core.validation import as_array
# The SLAM loop calls the extent kernels directly: its inputs are already validated, and the
# public wrappers' PSD checks cost 30-75 us per call (an eigen-solve per matrix).
from radarslam.extent.ellipse_fit import _fit_ellipse
from radarslam.extent.measurement import _scan_W
from radarslam.extent.random_matrix import _rm_predict, _rm_update
from radarslam.landmarks.clustering import clusters_of, dbscan_labels
from radarslam.landmarks.confirmation import Tentative, push_bit, rule2_step, should_remove
from radarslam.landmarks.merging import next_merge
from radarslam.landmarks.sifting import sift
from radarslam.models.motion import MotionModel, get_motion_model
from radarslam.models.radar import polar_to_xy
from radarslam.slam import ekf


@dataclass
class ExtentState:
    """Extent record of one landmark, kept outside the EKF state (method.md a.1).

    Before initialisation only ``buffer`` is used; afterwards ``X``/``alpha`` are the RMA estimate
    and ``X_efa`` the EFA baseline.
    """

    buffer: list[np.ndarray] = field(default_factory=list)
    n_buffered: int = 0
    X: np.ndarray | None = None
    alpha: float = 0.0
    X_efa: np.ndarray | None = None
    efa_buffer: list[np.ndarray] = field(default_factory=list)
    initialized_at: int | None = None

    @property
    def initialized(self) -> bool:
        return self.X is not None


@dataclass
class LandmarkRecord:
    """Bookkeeping of one confirmed landmark (its centroid lives in the EKF state)."""

    id: int
    created: int
    assoc: int = 1  # M/N windows, newest-first bits; [1, 0, ..., 0] at creation (c.5)
    in_range: int = 1
    extent: ExtentState = field(default_factory=ExtentState)


@dataclass(frozen=True)
class ScanReport:
    """What one scan did (for logging and tests)."""

    index: int
    n_detections: int
    n_candidates: int
    n_associated: int
    associations: dict[int, np.ndarray]  # landmark id -> detection indices
    removed: list[int]
    confirmed: list[int]
    merged: list[tuple[int, int]]  # (kept id, dropped id)
    n_clusters: int
    n_tentative: int


@dataclass(frozen=True)
class MapSnapshot:
    """The map after a scan: ids ``(N,)``, centroids ``(N, 2)``, covariances ``(N, 2, 2)``,
    RMA and EFA extents ``(N, 2, 2)`` (NaN where not initialised), creation scans ``(N,)``."""

    ids: np.ndarray
    positions: np.ndarray
    covs: np.ndarray
    rma: np.ndarray
    efa: np.ndarray
    created: np.ndarray


class EkfSlam:
    """EKF-SLAM of the pose and landmark centroids with landmark management and extents.

    Parameters
    ----------
    config : Config
        Uses ``filter``, ``landmarks`` and ``extent``.
    motion_model : MotionModel, optional
        Defaults to ``get_motion_model(config.filter.motion_model)``.
    """

    def __init__(self, config: Config, motion_model: MotionModel | None = None):
        self.config = config
        f = config.filter
        self.model = motion_model or get_motion_model(f.motion_model, **f.motion_model_kwargs())
        self.R = f.R
        self.R_extent = config.extent.R(self.R)
        self.U = f.U
        self.Q = f.Q
        self.x = np.array(f.initial_pose, dtype=float)
        self.P = np.diag(np.square(f.initial_pose_std))
        self.landmarks: list[LandmarkRecord] = []
        self.tentatives: list[Tentative] = []
        self._next_id = 0
        self._dt_since_scan = 0.0
        self._scans = 0
        self._associate_compiled = None
        self._min_log_distance_compiled = None
        if f.backend == "numba":
            try:
                from radarslam.slam._numba import associate_scan, min_log_distance
            except ImportError:
                raise InputError("filter.backend: 'numba' needs numba; pip install 'radarslam[fast]'") from None
            self._associate_compiled = associate_scan
            self._min_log_distance_compiled = min_log_distance

    # ------------------------------------------------------------------ views
    @property
    def pose(self) -> np.ndarray:
        return self.x[:3].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        return self.P[:3, :3].copy()

    @property
    def landmark_positions(self) -> np.ndarray:
        return self.x[3:].reshape(-1, 2).copy()

    def snapshot(self) -> MapSnapshot:
        """The current map (copies)."""
        n = len(self.landmarks)
        idx = 3 + 2 * np.arange(n)
        covs = np.empty((n, 2, 2))
        covs[:, 0, 0] = self.P[idx, idx]
        covs[:, 0, 1] = covs[:, 1, 0] = self.P[idx, idx + 1]
        covs[:, 1, 1] = self.P[idx + 1, idx + 1]
        nan = np.full((2, 2), np.nan)
        return MapSnapshot(
            ids=np.array([r.id for r in self.landmarks], dtype=int),
            positions=self.landmark_positions,
            covs=covs,
            rma=np.array([r.extent.X if r.extent.X is not None else nan for r in self.landmarks]).reshape(n, 2, 2),
            efa=np.array([r.extent.X_efa if r.extent.X_efa is not None else nan for r in self.landmarks]).reshape(n, 2, 2),
            created=np.array([r.created for r in self.landmarks], dtype=int),
        )

    # ------------------------------------------------------------------ events
    def process(self, event: Odometry | Scan) -> ScanReport | None:
        """Dispatch one event of the stream."""
        if isinstance(event, Odometry):
            self.predict(event)
            return None
        if isinstance(event, Scan):
            return self.update(event)
        raise InputError(f"event: expected Odometry or Scan, got {type(event).__name__}")

    def predict(self, odo: Odometry) -> None:
        """EKF prediction with one odometer reading (method.md c.2)."""
        u = as_array("odometry.control", odo.control, (2,))
        if not (math.isfinite(odo.dt) and odo.dt > 0):
            raise InputError(f"odometry.dt: expected a finite value > 0, got {odo.dt!r}")
        self.x, self.P = ekf.predict(self.x, self.P, u, odo.dt, self.model, self.U, self.Q)
        self._dt_since_scan += odo.dt

    def update(self, scan: Scan) -> ScanReport:
        """Process one scan (method.md a.8 steps 2-10). An empty scan still ages the M/N windows."""
        polar = np.asarray(scan.polar, dtype=float)
        if polar.size == 0:
            polar = np.empty((0, 2))
        polar = as_array("scan.polar", polar, (None, 2))
        if np.any(polar[:, 0] < 0):
            raise InputError(f"scan.polar: expected ranges >= 0, got min {polar[:, 0].min()}")
        k = scan.index
        lc, ec = self.config.landmarks, self.config.extent
        use_ext = ec.use_in_slam
        dt_ext = self._dt_since_scan if self._scans else 0.0
        self._dt_since_scan = 0.0
        self._scans += 1

        # Snapshot of the prior (Decision 3); the pure ekf functions never mutate x or P.
        x_prior, P_prior = self.x, self.P
        ids_prior = {r.id: j for j, r in enumerate(self.landmarks)}

        # 3. Sifting with the predicted pose.
        m = polar.shape[0]
        L = self.x[3:].reshape(-1, 2)
        xy_pred = polar_to_xy(self.x[:3], polar)
        ext_inv, has_ext = None, None
        if use_ext and ec.contour_sifting and self.landmarks:
            has_ext = np.array([r.extent.initialized for r in self.landmarks])
            Xs = np.array([r.extent.X if r.extent.initialized else np.eye(2) for r in self.landmarks])
            # closed-form 2 x 2 inverses (X is SPD with eigenvalues >= eig_floor)
            det = Xs[:, 0, 0] * Xs[:, 1, 1] - Xs[:, 0, 1] * Xs[:, 1, 0]
            ext_inv = np.stack([np.stack([Xs[:, 1, 1], -Xs[:, 0, 1]], -1),
                                np.stack([-Xs[:, 1, 0], Xs[:, 0, 0]], -1)], 1) / det[:, None, None]
        cand = sift(xy_pred, L, lc.sift_radius_m, ext_inv, has_ext, ec.kappa)

        # 4. Sequential association and EKF point updates.
        assoc: list[list[int]] = [[] for _ in self.landmarks]
        if self._associate_compiled is not None and self.landmarks:
            self._associate_compiled_scan(polar, np.flatnonzero(cand), assoc)
        else:
            for i in np.flatnonzero(cand):
                j, D, e, Hs, idx, Rj = self._best_match(polar[i], lc.n_nearest_assoc)
                if j >= 0 and D < lc.beta:
                    self.x, self.P = ekf.update(self.x, self.P, e, Hs, idx, Rj)
                    assoc[j].append(int(i))
        n_assoc = sum(len(a) for a in assoc)
        associations = {r.id: np.array(a, dtype=int) for r, a in zip(self.landmarks, assoc) if a}

        # 5. M/N windows and removal (every scan, Decision 8).
        pos = self.x[:2]
        L = self.x[3:].reshape(-1, 2)
        half_fov = math.radians(self.config.filter.field_of_view_deg) / 2.0
        drop = []
        for j, r in enumerate(self.landmarks):
            hit = bool(assoc[j])
            dx, dy = L[j, 0] - pos[0], L[j, 1] - pos[1]
            # in range: within R_max and, for a sensor that does not see all around, within its field of view
            near = hit or (math.hypot(dx, dy) <= self.config.filter.max_range_m
                           and (half_fov >= math.pi or abs(wrap_pi_scalar(math.atan2(dy, dx) - self.x[2])) <= half_fov))
            r.assoc = push_bit(r.assoc, hit, lc.removal_window)
            r.in_range = push_bit(r.in_range, near, lc.removal_window)
            if should_remove(k, r.created, r.assoc, r.in_range, window=lc.removal_window, max_hits=lc.removal_max_hits):
                drop.append(j)
        removed = [self.landmarks[j].id for j in drop]
        if drop:
            self.x, self.P = ekf.remove_landmarks(self.x, self.P, drop)
            keep = [j for j in range(len(self.landmarks)) if j not in set(drop)]
            self.landmarks = [self.landmarks[j] for j in keep]
            assoc = [assoc[j] for j in keep]

        # The scan in the world frame with the updated pose, for steps 6-9 (seed eq. 3).
        xy_upd = polar_to_xy(self.x[:3], polar)

        # 6. Extent step.
        if ec.track:
            for j, r in enumerate(self.landmarks):
                jp = ids_prior[r.id]
                ip = 3 + 2 * jp
                if ec.use_posterior_landmark:
                    c, C = self.x[3 + 2 * j: 5 + 2 * j], self.P[3 + 2 * j: 5 + 2 * j, 3 + 2 * j: 5 + 2 * j]
                else:
                    c, C = x_prior[ip: ip + 2], P_prior[ip: ip + 2, ip: ip + 2]
                self._extent_step(r, polar[assoc[j]], xy_upd[assoc[j]], c, C, dt_ext, k)

        # 7. Clustering of Z \ Z^s and the alpha test.
        rest = np.flatnonzero(~cand)
        clusters = []
        if rest.size >= lc.cluster_min_samples:
            xy_rest = xy_upd[rest]
            labels = dbscan_labels(xy_rest, lc.cluster_eps_m, lc.cluster_min_samples)
            clusters = clusters_of(polar[rest], xy_rest, labels, rest)
        fresh = [c for c in clusters if self._min_log_distance(c.centre_polar, lc.n_nearest_new) > lc.alpha]

        # 8-9. Rule 2 / Rule 1 confirmation and augmentation.
        confirmed, self.tentatives = rule2_step(
            self.tentatives, fresh, gate=lc.tentative_gate_m, confirm_points=lc.confirm_points,
            window=lc.confirm_window, hits=lc.confirm_hits)
        new_ids = []
        for c in confirmed:
            self.x, self.P = ekf.augment(self.x, self.P, c.centre_polar, self.R)
            self.landmarks.append(LandmarkRecord(self._next_id, k))
            new_ids.append(self._next_id)
            self._next_id += 1

        # 10. Merging.
        merged = self._merge()

        return ScanReport(k, m, int(cand.sum()), n_assoc, associations, removed, new_ids, merged,
                          len(clusters), len(self.tentatives))

    # ------------------------------------------------------------------ pieces
    def _associate_compiled_scan(self, polar: np.ndarray, cand: np.ndarray, assoc: list[list[int]]) -> None:
        """Step 4 with the compiled loop (``filter.backend = "numba"``)."""
        ec, lc = self.config.extent, self.config.landmarks
        N = len(self.landmarks)
        gX = np.zeros((N, 2, 2))
        has = np.zeros(N, dtype=np.bool_)
        if ec.use_in_slam and ec.inflate_noise:
            for j, r in enumerate(self.landmarks):
                if r.extent.X is not None:
                    gX[j] = ec.gamma_z * r.extent.X
                    has[j] = True
        x, P = self.x.copy(), self.P.copy()
        out = self._associate_compiled(x, P, polar, cand, self.R, gX, has, lc.n_nearest_assoc, lc.beta)
        self.x, self.P = x, P
        for i, j in zip(cand.tolist(), out.tolist()):
            if j >= 0:
                assoc[j].append(i)

    def _noise(self, j: int, Hp: np.ndarray, extent: bool = True) -> np.ndarray:
        """R, or R_eff = R + H_p (gamma_z X) H_p^T for a landmark with extent (a.7.2).

        ``extent=False`` forces R: the new-cluster alpha test (c.6) is not part of a.7.2, which
        inflates the noise only in the association test and the EKF update.
        """
        ec = self.config.extent
        X = self.landmarks[j].extent.X
        if extent and ec.use_in_slam and ec.inflate_noise and X is not None:
            return self.R + ec.gamma_z * (Hp @ X @ Hp.T)
        return self.R

    def _nearest(self, s: np.ndarray, count: int, xs: list[float] | None = None) -> list[int]:
        """Indices of the ``count`` landmarks Euclidean-nearest to detection ``s`` (current pose)."""
        xs = self.x.tolist() if xs is None else xs
        a = xs[2] + s[1]
        zx, zy = xs[0] + s[0] * math.cos(a), xs[1] + s[0] * math.sin(a)
        d2 = [(lx - zx) ** 2 + (ly - zy) ** 2 for lx, ly in zip(xs[3::2], xs[4::2])]
        return sorted(range(len(d2)), key=d2.__getitem__)[:count]

    def _best_match(self, s: np.ndarray, count: int, extent: bool = True):
        """Landmark of smallest log distance among the ``count`` nearest (c.4), with its update terms.

        Returns ``(j, D, e, Hs, idx, R_j)``; ``j = -1`` and ``D = inf`` without landmarks.
        """
        if not self.landmarks:
            return (-1, math.inf, None, None, None, None)
        xs = self.x.tolist()
        js = self._nearest(s, count, xs)
        ec = self.config.extent
        gX = None
        if extent and ec.use_in_slam and ec.inflate_noise:
            gX = [None if self.landmarks[j].extent.X is None else (ec.gamma_z * self.landmarks[j].extent.X).tolist()
                  for j in js]
        j, D, e = ekf.score_landmarks(self.x, self.P, s, js, self.R, gX, xs)
        if j < 0:
            return (-1, math.inf, None, None, None, None)
        Hs, idx = ekf.sparse_jacobian(self.x, j)
        Rj = self._noise(j, Hs[:, 3:], extent)
        return (j, D, np.array(e), Hs, idx, Rj)

    def _min_log_distance(self, s: np.ndarray, count: int) -> float:
        """Smallest log distance of detection ``s`` to its ``count`` nearest landmarks; inf if none.

        Used by the alpha test of c.6, always with the plain R (see :meth:`_noise`).
        """
        if self._min_log_distance_compiled is not None:
            return float(self._min_log_distance_compiled(self.x, self.P, float(s[0]), float(s[1]), count, self.R))
        return self._best_match(s, count, extent=False)[1]

    def _extent_step(self, r: LandmarkRecord, polar: np.ndarray, pts: np.ndarray, centroid: np.ndarray,
                     centroid_cov: np.ndarray, dt: float, k: int) -> None:
        """a.3-a.5 for one landmark; ``polar`` are this scan's associated detections and ``pts``
        the same converted with the updated pose."""
        ec = self.config.extent
        st = r.extent
        m = polar.shape[0]
        if not st.initialized:
            if m:
                st.buffer.append(pts)
                st.n_buffered += m
            if st.n_buffered > ec.n_init:
                fit = _fit_ellipse(np.concatenate(st.buffer), upper_bound=True)
                if fit:
                    st.X = fit[1]
                    st.alpha = ec.alpha0
                    st.X_efa = fit[1].copy()
                    st.initialized_at = k
                    st.efa_buffer = [np.concatenate(st.buffer)[-ec.efa_window:]]
                    st.buffer = []
                else:  # degenerate geometry: keep only the newest points and wait
                    st.buffer = [np.concatenate(st.buffer)[-ec.n_init:]]
                    st.n_buffered = st.buffer[0].shape[0]
            return
        if dt > 0.0:
            st.X, st.alpha = _rm_predict(st.X, st.alpha, dt, ec.tau_s)
        if m == 0:
            return
        W = _scan_W(self.x[:3], self.P[:3, :3], polar, self.R_extent, ec.w_mode)  # seed eq. (5), h.3
        st.X, st.alpha = _rm_update(st.X, st.alpha, centroid, centroid_cov, pts, W, ec.gamma_z, ec.eig_floor_m2)
        if ec.efa_mode == "sliding":
            data = np.concatenate(st.efa_buffer + [pts])[-ec.efa_window:]
            st.efa_buffer = [data]
        else:
            data = pts
        if data.shape[0] >= 3:
            fit = _fit_ellipse(data, not ec.efa_noise_correct, W if ec.efa_noise_correct else None)
            if fit:
                st.X_efa = fit[1]

    def _merge(self) -> list[tuple[int, int]]:
        """c.9: repeatedly drop the later-created landmark of the closest eligible pair."""
        lc = self.config.landmarks
        merged: list[tuple[int, int]] = []
        while len(self.landmarks) >= 2 and (lc.merge_max_per_scan == 0 or len(merged) < lc.merge_max_per_scan):
            pair = next_merge(self.x[3:].reshape(-1, 2), np.array([r.created for r in self.landmarks]),
                              np.array([r.id for r in self.landmarks]), lc.merge_distance_m, lc.merge_axis_tol_m)
            if pair is None:
                break
            keep, drop = pair
            survivor, gone = self.landmarks[keep], self.landmarks[drop]
            if not survivor.extent.initialized and gone.extent.initialized:
                survivor.extent = gone.extent  # c.9 [PROP]: the extent follows the merge
            elif not survivor.extent.initialized and not gone.extent.initialized:
                survivor.extent.buffer += gone.extent.buffer  # [PROP]: pool the pre-init detections
                survivor.extent.n_buffered += gone.extent.n_buffered
            self.x, self.P = ekf.remove_landmarks(self.x, self.P, [drop])
            del self.landmarks[drop]
            merged.append((survivor.id, gone.id))
        return merged
