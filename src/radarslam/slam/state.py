"""The estimator's state: the EKF mean and covariance, the landmark records and the tentatives.

:class:`SlamState` owns ``x``, ``P`` and the bookkeeping beside them, and is the only object that
maps a landmark to its rows of ``x`` and ``P`` (through :mod:`.layout`). The filter
(:class:`~radarslam.slam.filter.EkfSlam`, reading the engine's record back) and the components (associator, extent estimator) read
and replace ``x``/``P`` through it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from radarslam.landmarks.confirmation import Tentatives, no_tentatives
from radarslam.landmarks.records import Records, add_record, compact_records, new_records
from radarslam.slam import ekf
from radarslam.slam.layout import LANDMARK_DIM, POSE_DIM, landmark_index


class Landmark:
    """Landmark ``j`` of a :class:`SlamState`, read through to its arrays (a view: valid until the
    next removal). ``extent`` is the extent estimator's per-landmark state (its own type, see
    :mod:`radarslam.extent.estimator`)."""

    __slots__ = ("_state", "_j")

    def __init__(self, state: "SlamState", j: int):
        self._state, self._j = state, j

    @property
    def id(self) -> int:
        return int(self._state.records.ids[self._j])

    @property
    def created(self) -> int:
        return int(self._state.records.created[self._j])

    @property
    def assoc(self) -> int:
        """The M/N window of associations, newest-first bits (docs/method.md c.5)."""
        return int(self._state.records.mbits[self._j])

    @property
    def in_range(self) -> int:
        """The M/N window of scans in view or associated."""
        return int(self._state.records.rbits[self._j])

    @property
    def first(self) -> np.ndarray:
        """The first estimate [px, py] (m), the centroid when it entered the state: where its
        measurement Jacobian is evaluated under first-estimates Jacobians (docs/method.md c.2.1)."""
        return self._state.records.first[self._j].copy()

    @property
    def extent(self) -> Any:
        return self._state.extents[self._j]

    @extent.setter
    def extent(self, value: Any) -> None:
        self._state.extents[self._j] = value


@dataclass
class SlamState:
    """``x = [x, y, theta, p_1, ..., p_N]`` and ``P``; the landmarks' bookkeeping in state order as
    arrays (:class:`~radarslam.landmarks.records.Records`, rows ``0 .. n_landmarks - 1``, the
    fused engine's own form) with the extent estimator's per-landmark states beside them
    (``extents``); the unconfirmed landmarks of Rule 2, and the next landmark id.

    With odometry-bias states (docs/method.md c.11) the platform block is
    ``[x, y, theta, b_1, ..., b_m]`` and ``platform_dim = 3 + m``; the landmarks follow it."""

    x: np.ndarray
    P: np.ndarray
    records: Records = field(default_factory=lambda: new_records(16))
    extents: list = field(default_factory=list)
    tentatives: Tentatives = field(default_factory=no_tentatives)
    next_id: int = 0
    #: Under first-estimates Jacobians (docs/method.md c.2.1): the pose [x_m, y_m, theta_rad] at
    #: which this scan's measurement Jacobians are evaluated (its prediction); None = the estimate.
    lin_pose: np.ndarray | None = None
    #: Size of the platform block at the head of ``x``: the pose (3) and the bias states (c.11).
    platform_dim: int = POSE_DIM

    @classmethod
    def initial(cls, pose, pose_std, bias=None, bias_std=None) -> "SlamState":
        """No landmarks; the pose ``N(pose, diag(pose_std^2))`` (docs/method.md b.5) and, when
        given, the odometry-bias states ``N(bias, diag(bias_std^2))`` (m,) after it (c.11)."""
        if bias is None:
            return cls(np.array(pose, dtype=float), np.diag(np.square(np.asarray(pose_std, dtype=float))))
        x = np.concatenate([np.asarray(pose, dtype=float), np.asarray(bias, dtype=float)])
        var = np.square(np.concatenate([np.asarray(pose_std, dtype=float), np.asarray(bias_std, dtype=float)]))
        return cls(x, np.diag(var), platform_dim=x.shape[0])

    @classmethod
    def from_mean(cls, x, P, extents=None, platform_dim: int = POSE_DIM) -> "SlamState":
        """A state whose landmarks are all of ``x`` after the platform block: ids ``0 .. N - 1``,
        born at scan 0, first estimates their centroids; ``extents`` (N,) or None for each."""
        x = np.asarray(x, dtype=float)
        n = (x.shape[0] - platform_dim) // 2
        st = cls(x, np.asarray(P, dtype=float), platform_dim=platform_dim, next_id=n)
        for j in range(n):
            i = landmark_index(j, platform_dim)
            st.records = add_record(st.records, j, j, 0, float(x[i]), float(x[i + 1]))
        st.extents = list(extents) if extents is not None else [None] * n
        return st

    def __post_init__(self):
        if not isinstance(self.records, Records):
            raise TypeError(f"records: expected landmarks.records.Records, got {type(self.records).__name__}")

    # ---------------------------------------------------------------- index arithmetic
    def index(self, j: int) -> int:
        """First row of landmark ``j`` in ``x`` and ``P``."""
        return landmark_index(j, self.platform_dim)

    @property
    def n_landmarks(self) -> int:
        """The number of landmarks, the rows of :attr:`records` in use (from ``x``'s size)."""
        return (self.x.shape[0] - self.platform_dim) // 2

    @property
    def landmarks(self) -> list[Landmark]:
        """The landmarks in state order, as :class:`Landmark` views."""
        return [Landmark(self, j) for j in range(self.n_landmarks)]

    # ---------------------------------------------------------------- views (copies)
    @property
    def pose(self) -> np.ndarray:
        return self.x[:POSE_DIM].copy()

    @property
    def pose_cov(self) -> np.ndarray:
        return self.P[:POSE_DIM, :POSE_DIM].copy()

    @property
    def bias(self) -> np.ndarray:
        """The odometry-bias states ``(m,)`` (c.11); empty without them."""
        return self.x[POSE_DIM:self.platform_dim].copy()

    @property
    def bias_cov(self) -> np.ndarray:
        """Their covariance ``(m, m)``."""
        return self.P[POSE_DIM:self.platform_dim, POSE_DIM:self.platform_dim].copy()

    @property
    def positions(self) -> np.ndarray:
        """Landmark centroids ``(N, 2)``."""
        return self.x[self.platform_dim:].reshape(-1, 2).copy()

    def position(self, j: int) -> np.ndarray:
        i = self.index(j)
        return self.x[i:i + 2].copy()

    def position_cov(self, j: int) -> np.ndarray:
        i = self.index(j)
        return self.P[i:i + 2, i:i + 2].copy()

    def position_covs(self) -> np.ndarray:
        """The landmarks' 2 x 2 marginal covariances ``(N, 2, 2)``."""
        first, step = self.index(0), LANDMARK_DIM      # the blocks sit on the diagonal from here
        diag, upper = np.diagonal(self.P), np.diagonal(self.P, offset=1)
        covs = np.empty((self.n_landmarks, 2, 2))
        covs[:, 0, 0] = diag[first::step]
        covs[:, 0, 1] = covs[:, 1, 0] = upper[first::step]
        covs[:, 1, 1] = diag[first + 1::step]
        return covs

    def ids(self) -> np.ndarray:
        return self.records.ids[:self.n_landmarks].copy()

    def created(self) -> np.ndarray:
        return self.records.created[:self.n_landmarks].copy()

    def rows_by_id(self) -> dict[int, int]:
        """Landmark id -> its position ``j`` in the state."""
        return dict(zip(self.records.ids[:self.n_landmarks].tolist(), range(self.n_landmarks)))

    def linearisation(self, j: int) -> np.ndarray:
        """The state at which landmark ``j``'s measurement Jacobian is evaluated: ``x`` itself, or
        under first-estimates Jacobians (:attr:`lin_pose` set; c.2.1) a copy of ``x`` (n,) with the
        pose ``lin_pose`` and landmark ``j`` at its first estimate."""
        if self.lin_pose is None:
            return self.x
        x = self.x.copy()
        x[:POSE_DIM] = self.lin_pose
        i = self.index(j)
        x[i:i + 2] = self.records.first[j]
        return x

    def linearisation_all(self) -> np.ndarray:
        """Every landmark's :meth:`linearisation` in one vector, for the compiled associators: empty
        for the standard Jacobians; under first-estimates Jacobians a copy of ``x`` (n,) with the
        pose ``lin_pose`` and every landmark at its first estimate (landmark ``j``'s Jacobian reads
        only the pose and its own centroid, so at this vector it is the one at ``linearisation(j)``)."""
        if self.lin_pose is None:
            return np.empty(0)
        x = self.x.copy()
        x[:POSE_DIM] = self.lin_pose
        x[self.platform_dim:] = self.records.first[:self.n_landmarks].ravel()
        return x

    # ---------------------------------------------------------------- changes
    def set(self, x: np.ndarray, P: np.ndarray) -> None:
        """Replace the mean and covariance (same dimension)."""
        self.x, self.P = x, P

    def add_landmark(self, s: np.ndarray, R: np.ndarray, created: int, extent: Any = None) -> int:
        """Augment the state with a landmark seen at ``s = [r, phi]`` (APSIPA eqs. 10-11); its id."""
        return self.append_landmark(*ekf.augment(self.x, self.P, s, R), created, extent)

    def add_landmark_at_mean(self, polar: np.ndarray, R: np.ndarray, created: int, extent: Any = None,
                             spread: np.ndarray | None = None) -> int:
        """Augment the state with a landmark at the mean of detections ``polar`` (:func:`.ekf.augment_mean`)."""
        return self.append_landmark(*ekf.augment_mean(self.x, self.P, polar, R, spread), created, extent)

    def append_landmark(self, x: np.ndarray, P: np.ndarray, created: int, extent: Any = None) -> int:
        """Take ``(x, P)``, the current state augmented by one landmark; record it and return its id."""
        if x.shape[0] != self.x.shape[0] + 2:
            raise ValueError(f"x: expected {self.x.shape[0] + 2} entries, got {x.shape[0]}")
        n = self.n_landmarks
        self.x, self.P = x, P
        lid = self.next_id
        self.records = add_record(self.records, n, lid, created, float(x[-2]), float(x[-1]))
        self.extents.append(extent)
        self.next_id += 1
        return lid

    def remove(self, js: list[int]) -> list[tuple[int, Any]]:
        """Delete landmarks ``js`` (state positions) from ``x``, ``P`` and the records; the removed
        landmarks' ``(id, extent)`` in state order."""
        if not js:
            return []
        keep = np.ones(self.n_landmarks, dtype=bool)
        keep[list(js)] = False
        removed = [(int(self.records.ids[j]), self.extents[j]) for j in np.flatnonzero(~keep).tolist()]
        self.x, self.P = ekf.remove_landmarks(self.x, self.P, list(js), self.platform_dim)
        old = compact_records(self.records, keep)
        self.extents = [self.extents[j] for j in old.tolist()]
        return removed
