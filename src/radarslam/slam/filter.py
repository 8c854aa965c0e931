"""The EKF-SLAM filter as an object: :class:`EkfSlam` builds the filter's components from the configuration
and runs the events one at a time through the fused engine (slam/per_event.py), the steps of docs/method.md
a.8 written once in ``slam/fused/``.

:class:`EkfSlam` holds a :class:`~radarslam.slam.state.SlamState`, read back from the engine after every
event, and its components, each built by its registered factory from the configuration
(docs/architecture.md):

- the motion model (``filter.motion_model``) and the measurement model (``filter.measurement_model``);
- the associator (``landmarks.associator``);
- the extent estimator (``extent.estimator``).

A component of the user's own runs in Python within the engine's steps form (slam/fused/own.py).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from radarslam.config import Config, EstimatorConfig
from radarslam.core.errors import ConfigError, InputError
from radarslam.core.registry import ASSOCIATORS, EXTENT_ESTIMATORS
from radarslam.core.types import Odometry, Scan
from radarslam.models.body_velocity import BodyVelocityModel
from radarslam.models.motion import MotionModel, motion_model_from_config
from radarslam.models.radar import RangeAzimuthModel
from radarslam.slam.association import Associator
from radarslam.slam.bias import (bias_states, control_noise, initial_state, measurement_noise, turn_noise_gain2,
                                 turn_noise_index)
from radarslam.slam.doppler_gate import DopplerGate
from radarslam.slam.layout import POSE_DIM
from radarslam.slam.map_rows import MapSnapshot, state_rows
from radarslam.slam.odometry_source import odometry_source
from radarslam.slam.partial_view import view_components
from radarslam.slam.per_event import check_components, engine_for, read_back, write_through
from radarslam.slam.radar_time import radar_time_states
from radarslam.slam.radar_yaw import radar_yaw_states
from radarslam.slam.report import ScanReport
from radarslam.slam.state import Landmark
from radarslam.slam.view_offset import view_offset_k

__all__ = ["ENGINES", "EkfSlam", "Landmark", "MapSnapshot", "ScanReport"]

#: ``engine`` of :class:`EkfSlam`: the configuration's form of the fused engine, or one named.
ENGINES = ("auto", "compiled", "steps", "python")


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
    engine : {"auto", "compiled", "steps", "python"}
        The form of the fused engine that runs the events one at a time (slam/per_event.py
        ``engine_for``: the function a whole stream runs through, the state read back after every
        event; slam/fused/engine.py ``form``): ``"auto"`` the configuration's (compiled; the steps
        form under ``filter.fused`` false or with a component of the user's own; the Python form
        under ``filter.backend`` python), or the one named.
    """

    def __init__(self, config: EstimatorConfig | Config, *, motion_model: MotionModel | None = None,
                 associator: Associator | None = None, extent_estimator=None, engine: str = "auto"):
        if engine not in ENGINES:
            raise InputError(f"engine: expected one of {', '.join(ENGINES)}, got {engine!r}")
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
        if self.fej:
            self._check_fej(config)
        self._scans = 0
        self._last_scan_t: float | None = None
        #: filter.doppler_gate: moving objects kept out of the map (c.10.4), else None.
        self._gate = DopplerGate(f, config.mounting) if f.doppler_gate else None
        #: filter.odometry "doppler"/"both": the Doppler-and-gyro prediction driver (c.10.5), else None.
        self._odometry = odometry_source(self)
        check_components(self)
        #: The fused engine one event at a time (slam/per_event.py), built at the first event.
        self._online, self._form = None, engine
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
        return state_rows(self.state, self.extent)                     # before the first scan

    # ------------------------------------------------------------------ events
    def process(self, event: Odometry | Scan) -> ScanReport | None:
        """Run one event of the stream through the engine; a scan's :class:`ScanReport`, None for a reading.

        Raises
        ------
        InputError
            Before any change, for an event that is neither a reading nor a scan, non-numeric or
            non-finite values, a non-positive ``dt``, negative ranges or a scan earlier than the
            previous one; for an event that makes the state non-finite (the state is then left as it
            was before a reading; after a scan the filter is not to be used further).
        """
        if not isinstance(event, (Odometry, Scan)):
            raise InputError(f"event: expected Odometry or Scan, got {type(event).__name__}")
        if self._online is None:
            self._online = engine_for(self, self._form)
        write_through(self, self._online)
        self._online.process(event)
        scan = isinstance(event, Scan)
        read_back(self, self._online, int(event.index) if scan else None)
        return self._online.report if scan else None

    def predict(self, odo: Odometry) -> None:
        """EKF prediction with one odometer reading (docs/method.md c.2); :meth:`process` of a reading."""
        if self._odometry is not None:
            raise ConfigError(f"filter.odometry: expected 'odometer' for EkfSlam.predict, got "
                              f"{self.config.filter.odometry!r} (feed the events to EkfSlam.process; c.10.5)")
        if not isinstance(odo, Odometry):
            raise InputError(f"odo: expected Odometry, got {type(odo).__name__}")
        self.process(odo)

    def update(self, scan: Scan) -> ScanReport:
        """Process one scan (docs/method.md a.8 steps 2-10); :meth:`process` of a scan. An empty scan
        still ages the M/N windows."""
        if not isinstance(scan, Scan):
            raise InputError(f"scan: expected Scan, got {type(scan).__name__}")
        return self.process(scan)


def _readonly(a: np.ndarray) -> np.ndarray:
    v = a.view()
    v.flags.writeable = False
    return v
