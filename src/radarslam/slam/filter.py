"""The EKF-SLAM orchestrator: the steps of the method, one named call each.

:class:`EkfSlam` holds a :class:`~radarslam.slam.state.SlamState` and its components, each built by
its registered factory from the configuration (docs/architecture.md):

- the motion model (``filter.motion_model``) and the measurement model (``filter.measurement_model``);
- the associator (``landmarks.associator``, in the ``filter.backend`` implementation);
- the extent estimator (``extent.estimator``).

:meth:`EkfSlam.update` runs docs/method.md a.8 on one scan: sift; associate and update; M/N
bookkeeping and removal; extent step; cluster; alpha test; confirm and augment; merge. The
arithmetic lives in the modules that own it (:mod:`.ekf`, :mod:`radarslam.landmarks`,
:mod:`radarslam.extent`), not here.
"""

from __future__ import annotations

import dataclasses

import math

import numpy as np

from radarslam.config import Config, EstimatorConfig
from radarslam.core.errors import ConfigError, InputError
from radarslam.core.registry import ASSOCIATORS, EXTENT_ESTIMATORS
from radarslam.models.radar import RangeAzimuthModel
from radarslam.core.types import Odometry, Scan
from radarslam.landmarks.clustering import Cluster
from radarslam.landmarks.steps import next_merge, removal_step, rule2_step
from radarslam.landmarks.sifting import sift
from radarslam.models.body_velocity import BodyVelocityModel
from radarslam.models.motion import MotionModel, motion_model_from_config
from radarslam.slam import ekf
from radarslam.slam.association import Associator, Spreads
from radarslam.slam.bias import (bias_states, control_noise, initial_state, measurement_noise, predict_terms,
                                 turn_noise, turn_noise_gain2, turn_noise_index)
from radarslam.core.mounting import ORIGIN
from radarslam.slam.doppler_gate import DopplerGate
from radarslam.slam import consider, sensor_frame
from radarslam.slam.radar_time import pose_rate, radar_time_states
from radarslam.slam.radar_yaw import radar_yaw_states
from radarslam.slam.scan_frame import NO_FRAME, frame_args, measured_from, rehold
from radarslam.slam.view_offset import view_offset_k
from radarslam.slam.map_rows import MapSnapshot, RetiredMap, retire_radius, state_rows
from radarslam.core.validation import as_array
from radarslam.slam.event_input import check_finite, finite_number, scan_polar
from radarslam.slam.layout import POSE_DIM
from radarslam.slam.kernels import cluster_kernel as _cluster_kernel, step_kernels as _step_kernels
from radarslam.slam.odometry_source import odometry_source
from radarslam.slam.partial_view import view_components, view_corrected_centroid, view_walk
from radarslam.slam.per_event import engine_for, read_back, write_through
from radarslam.slam.report import ScanReport
from radarslam.slam.state import Landmark

__all__ = ["EkfSlam", "Landmark", "MapSnapshot", "ScanReport"]


