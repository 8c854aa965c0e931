"""The Doppler gate: moving objects kept out of the map (``filter.doppler_gate``, docs/method.md c.10.4).

Per scan (:meth:`DopplerGate.apply`, before sifting):

1. the sensor velocity is fitted to the scan's Doppler (c.10.2), with the directions from the
   sensor's mounting (a :class:`~radarslam.core.mounting.Mounting`: ``[sensor]``'s for a scan in the
   platform frame, zero for a scan in its own radar's frame, c.13;
   :func:`~radarslam.models.doppler.mounted_directions`);
2. each detection is tested against the static world (the per-detection test, c.10.4.1);
3. the detections are grouped into objects (single linkage within ``filter.doppler_object_radius_m``)
   and each object is tested as a whole (its own fitted velocity, c.10.4.2): all detections of a
   moving object are dropped, including those whose own Doppler passed;
4. the moving objects' detections are remembered in the world frame for
   ``filter.doppler_memory_scans`` scans (c.10.4.3).

At landmark creation (:meth:`DopplerGate.veto`, step 7) a new cluster with a detection within
``filter.doppler_memory_radius_m`` of a remembered moving detection neither starts nor feeds an
unconfirmed landmark: a car crossing the line of sight has a radial velocity near zero for a few
scans and passes every instantaneous test, but it was seen moving just before.
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.deprecation import renamed
from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting
from radarslam.landmarks.clustering import Cluster
from radarslam.models import doppler_kernels
from radarslam.models._doppler_compiled import classify_scan
from radarslam.models.doppler import EgoVelocity, chi2_quantile
from radarslam.slam.gate_kernels import any_near, moving_young_rows, remember_rows

#: The least consensus fraction of a valid fit (``fit_ego_velocity``'s default, c.10.3).
MIN_INLIER_FRACTION = 0.3

__all__ = ["DopplerGate"]


class DopplerGate:
    """c.10.4 on a stream of scans (module docstring).

    Parameters
    ----------
    filter_config : FilterConfig
        The RANSAC settings (c.10.2) and the gate's (``doppler_gate_probability``,
        ``doppler_object_radius_m``, ``doppler_object_probability``, ``doppler_memory_scans``,
        ``doppler_memory_radius_m``).
    mounting : Mounting
        The radar's on the platform, for scans in the platform frame (``Mounting.from_config`` of
        ``[sensor]``; the former ``(x m, y m, yaw rad)`` tuple is taken too).
    """

    def __init__(self, filter_config, mounting: Mounting = Mounting()):
        self.f = filter_config
        self.mounting = Mounting.coerce(mounting)
        #: RANSAC's minimal sets (c.10.2): a fixed seed, so a run is reproducible.
        self.rng = np.random.default_rng(0)
        #: The moving objects' detections remembered (c.10.4.3): world positions ``memory_xy[:n_memory]``
        #: seen at scans ``memory_k[:n_memory]``, oldest first.
        self.memory_xy, self.memory_k, self.n_memory = np.empty((0, 2)), np.empty(0, dtype=np.int64), 0
        #: World positions (n, 2) of this scan's moving objects' detections (c.10.4.4).
        self.now = np.empty((0, 2))

    def apply(self, scan, polar: np.ndarray, pose: np.ndarray, mount: Mounting | None = None):
        """Steps 1-4 on one scan: ``(kept rows, moving rows, EgoVelocity)``; ``mount`` replaces the
        configured mounting (a zero :class:`Mounting` for a scan in its own radar's frame, docs/method.md c.13)."""
        keep, bad, ego, objects = self.classify(scan, polar, mount)
        if objects is not None:
            self._remember(scan.index, objects, pose)
        return keep, bad, ego

    def classify(self, scan, polar: np.ndarray, mount: Mounting | None = None):
        """Steps 1-3 on one scan, which depend on the scan alone (not on the filter's state):
        ``(kept rows, moving rows, EgoVelocity, the moving objects' detections in the platform
        frame (n, 2), or None when the objects were not tested)``; step 4 (:meth:`_remember`, in the
        world frame of the pose) is the caller's."""
        f = self.f
        ch = scan.channels or {}
        if polar.shape[0] and "doppler_mps" not in ch:
            raise InputError(f"scan {scan.index}: filter.doppler_gate expected channels['doppler_mps'], got "
                             f"channels {sorted(ch)}")
        d = np.asarray(ch.get("doppler_mps", np.empty(0)), dtype=float)
        if d.shape != (polar.shape[0],):
            raise InputError(f"scan {scan.index}: channels['doppler_mps']: expected shape ({polar.shape[0]},), "
                             f"got {d.shape}")
        polar = np.ascontiguousarray(polar, dtype=float).reshape(-1, 2)
        # the backend's form (filter.backend): the reference compiles nothing (a first run on a machine),
        # the same draws, inliers and generator state as the compiled one (tests/test_doppler_kernels.py)
        kernel = doppler_kernels.classify_scan if f.backend == "python" else classify_scan
        m = self.mounting if mount is None else mount
        v, cov, inl, sigma, stat, rest, valid, bad, objects, tested = kernel(
            polar, np.ascontiguousarray(d), m.x, m.y, m.yaw, self.rng, int(f.doppler_iterations),
            float(f.doppler_threshold_mps), float(f.doppler_std_floor_mps), MIN_INLIER_FRACTION, *self.quantiles())
        ego = EgoVelocity(v, cov, inl, float(sigma), float(stat), bool(rest), bool(valid))
        seen = _platform_xy(polar[objects]) if tested else None
        return np.flatnonzero(~bad), np.flatnonzero(bad), ego, seen

    def quantiles(self) -> tuple[float, float, float, float, float]:
        """The arguments ``(q_zero, q_gate, radius, q_one, q_two)`` of
        :func:`~radarslam.models.doppler_kernels.classify_scan` from the configuration."""
        f = self.f
        return (chi2_quantile(f.zero_velocity_probability, 2), chi2_quantile(f.doppler_gate_probability, 1),
                float(f.doppler_object_radius_m), chi2_quantile(f.doppler_object_probability, 1),
                chi2_quantile(f.doppler_object_probability, 2))

    def _remember(self, k: int, xy: np.ndarray, pose: np.ndarray) -> None:
        """Keep this scan's moving objects ``xy`` (platform frame) in the world frame of ``pose`` and
        forget those older than the memory (:func:`~radarslam.slam.gate_kernels.remember_rows`)."""
        self.memory_xy, self.memory_k, self.n_memory, self.now = remember_rows(
            self.memory_xy, self.memory_k, self.n_memory, np.ascontiguousarray(xy, dtype=float).reshape(-1, 2),
            np.asarray(pose, dtype=float), int(k), int(self.f.doppler_memory_scans))

    def moving_landmarks(self, positions: np.ndarray, created: np.ndarray, k: int) -> list[int]:
        """The landmarks (state positions) created less than ``filter.doppler_probation_scans`` scans
        before scan ``k`` with a detection of this scan's moving objects (:meth:`apply` of scan
        ``k``) within ``filter.doppler_memory_radius_m`` (c.10.4.4)."""
        r = float(self.f.doppler_memory_radius_m)
        return np.flatnonzero(moving_young_rows(np.ascontiguousarray(positions, dtype=float).reshape(-1, 2),
                                                np.asarray(created, dtype=np.int64), int(k), self.now,
                                                int(self.f.doppler_probation_scans), r * r)).tolist()

    def veto(self, clusters: list[Cluster], xy: np.ndarray) -> list[Cluster]:
        """The clusters with no detection (world positions ``xy`` of the scan's kept detections)
        within ``filter.doppler_memory_radius_m`` of a remembered moving detection (c.10.4.3)."""
        if not self.n_memory or not clusters:
            return clusters
        r = float(self.f.doppler_memory_radius_m)
        return [c for c in clusters if not any_near(xy[c.members], self.memory_xy, self.n_memory, r * r)]


def _mounting(sensor) -> tuple[float, float, float]:
    m = Mounting.from_config(sensor)
    return m.x, m.y, m.yaw


#: ``mounting(sensor)``, the former ``(x, y, yaw)`` of ``[sensor]``, with a DeprecationWarning.
__getattr__ = renamed(__name__, {"mounting": (_mounting, "radarslam.core.mounting.Mounting.from_config(sensor)")})


def _platform_xy(polar: np.ndarray) -> np.ndarray:
    """Platform-frame positions ``(n, 2)`` of ``[range, azimuth]`` detections."""
    return np.column_stack([polar[:, 0] * np.cos(polar[:, 1]), polar[:, 0] * np.sin(polar[:, 1])])
