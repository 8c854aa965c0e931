"""The map a run reports: the landmarks of the filter's state and those retired from it (docs/method.md c.15).

:class:`MapSnapshot` is the map after a scan; :func:`state_rows` reads the state's landmarks (with
their extents as the estimator reports them); :func:`retire_radius` is the distance beyond which the
engine retires a landmark from the state (its step 5) and keeps it, as it was when it left, after the
state's rows in the map (``slam/fused/storage.py: record_map``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MAP_FIELDS", "MapSnapshot", "retire_radius", "state_rows"]


def retire_radius(config) -> float:
    """The distance (m) from the platform's origin (the pose block) beyond which a landmark is retired
    (c.15): ``landmarks.retire_distance_m`` (a radar's reach) plus the lever-arm margin, the largest
    ``|l|`` of the rig's radars (``EstimatorConfig.rig``, else its ``mounting``, ``[sensor]``'s), so
    that no radar can still see a landmark when it leaves (a radar at ``l`` sees to ``d_r + |l|`` from
    the origin); 0 (never) for ``retire_distance_m`` 0."""
    d = float(config.landmarks.retire_distance_m)
    if d <= 0.0:
        return 0.0
    arms = [(float(m.x), float(m.y)) for m in (config.rig or (config.mounting,))]
    return d + max(float(np.hypot(x, y)) for x, y in arms)


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


#: The fields of :class:`MapSnapshot`, in order.
MAP_FIELDS = ("ids", "positions", "covs", "rma", "efa", "created")


def state_rows(state, extent) -> MapSnapshot:
    """The landmarks of ``state`` (a :class:`~radarslam.slam.state.SlamState`) as map rows (copies),
    their extents read by the estimator ``extent`` (``matrix``: RMA, ``baseline``: EFA)."""
    nan, n = np.full((2, 2), np.nan), state.n_landmarks
    rma = [extent.matrix(e) for e in state.extents]
    efa = [extent.baseline(e) for e in state.extents]
    return MapSnapshot(
        ids=state.ids(), positions=state.positions, covs=state.position_covs(),
        rma=np.array([nan if X is None else X for X in rma]).reshape(n, 2, 2),
        efa=np.array([nan if X is None else X for X in efa]).reshape(n, 2, 2),
        created=state.created(),
    )
