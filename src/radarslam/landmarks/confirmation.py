"""Confirmation of new landmarks (Rule 1 / Rule 2, docs/method.md c.7) and M/N removal windows (c.5)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from radarslam.core.angles import wrap_pi
from radarslam.landmarks.clustering import Cluster


@dataclass
class Tentative:
    """An unconfirmed landmark (Rule 2)."""

    centre_xy: np.ndarray
    count: int
    window: int
    npts: int


def rule2_step(tentatives: list[Tentative], clusters: list[Cluster], *, gate: float, confirm_points: int,
               window: int, hits: int) -> tuple[list[Cluster], list[Tentative]]:
    """One scan of Rule 1 / Rule 2 over the clusters that passed the alpha test.

    1. Greedy one-to-one matching of clusters to last scan's tentatives: repeatedly the pair with
       the smallest centre distance, if below ``gate`` (gamma_a).
    2. Matched: ``count += 1``, centre and ``npts`` from the cluster; confirmed if
       ``count >= hits`` or ``npts >= confirm_points``.
    3. The remaining tentatives age (``window += 1``) and are dropped when ``window >= M`` or
       when ``count + M - window < N`` (they can no longer reach N hits).
    4. Unmatched clusters: confirmed at once with ``size >= confirm_points`` (Rule 1), otherwise
       a new tentative with ``count = window = 1``.

    Returns
    -------
    confirmed : list of Cluster
        Clusters whose centre (this scan's measurement) initialises a new landmark.
    tentatives : list of Tentative
        The unconfirmed landmarks carried to the next scan.
    """
    confirmed: list[Cluster] = []
    matched_c: set[int] = set()
    matched_t: set[int] = set()
    if tentatives and clusters:
        tc = np.array([t.centre_xy for t in tentatives])
        cc = np.array([c.centre_xy for c in clusters])
        d = np.linalg.norm(tc[:, None, :] - cc[None, :, :], axis=2)
        for flat in np.argsort(d, axis=None, kind="stable"):
            ti, ci = divmod(int(flat), len(clusters))
            if d[ti, ci] >= gate:
                break
            if ti in matched_t or ci in matched_c:
                continue
            matched_t.add(ti)
            matched_c.add(ci)
            t, c = tentatives[ti], clusters[ci]
            t.count += 1
            t.centre_xy = c.centre_xy
            t.npts = c.size
            if t.count >= hits or t.npts >= confirm_points:
                confirmed.append(c)
                t.window = -1  # marks it consumed
    kept: list[Tentative] = []
    for t in tentatives:
        if t.window < 0:
            continue
        t.window += 1
        if t.window >= window or t.count + window - t.window < hits:
            continue
        kept.append(t)
    for ci, c in enumerate(clusters):
        if ci in matched_c:
            continue
        if c.size >= confirm_points:
            confirmed.append(c)
        else:
            kept.append(Tentative(c.centre_xy, 1, 1, c.size))
    return confirmed, kept


def push_bit(window: int, bit: bool, length: int) -> int:
    """Shift a newest-first bit window (bit 0 = this scan) and keep ``length`` bits."""
    return ((window << 1) | int(bit)) & ((1 << length) - 1)


def should_remove(k: int, created: int, assoc: int, in_range: int, *, window: int, max_hits: int) -> bool:
    """M/N removal (c.5): old enough, in range in all of the last M scans, associated in <= N."""
    return (k - window + 1 >= created and in_range.bit_count() == window
            and assoc.bit_count() <= max_hits)


def in_sensor_view(positions: np.ndarray, pose: np.ndarray, max_range: float, field_of_view_deg: float) -> np.ndarray:
    """Which landmarks ``(N, 2)`` the sensor at ``pose`` covers: within ``max_range`` and, for a
    sensor that does not see all around, within the field of view centred on the heading (the
    "in range" of the M/N removal, c.5). Boolean ``(N,)``."""
    half_fov = math.radians(field_of_view_deg) / 2.0
    x0, y0, th = float(pose[0]), float(pose[1]), float(pose[2])
    if positions.shape[0] == 0:
        return np.zeros(0, dtype=bool)
    dx, dy = positions[:, 0] - x0, positions[:, 1] - y0
    out = np.hypot(dx, dy) <= max_range
    if half_fov < math.pi:
        out &= np.abs(wrap_pi(np.arctan2(dy, dx) - th)) <= half_fov
    return out


def removal_step(records: list, hit: np.ndarray, in_view: np.ndarray, k: int, *, window: int,
                 max_hits: int) -> list[int]:
    """One scan of the M/N removal windows (c.5, every scan, Decision 8).

    Each record (``.assoc``, ``.in_range``, ``.created``) pushes whether it was associated and
    whether it was in range (an associated landmark counts as in range); returns the positions of
    the records to remove, ascending.
    """
    drop = []
    seen = np.logical_or(hit, in_view).tolist()          # an associated landmark counts as in range
    for j, (r, h, v) in enumerate(zip(records, hit.tolist(), seen)):
        r.assoc = push_bit(r.assoc, h, window)
        r.in_range = push_bit(r.in_range, v, window)
        if should_remove(k, r.created, r.assoc, r.in_range, window=window, max_hits=max_hits):
            drop.append(j)
    return drop
