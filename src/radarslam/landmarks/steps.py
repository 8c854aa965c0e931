"""The orchestrator's landmark-management steps (docs/method.md c.4, c.7, c.9): each runs a kernel of
:mod:`.confirmation` or :mod:`.merging` as Python or, with ``compiled`` (the numba backend), as
compiled by :mod:`._compiled`; the fused engine calls the compiled kernels itself."""

from __future__ import annotations

import math

import numpy as np

from radarslam.landmarks._compiled import compiled_closest_pair, compiled_mn_windows, compiled_rule12
from radarslam.landmarks.clustering import Cluster
from radarslam.landmarks.confirmation import Tentatives, mn_windows, rule12
from radarslam.landmarks.merging import closest_pair


def rule2_step(tentatives: Tentatives, clusters: list[Cluster], *, gate: float, confirm_points: int,
               window: int, hits: int, compiled: bool = False) -> tuple[list[Cluster], Tentatives]:
    """One scan of Rule 1 / Rule 2 over the clusters that passed the alpha test (:func:`rule12`,
    compiled with ``compiled``: the numba backend).

    Returns
    -------
    confirmed : list of Cluster
        Clusters whose centre (this scan's measurement) initialises a new landmark.
    tentatives : Tentatives
        The unconfirmed landmarks carried to the next scan.
    """
    cc = np.array([c.centre_xy for c in clusters], dtype=float).reshape(-1, 2)
    cs = np.array([c.size for c in clusters], dtype=np.int64)
    kernel = rule12
    if compiled:
        kernel = compiled_rule12
    conf, *rows = kernel(tentatives.centre, tentatives.count, tentatives.window, tentatives.npts, cc, cs,
                         float(gate), int(confirm_points), int(window), int(hits))
    return [clusters[int(c)] for c in conf], Tentatives(*rows)


def removal_step(records, hit: np.ndarray, in_view: np.ndarray, k: int, *, window: int,
                 max_hits: int, compiled: bool = False) -> list[int]:
    """:func:`mn_windows` (compiled with ``compiled``: the numba backend) on the landmark records
    (:class:`~radarslam.landmarks.records.Records`, rows ``0 .. hit.size - 1``), their windows
    updated in place; returns the positions of the records to remove, ascending."""
    kernel = mn_windows
    if compiled:
        kernel = compiled_mn_windows
    n = hit.shape[0]
    keep = kernel(records.mbits[:n], records.rbits[:n], records.created[:n], np.asarray(hit, dtype=bool),
                  np.asarray(in_view, dtype=bool), int(k), int(window), int(max_hits))
    return np.flatnonzero(~keep).tolist()


def next_merge(positions: np.ndarray, created: np.ndarray, ids: np.ndarray, distance: float,
               axis_tol: float = math.inf, compiled: bool = False) -> tuple[int, int] | None:
    """:func:`closest_pair` (compiled with ``compiled``: the numba backend), or None."""
    kernel = closest_pair
    if compiled:
        kernel = compiled_closest_pair
    keep, drop = kernel(np.ascontiguousarray(positions, dtype=float).reshape(-1, 2),
                        np.asarray(created, dtype=np.int64), np.asarray(ids, dtype=np.int64),
                        float(distance), float(axis_tol))
    return None if keep < 0 else (int(keep), int(drop))