class EkfSlam:
    """EKF-SLAM of the pose and landmark centroids with landmark management and extents.

    Parameters
    ----------
    config : EstimatorConfig or Config
        The ``filter``, ``landmarks`` and ``extent`` sections (a full :class:`Config` is accepted
        and only those sections are kept).
    motion_model, associator, extent_estimator : optional
        Components to use instead of the ones the configuration names. The measurement model is the
        one built in, range and azimuth (``filter.measurement_model``; docs/architecture.md
        "Measurement model"): the EKF kernels and the associators are written for it.
    engine : {"auto", "orchestrator"}
        What runs the events: ``"auto"``, the fused engine one event at a time where it covers the
        configuration (slam/per_event.py ``engine_for``: the same compiled function a whole stream runs
        through, the state read back after every event), else the orchestrator's steps below;
        ``"orchestrator"``, those steps always (a first run that must not wait for the engine's compile).
    """

    def __init__(self, config: EstimatorConfig | Config, *, motion_model: MotionModel | None = None,
                 associator: Associator | None = None, extent_estimator=None, engine: str = "auto"):
        if engine not in ("auto", "orchestrator"):
            raise InputError(f"engine: expected 'auto' or 'orchestrator', got {engine!r}")
        if isinstance(config, Config):
            config = config.estimator
        if not isinstance(config, EstimatorConfig):
            raise InputError(f"config: expected an EstimatorConfig or Config, got {type(config).__name__}")
        if config.filter.odometry == "auto":          # c.10.5.2: decided by a recording; without one, the odometer
            config = dataclasses.replace(config, filter=dataclasses.replace(config.filter, odometry="odometer"))
        self.config = config
        f = config.filter
        self.model = motion_model or motion_model_from_config(f)
        self.measurement = RangeAzimuthModel()
        #: First-estimates Jacobians (docs/method.md c.2.1): the associators evaluate them.
        self.fej = f.jacobians == "fej"
        try:
            self.associator = associator or ASSOCIATORS.create(config.landmarks.associator, config,
                                                               backend=f.backend)
        except ImportError:
            raise InputError("filter.backend: 'numba' needs numba (a dependency of radarslam: pip install numba), "
                             "or choose filter.backend = 'python'") from None
        self.extent = extent_estimator or EXTENT_ESTIMATORS.create(config.extent.estimator, config)
        #: Q_v of the partial-view model (docs/method.md a.12; its estimator and associator then
        #: replace the defaults), or None for the full view.
        self.view, self.extent, self.associator = view_components(config, self.extent, self.associator,
                                                                  extent_estimator is None, associator is None)
        #: c.17: the part in view's offset, added once to a landmark's mean detection's noise (0: none).
        self._offset_k = view_offset_k(config, self.view is not None)
        self._clusters = _cluster_kernel(f.backend)
        self._candidates, self._group, self._in_view = _step_kernels(f.backend)
        self.R = self.measurement.noise(f)
        self.U = control_noise(self.model, f)        # c.11.6: white, or the equivalent of correlated errors
        self._turn_k = (turn_noise_index(self.model, f), turn_noise_gain2(f))   # c.11.8: U grows with the turn
        self.R_assoc = measurement_noise(self.R, f)  # c.11.9: R of association and update
        self.Q = f.Q
        #: U's stds and Q's variances are those of a reading over this interval (c.2.2).
        self._noise_ref = float(f.noise_interval_s)
        #: The odometry-bias states (docs/method.md c.11) under filter.odometry_bias "states", else None.
        #: They belong to the model that drives the prediction: the body-velocity model under Doppler odometry.
        self.bias_model = bias_states(self.model if f.odometry == "odometer" else BodyVelocityModel(), f,
                                      radar_yaw_states(config), radar_time_states(config))   # c.13.1-2, if asked
        self.state = initial_state(f, self.bias_model)
        #: c.13.4: the end of the block held by the Schmidt-Kalman update (filter.car_states "consider": every
        #: platform state after the pose), POSE_DIM when nothing is held.
        self.held_end = self.state.platform_dim if f.car_states == "consider" else POSE_DIM
        #: FEJ: the first estimate of the current pose (the last prediction, or the initial pose).
        self._pose_first = self.state.pose if self.fej else None
        if self.fej:
            self._check_fej(config)
        self._dt_since_scan = 0.0
        self._last_u = None                             # c.13.2: the latest reading, for the pose's rate
        self._view_angle: dict[int, float] = {}        # a.12.5: bearing landmark -> sensor at the last scan
        self._retired = RetiredMap()                    # c.15: the landmarks retired from the state
        self._scans = 0
        self._last_scan_t: float | None = None
        self._view = (f.max_range_m, math.radians(f.field_of_view_deg) / 2)   # the M/N view test's (c.13)
        #: filter.doppler_gate: moving objects kept out of the map (c.10.4), else None.
        self._gate = DopplerGate(f, config.mounting) if f.doppler_gate else None
        #: filter.odometry "doppler"/"both": the Doppler-and-gyro prediction driver (c.10.5), else None.
        self._odometry = odometry_source(self)
        #: The fused engine one event at a time (slam/per_event.py), chosen at the first event; None: the steps below.
        self._online, self._engine_asked = None, engine == "orchestrator"
        self._initialized_at: dict[int, int] = {}      # landmark id -> the scan its extent was first seen set up

    def _check_fej(self, config: EstimatorConfig) -> None:
        """Refuse first-estimates Jacobians (c.2.1) where they are not built: a motion model whose
        step is not a position increment independent of the position (``se2_increment``: the
        unicycle, Ackermann and body-velocity models are), an associator that does not evaluate
        them, or the partial view."""
        got = None
        if not getattr(self.model, "se2_increment", False):
            got = f"motion model {config.filter.motion_model!r}"
        elif not getattr(self.associator, "fej", False):
            got = f"associator {config.landmarks.associator!r}"
        elif self.view is not None:
            got = "the partial-view model (extent.view_model)"
        if got is not None:
            raise ConfigError(f"filter.jacobians: expected 'standard' with {got} (first estimates are built for the "
                              f"unicycle, Ackermann or body-velocity model with nearest-neighbour, batch or "
                              f"batch-joint, full view), got 'fej'")

    # ------------------------------------------------------------------ views
    @property
    def x(self) -> np.ndarray:
        """The state mean (read-only view; change it through :attr:`state`)."""
        return _readonly(self.state.x)

    @property
    def P(self) -> np.ndarray:
        """The state covariance (read-only view)."""
        return _readonly(self.state.P)

    @property
    def landmarks(self) -> list[Landmark]:
        return self.state.landmarks

    @property
    def tentatives(self):
        return self.state.tentatives

    @property
    def pose(self) -> np.ndarray:
        return self.state.pose

    @property
    def pose_cov(self) -> np.ndarray:
        return self.state.pose_cov

    @property
    def landmark_positions(self) -> np.ndarray:
        return self.state.positions

    @property
    def bias(self) -> np.ndarray:
        """The odometry-bias states ``(m,)`` (c.11; names in ``self.bias_model.names``); empty without them."""
        return self.state.bias

    def snapshot(self) -> MapSnapshot:
        """The current map (copies): the landmarks of the state, then those retired from it (c.15)."""
        if self._online is not None and self._online.maps is not None:
            m = self._online.maps
            return MapSnapshot(m.ids.copy(), m.pos.copy(), m.cov.copy(), m.rma.copy(), m.efa.copy(), m.created.copy())
        return self._retired.after(state_rows(self.state, self.extent))

    def _engine(self):
        """The fused engine this filter's events run through (decided at the first event), or None."""
        if not self._engine_asked:
            self._engine_asked = True
            if self._scans == 0 and self.state.n_landmarks == 0:
                self._online = engine_for(self)
        return self._online

    def _through_engine(self, event) -> ScanReport | None:
        """``event`` run by the fused engine, the state read back (slam/per_event.py)."""
        if not isinstance(event, (Odometry, Scan)):
            raise InputError(f"event: expected Odometry or Scan, got {type(event).__name__}")
        write_through(self, self._online)
        self._online.process(event)
        scan = isinstance(event, Scan)
        read_back(self, self._online, int(event.index) if scan else None)
        return self._online.report if scan else None

    # ------------------------------------------------------------------ events
    def process(self, event: Odometry | Scan) -> ScanReport | None:
        """Dispatch one event of the stream."""
        if self._engine() is not None:
            return self._through_engine(event)
        if self._odometry is not None:                 # c.10.5: Doppler and gyro drive the prediction
            return self._odometry.process(self, event)
        if isinstance(event, Odometry):
            self.predict(event)
            return None
        if isinstance(event, Scan):
            return self.update(event)
        raise InputError(f"event: expected Odometry or Scan, got {type(event).__name__}")

    def predict(self, odo: Odometry) -> None:
        """EKF prediction with one odometer reading (docs/method.md c.2).

        Raises
        ------
        InputError
            For a non-finite or non-numeric control, a non-positive ``dt``, or a reading that would
            make the state non-finite (the state is then left as it was).
        """
        if self._odometry is not None:
            raise ConfigError(f"filter.odometry: expected 'odometer' for EkfSlam.predict, got "
                              f"{self.config.filter.odometry!r} (feed the events to EkfSlam.process; c.10.5)")
        if self._engine() is not None:
            self._through_engine(odo)
            return
        u = odo.control
        if not (type(u) is np.ndarray and u.dtype == np.float64 and u.shape == (2,)   # the loaders' form
                and math.isfinite(u[0]) and math.isfinite(u[1])):
            u = as_array("odometry.control", u, (2,))
        dt = finite_number(odo.dt, "odometry.dt")
        if not dt > 0:
            raise InputError(f"odometry.dt: expected a finite value > 0, got {odo.dt!r}")
        st = self.state
        with np.errstate(over="ignore", invalid="ignore"):  # an overflow is reported just below
            U = self.U if self._turn_k[0] is None else turn_noise(self.U, u, *self._turn_k)
            U, Q = ekf.interval_noise(U, self.Q, dt, self._noise_ref)             # c.2.2
            pose, Ppp, Ppl = predict_terms(self.bias_model, st.x, st.P, u, dt, self.model, U, Q,
                                           self._pose_first)
        # only the pose rows change (c.2): check them, then write them in place (O(N), no copy of P)
        if not (np.isfinite(pose).all() and np.isfinite(Ppp).all() and np.isfinite(Ppl).all()):
            check_finite(pose, np.concatenate([Ppp.ravel(), Ppl.ravel()]),
                          f"odometry at t={odo.t!r} (control {u.tolist()}, dt {dt!r})")
        ekf.apply_prediction(st.x, st.P, pose, Ppp, Ppl)
        if self.fej:
            self._pose_first = pose[:3].copy()  # the first estimate of the new pose (c.2.1; pose: the platform block)
        self._dt_since_scan += dt
        self._last_u = u

    def update(self, scan: Scan) -> ScanReport:
        """Process one scan (docs/method.md a.8 steps 2-10). An empty scan still ages the M/N windows.

        Raises
        ------
        InputError
            Before any change, for non-numeric or non-finite detections, negative ranges, or a
            scan time earlier than the previous scan's; after the steps, if the scan made the state
            non-finite (the filter is then not to be used further).
        """
        if self._engine() is not None:
            return self._through_engine(scan)
        polar = scan_polar(scan)
        t = finite_number(scan.t, "scan.t")
        if self._last_scan_t is not None and t < self._last_scan_t:
            raise InputError(f"scan.t: expected scan times that do not go backwards, got {t!r} after "
                             f"{self._last_scan_t!r} (scan {scan.index})")
        self._last_scan_t = t
        mount = sensor_frame.scan_mounting(scan.sensor)
        sen = scan.sensor
        f = self.config.filter
        self._view = (f.max_range_m if sen is None or sen.max_range_m is None else sen.max_range_m,
                      math.radians(f.field_of_view_deg) / 2 if sen is None or sen.fov_rad is None else sen.fov_rad / 2)
        self._held = consider.held(self.state.x, self.state.P, POSE_DIM, self.held_end)   # c.13.4
        self._frame = None
        report = self._measured(scan, polar, mount, sen)
        consider.restore(self.state.x, self.state.P, *self._held, POSE_DIM)                 # c.13.4
        return report

    def _measured(self, scan: Scan, polar: np.ndarray, mount, sen) -> ScanReport:
        """:meth:`_steps` with the state's pose block the scan's radar's at its measurement (c.13-c.13.2)."""
        bm = self.bias_model
        yaw, tau = (None, None) if sen is None or bm is None else (bm.yaw_index(sen.sensor_id), bm.time_index(sen.sensor_id))
        if mount is None and yaw is None and tau is None:
            return self._steps(scan, polar, mount)
        mount, first = mount or ORIGIN, self._pose_first  # c.13-c.13.2: the scan from its radar at its time
        rate = None if tau is None else pose_rate(bm, self.model, self.state.x, self._last_u)
        self._frame = frame_args(mount, yaw, tau, rate)
        with measured_from(self.state, self._frame, first if self.fej else None) as lin:
            self._pose_first = lin if self.fej else first
            try:
                return self._steps(scan, polar, mount)
            finally:
                self._pose_first = first

    def _steps(self, scan: Scan, polar: np.ndarray, mount) -> ScanReport:
        """a.8 steps 2-10 on one checked scan, the state's pose being the scan's sensor's (c.13)."""
        k = scan.index
        keep, moving, ego = None, np.empty(0, dtype=int), None
        if self._gate is not None:                                        # c.10.4
            keep, moving, ego = self._gate.apply(scan, polar, self.state.pose, None if mount is None else ORIGIN)
            polar = polar[keep]
        dt = self._take_scan_interval()
        if self.view is not None:
            self._view_angle = view_walk(self.state, self._view_angle,
                                         self.config.extent.view_walk_m2_per_rad)    # a.12.5
        prior = self._prior()                                             # Decision 3
        if self.fej:                     # this scan's Jacobians at its predicted pose (c.2.1)
            self.state.lin_pose = self._pose_first.copy()
        cand = self._sift(polar, prior)                                   # 3
        assoc, nis = self._associate_and_update(polar, cand)              # 4
        if self.held_end > POSE_DIM:                                      # c.13.4: back to the held states
            rehold(self.state.x, self.state.P, *self._held, POSE_DIM, self._frame is not None, *(self._frame or NO_FRAME))
        associations = {lid: (np.array(a, dtype=int) if keep is None else keep[a])
                        for lid, a in zip(self.state.ids().tolist(), assoc) if a}
        removed, assoc = self._remove_unseen(assoc, k)                    # 5
        xy = self.measurement.to_world(self.state.pose, polar)            # seed eq. (3), updated pose
        self._extent_step(polar, xy, assoc, prior, dt, k)                 # 6
        clusters = self._cluster(polar, xy, cand)                         # 7
        fresh = self._alpha_test(clusters)                                # 7
        if self._gate is not None:
            fresh = self._gate.veto(fresh, xy)                            # c.10.4.3
        confirmed, members = self._confirm_and_augment(fresh, polar, k)   # 8-9
        merged = self._merge()                                            # 10
        check_finite(self.state.x, self.state.P, f"scan {k} (t={scan.t!r}, {polar.shape[0]} detections)")
        n_assoc = sum(a.size for a in associations.values())
        created = {i: (m if keep is None else keep[m]) for i, m in zip(confirmed, members)}
        return ScanReport(k, polar.shape[0] + moving.size, int(cand.sum()), n_assoc, associations, removed,
                          confirmed, merged, len(clusters), self.state.tentatives.count.shape[0], nis, moving, ego, created)

    # ------------------------------------------------------------------ the steps
    def _take_scan_interval(self) -> float:
        """Time since the previous scan (0 at the first), for the extent prediction (a.4)."""
        dt = self._dt_since_scan if self._scans else 0.0
        self._dt_since_scan = 0.0
        self._scans += 1
        return dt

    def _prior(self):
        """What the extent step needs of the state before the scan's updates (Decision 3), copied
        because the updates work in place: ``(x, the landmarks' 2 x 2 covariance blocks, rows by id)``."""
        st = self.state
        return st.x.copy(), st.position_covs(), st.rows_by_id()

    def _sift(self, polar: np.ndarray, prior) -> np.ndarray:
        """Step 3: candidates for association, with the predicted state (c.3; a.7.1), which is the
        one ``prior`` holds (:meth:`_prior`: its centroids and covariance blocks are reused)."""
        st = self.state
        x_prior, blocks_prior, _ = prior
        xy = self.measurement.to_world(st.pose, polar)
        positions = x_prior[st.platform_dim:].reshape(-1, 2)
        test = None
        if st.n_landmarks:
            test = self.extent.sift(st.extents, xy, polar, positions, blocks_prior,
                                    st.pose, st.pose_cov)
        inside, has = test if test is not None else (None, None)
        return sift(xy, positions, self.config.landmarks.sift_radius_m, inside, has, self._candidates)

    def _associate_and_update(self, polar: np.ndarray, cand: np.ndarray) -> tuple[list[list[int]], np.ndarray]:
        """Step 4: the associator scores the candidates and updates the state (c.4; a.7.2); the
        association of each landmark and the NIS of every update."""
        st = self.state
        assoc: list[list[int]] = [[] for _ in range(st.n_landmarks)]
        if not st.n_landmarks:
            return assoc, np.empty(0)
        candidates = np.flatnonzero(cand)
        states = st.extents
        spreads = Spreads(*self.extent.spreads(states), offset_k=self._offset_k)
        if self.view is not None:
            covs = self.extent.view_shape_covs(states) if self.config.extent.view_shape_uncertainty else None
            spreads = Spreads(spreads.gX, spreads.has, self.extent.view_shapes(states), self.view,
                              None if covs is None else covs[0], None if covs is None else covs[1])
        out, nis = self.associator.associate(st, polar, candidates, self.R_assoc, spreads)
        aoff, arow = self._group(np.asarray(out, dtype=np.int64), candidates, len(assoc))
        return [arow[aoff[j]:aoff[j + 1]].tolist() for j in range(len(assoc))], np.asarray(nis, dtype=float)

    def _remove_unseen(self, assoc: list[list[int]], k: int) -> tuple[list[int], list[list[int]]]:
        """Step 5: M/N windows of every landmark and removal (c.5, Decision 8); under the Doppler
        gate also the young landmarks a moving object was seen on (c.10.4.4)."""
        st, lc = self.state, self.config.landmarks
        view = self._in_view(st.x, st.platform_dim, st.n_landmarks, *self._view)     # the scan's sensor (c.13)
        hit = np.array([bool(a) for a in assoc], dtype=bool)
        drop = removal_step(st.records, hit, view, k, window=lc.removal_window, max_hits=lc.removal_max_hits,
                            compiled=self.config.filter.backend == "numba")
        if self._gate is not None:                                        # c.10.4.4
            drop = sorted(set(drop) | set(self._gate.moving_landmarks(st.positions, st.created(), k)))
        retire = self._retired.select(st, retire_radius(self.config), set(drop))   # c.15, with the lever-arm margin
        if retire:
            self._retired.keep(state_rows(st, self.extent), retire)
        gone = set(drop) | set(retire)
        removed = [lid for lid, _ in st.remove(sorted(gone)) if lid not in self._retired.ids]
        return removed, [a for j, a in enumerate(assoc) if j not in gone]

    def _extent_step(self, polar: np.ndarray, xy: np.ndarray, assoc: list[list[int]], prior, dt: float,
                     k: int) -> None:
        """Step 6: each landmark's extent with this scan's associated detections (a.3-a.5)."""
        st, ext = self.state, self.extent
        if not getattr(ext, "active", True) or not st.n_landmarks:
            return
        if ext.posterior_centroid:
            centroids, covs = st.positions, st.position_covs()
        else:
            x_prior, blocks_prior, rows_prior = prior
            rows = [rows_prior[i] for i in st.ids().tolist()]
            centroids, covs = x_prior[st.platform_dim:].reshape(-1, 2)[rows], blocks_prior[rows]
        states = st.extents
        pose, pose_cov = st.pose, st.pose_cov
        step_all = getattr(ext, "step_all", None)
        if step_all is not None:
            step_all(states, polar, xy, assoc, centroids, covs, pose, pose_cov, dt, k)
            return
        for j, s in enumerate(states):
            ext.step(s, polar[assoc[j]], xy[assoc[j]], centroids[j], covs[j], pose, pose_cov, dt, k)

    def _cluster(self, polar: np.ndarray, xy: np.ndarray, cand: np.ndarray) -> list[Cluster]:
        """Step 7: DBSCAN of the detections no landmark claimed (c.6)."""
        lc = self.config.landmarks
        rest = np.flatnonzero(~cand)
        if rest.size < lc.cluster_min_samples:
            return []
        return self._clusters(polar[rest], xy[rest], rest, lc.cluster_eps_m, lc.cluster_min_samples)

    def _alpha_test(self, clusters: list[Cluster]) -> list[Cluster]:
        """Step 7: keep the clusters farther than ``alpha`` in log distance from every landmark
        (c.6; always with the plain R: a.7.2 inflates only association and update)."""
        alpha = self.config.landmarks.alpha
        return [c for c in clusters if self.associator.min_log_distance(self.state, c.centre_polar, self.R) > alpha]

    def _confirm_and_augment(self, fresh: list[Cluster], polar: np.ndarray,
                             k: int) -> tuple[list[int], list[np.ndarray]]:
        """Steps 8-9: Rule 2 / Rule 1 and state augmentation (c.7, c.8); the new ids and the
        detections (rows of ``polar``) of the cluster each was confirmed from.

        ``landmarks.init = "nearest"``: at the cluster's nearest detection with R (the paper);
        ``"cluster"``: at the mean of its detections with the mean's noise and the extent
        estimator's prior spread."""
        st, lc = self.state, self.config.landmarks
        confirmed, st.tentatives = rule2_step(st.tentatives, fresh, gate=lc.tentative_gate_m,
                                              confirm_points=lc.confirm_points, window=lc.confirm_window,
                                              hits=lc.confirm_hits, compiled=self.config.filter.backend == "numba")
        if lc.init == "cluster":
            spread = self.extent.initial_spread()
            ids = [st.add_landmark_at_mean(polar[c.members], self.R, k, self.extent.new(), spread)
                   for c in confirmed]
            if self.view is not None and self.config.extent.view_init_correct:
                X0 = self.extent.prior_shape()
                for j in range(st.n_landmarks - len(ids), st.n_landmarks):     # a.12.6
                    i = st.index(j)
                    st.x[i:i + 2] = view_corrected_centroid(st.x[i:i + 2].copy(), st.x[:2], X0)
        else:
            ids = [st.add_landmark(c.centre_polar, self.R, k, self.extent.new()) for c in confirmed]
        return ids, [c.members for c in confirmed]

    def _merge(self) -> list[tuple[int, int]]:
        """Step 10 (c.9): repeatedly drop the later-created landmark of the closest eligible pair."""
        st, lc = self.state, self.config.landmarks
        merged: list[tuple[int, int]] = []
        while st.n_landmarks >= 2 and (lc.merge_max_per_scan == 0 or len(merged) < lc.merge_max_per_scan):
            pair = next_merge(st.positions, st.created(), st.ids(), lc.merge_distance_m,
                              lc.merge_axis_tol_m, compiled=self.config.filter.backend == "numba")
            if pair is None:
                break
            keep, drop = pair
            survivor, ((gone, gone_extent),) = int(st.records.ids[keep]), st.remove([drop])
            j = keep - (drop < keep)                                      # the survivor's row now
            st.extents[j] = self.extent.merge(st.extents[j], gone_extent)
            merged.append((survivor, gone))
        return merged


def _readonly(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.flags.writeable = False
    return v
