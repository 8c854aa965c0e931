"""The fused engine's records (:mod:`radarslam.slam.fused`): the landmarks, the Doppler gate's memory
and the per-scan outputs as arrays (the tentatives are :class:`~radarslam.slam.state.SlamState`'s own record,
landmarks.confirmation.Tentatives), with their growth, removal and the record after a scan.

Each record is a :class:`typing.NamedTuple` of arrays, which numba compiles as a tuple with named
fields: the arrays are changed in place; growing one makes new arrays, so the helpers that may grow
return the record anew.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from radarslam.core.jit import compiled_only
from radarslam.extent._compiled import gated_diameter as compiled_gated_diameter
from radarslam.landmarks._compiled import compiled_compact_records, compiled_grown, compiled_grown_inner, compiled_with_room
from radarslam.landmarks.records import Records
from radarslam.slam import _view_compiled
from radarslam.slam.state_loops import all_finite as _all_finite, drop_state_rows as _drop_state_rows

# The visible-arc estimator's trunk diameter, compiled as it is (docs/method.md a.9).
_gated_diameter = compiled_gated_diameter
_exp_sym2 = _view_compiled.exp_sym2


class Landmarks(NamedTuple):
    """The landmark records in state order (rows ``0 .. N - 1`` in use; capacity along axis 0): the
    bookkeeping of :class:`~radarslam.landmarks.records.Records` (its first five fields, grown,
    added and moved by its kernels, :func:`records`), then the extent estimators' states."""

    ids: np.ndarray        #: (L,) int64, landmark ids
    created: np.ndarray    #: (L,) int64, creation scans
    mbits: np.ndarray      #: (L,) int64, M/N window of associations (c.5), newest in bit 0
    rbits: np.ndarray      #: (L,) int64, M/N window of scans in view or associated
    einit: np.ndarray      #: (L,) bool, extent initialised
    X: np.ndarray          #: (L, 2, 2) RMA extents
    alpha: np.ndarray      #: (L,) RMA degrees of freedom
    Xefa: np.ndarray       #: (L, 2, 2) EFA extents
    nbuf: np.ndarray       #: (L,) int64, detections held before the extent is initialised (a.3)
    buf: np.ndarray        #: (L, B, 2) those detections in the world frame
    narc: np.ndarray       #: (L,) int64, visible-arc widths held (a.9; :class:`Arcs`)
    arc_head: np.ndarray   #: (L,) int64, the first of them in :class:`Arcs` (-1: none)
    arc_tail: np.ndarray   #: (L,) int64, the last of them (-1: none)
    first: np.ndarray      #: (L, 2) first estimates: the centroids at birth (FEJ, docs/method.md c.2.1)
    shape: np.ndarray      #: (L, 3) MEM-EKF* shapes [theta, l1, l2] (a.10; ``X`` holds their matrices)
    Cs: np.ndarray         #: (L, 3, 3) their covariances
    xi: np.ndarray         #: (L, 3) partial-view log-matrix shapes (a.12.7; ``Pxi`` their covariances)
    Pxi: np.ndarray        #: (L, 3, 3)
    nview: np.ndarray      #: (L,) int64, scans that updated the partial-view shape
    vangle: np.ndarray     #: (L,) the bearing landmark -> sensor at the last scan (a.12.5 view walk; NaN: none)


class Arcs(NamedTuple):
    """The visible-arc estimator's per-scan widths (docs/method.md a.9) of every landmark, as linked
    lists in order of arrival (a merge appends the dropped landmark's list to the survivor's, as
    :meth:`~radarslam.extent.visible_arc.VisibleArcEstimator.merge` does)."""

    d: np.ndarray          #: (n,) per-scan diameters (m)
    beam: np.ndarray       #: (n,) the beam widths at the trunk's range (m)
    nxt: np.ndarray        #: (n,) int64, the landmark's next entry, -1 at its last


class Memory(NamedTuple):
    """The Doppler gate's memory (docs/method.md c.10.4.3-c.10.4.4; :class:`~radarslam.slam.doppler_gate.DopplerGate`):
    the moving objects' detections of the last scans, and those of the scan that last tested objects."""

    xy: np.ndarray         #: (n, 2) remembered moving detections, world frame, oldest first
    k: np.ndarray          #: (n,) int64, the scan of each
    now: np.ndarray        #: (c, 2) the last tested scan's moving detections, world frame


class Clusters(NamedTuple):
    """The clusters of a scan's unclaimed detections (a.8 step 7)."""

    rest: np.ndarray       #: (n,) int64, the detections no landmark claimed
    labels: np.ndarray     #: (n,) int64, their DBSCAN labels (-1 noise; empty when too few to cluster)
    centre: np.ndarray     #: (c,) int64, per cluster the detection at its centre
    size: np.ndarray       #: (c,) int64, per cluster its number of points


class ScanRecord(NamedTuple):
    """What :func:`radarslam.slam.driver.run_filter` records after every scan (``S`` rows)."""

    poses: np.ndarray      #: (S, 3)
    pose_covs: np.ndarray  #: (S, 3, 3)
    n_det: np.ndarray      #: (S,) int64 detections
    n_ass: np.ndarray      #: (S,) int64 associated detections
    n_lm: np.ndarray       #: (S,) int64 landmarks
    nis_sum: np.ndarray    #: (S,)
    nis_cnt: np.ndarray    #: (S,) int64
    map_off: np.ndarray    #: (S + 1,) int64, the map after scan s is rows map_off[s]:map_off[s + 1]
    seconds: np.ndarray    #: (S,) wall time per scan (with ``timing``, else zeros)
    nis: np.ndarray        #: (u,) the NIS of every update: scan s's are nis[nis_off[s]:nis_off[s + 1]]
    nis_off: np.ndarray    #: (S + 1,) int64
    trace_off: np.ndarray  #: (S + 1,) int64, the landmarks after scan s are trace rows trace_off[s]:trace_off[s + 1]
    trace_ids: np.ndarray  #: (t,) int64 their ids (only after the scans ``Stream.trace`` marks)
    trace_pos: np.ndarray  #: (t, 2) their centroids
    bias: np.ndarray       #: (S, m) the odometry-bias states (docs/method.md c.11; m = 0 without them)
    bias_covs: np.ndarray  #: (S, m, m) their covariance


class MapRows(NamedTuple):
    """The maps after every scan, one row per landmark (capacity along axis 0)."""

    ids: np.ndarray        #: (R,) int64
    pos: np.ndarray        #: (R, 2) centroids
    cov: np.ndarray        #: (R, 2, 2) centroid covariances
    rma: np.ndarray        #: (R, 2, 2) RMA extents (NaN where not initialised)
    efa: np.ndarray        #: (R, 2, 2) EFA extents (NaN where not initialised)
    created: np.ndarray    #: (R,) int64 creation scans


# ---------------------------------------------------------------------------------------- arrays
#: ``a`` with room for ``n`` rows (doubling): :func:`radarslam.core.arrays.grown`, compiled.
_grow_rows = compiled_grown


#: The detection buffers ``(L, B, 2)`` with room for ``n`` points per landmark: core.arrays.grown_inner, compiled.
_grow_buffer = compiled_grown_inner


@njit(cache=True, inline="always")
def _blocks(x, P, platform):  # pragma: no cover - compiled
    """Landmark centroids ``(N, 2)`` and their 2 x 2 covariance blocks ``(N, 2, 2)`` after a
    platform block of ``platform`` entries."""
    N = (x.shape[0] - platform) // 2
    pos = np.empty((N, 2))
    cov = np.empty((N, 2, 2))
    for j in range(N):
        i = platform + 2 * j
        pos[j, 0] = x[i]
        pos[j, 1] = x[i + 1]
        cov[j, 0, 0] = P[i, i]
        cov[j, 0, 1] = P[i, i + 1]
        cov[j, 1, 0] = P[i, i + 1]
        cov[j, 1, 1] = P[i + 1, i + 1]
    return pos, cov


# ---------------------------------------------------------------------------------------- landmarks
@njit(cache=True, inline="always")
def new_landmarks(cap, buf_len):  # pragma: no cover - compiled
    """Empty landmark records with room for ``cap`` landmarks of ``buf_len`` buffered points."""
    return Landmarks(np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64), np.empty(cap, dtype=np.int64),
                     np.empty(cap, dtype=np.int64), np.zeros(cap, dtype=np.bool_), np.zeros((cap, 2, 2)),
                     np.zeros(cap), np.zeros((cap, 2, 2)), np.zeros(cap, dtype=np.int64),
                     np.zeros((cap, buf_len, 2)), np.zeros(cap, dtype=np.int64), np.full(cap, -1, dtype=np.int64),
                     np.full(cap, -1, dtype=np.int64), np.zeros((cap, 2)), np.zeros((cap, 3)), np.zeros((cap, 3, 3)),
                     np.zeros((cap, 3)), np.zeros((cap, 3, 3)), np.zeros(cap, dtype=np.int64), np.full(cap, np.nan))


@njit(cache=True, inline="always")
def records(lm):  # pragma: no cover - compiled
    """The bookkeeping of ``lm`` as :class:`~radarslam.landmarks.records.Records` (the same arrays)."""
    return Records(lm.ids, lm.created, lm.mbits, lm.rbits, lm.first)


@compiled_only
def grow_landmarks(lm, n):  # pragma: no cover - compiled
    """``lm`` with room for at least ``n`` landmarks (landmarks.records.with_room, the estimators'
    states alike)."""
    if n <= lm.ids.shape[0]:
        return lm
    rec = compiled_with_room(records(lm), n)
    c = rec.ids.shape[0]
    return Landmarks(rec.ids, rec.created, rec.mbits, rec.rbits, _grow_rows(lm.einit, c), _grow_rows(lm.X, c),
                     _grow_rows(lm.alpha, c), _grow_rows(lm.Xefa, c), _grow_rows(lm.nbuf, c), _grow_rows(lm.buf, c),
                     _grow_rows(lm.narc, c), _grow_rows(lm.arc_head, c), _grow_rows(lm.arc_tail, c), rec.first,
                     _grow_rows(lm.shape, c), _grow_rows(lm.Cs, c), _grow_rows(lm.xi, c), _grow_rows(lm.Pxi, c),
                     _grow_rows(lm.nview, c), _grow_rows(lm.vangle, c))


@compiled_only
def with_buffer(lm, n):  # pragma: no cover - compiled
    """``lm`` with room for ``n`` buffered points per landmark."""
    if lm.buf.shape[1] >= n:
        return lm
    return Landmarks(lm.ids, lm.created, lm.mbits, lm.rbits, lm.einit, lm.X, lm.alpha, lm.Xefa, lm.nbuf,
                     _grow_buffer(lm.buf, n), lm.narc, lm.arc_head, lm.arc_tail, lm.first, lm.shape, lm.Cs, lm.xi,
                     lm.Pxi, lm.nview, lm.vangle)


@compiled_only
def compact_landmarks(lm, keep):  # pragma: no cover - compiled
    """Move the records whose ``keep`` is True to the front, in order, in place: the bookkeeping by
    landmarks.records.compact_records, the estimators' states alike. Returns each survivor's
    position before (``(n_keep,)``)."""
    old = compiled_compact_records(records(lm), keep)
    for q in range(old.shape[0]):
        j = old[q]
        if q != j:
            lm.einit[q], lm.X[q], lm.alpha[q], lm.Xefa[q] = lm.einit[j], lm.X[j], lm.alpha[j], lm.Xefa[j]
            lm.nbuf[q] = lm.nbuf[j]
            lm.buf[q] = lm.buf[j]
            lm.narc[q], lm.arc_head[q], lm.arc_tail[q] = lm.narc[j], lm.arc_head[j], lm.arc_tail[j]
            lm.shape[q] = lm.shape[j]
            lm.Cs[q] = lm.Cs[j]
            lm.xi[q], lm.Pxi[q], lm.nview[q], lm.vangle[q] = lm.xi[j], lm.Pxi[j], lm.nview[j], lm.vangle[j]
    return old


# ---------------------------------------------------------------------------------------- Doppler gate
@njit(cache=True, inline="always")
def new_memory(cap):  # pragma: no cover - compiled
    """An empty :class:`Memory` with room for ``cap`` detections."""
    return Memory(np.empty((cap, 2)), np.empty(cap, dtype=np.int64), np.empty((cap, 2)))


# ---------------------------------------------------------------------------------------- visible arcs
@njit(cache=True, inline="always")
def new_arcs(cap):  # pragma: no cover - compiled
    """Empty :class:`Arcs` with room for ``cap`` widths."""
    return Arcs(np.empty(cap), np.empty(cap), np.empty(cap, dtype=np.int64))


@njit(cache=True, inline="always")
def add_arc(arcs, n, lm, j, d, b):  # pragma: no cover - compiled
    """Append the width ``(d, b)`` to landmark ``j``'s list (``n`` entries in use). Returns ``arcs``
    (grown if needed)."""
    if n >= arcs.d.shape[0]:
        arcs = Arcs(_grow_rows(arcs.d, n + 1), _grow_rows(arcs.beam, n + 1), _grow_rows(arcs.nxt, n + 1))
    arcs.d[n], arcs.beam[n], arcs.nxt[n] = d, b, -1
    if lm.narc[j] == 0:
        lm.arc_head[j] = n
    else:
        arcs.nxt[lm.arc_tail[j]] = n
    lm.arc_tail[j] = n
    lm.narc[j] += 1
    return arcs


@compiled_only
def pool_arcs(arcs, lm, i, j):  # pragma: no cover - compiled
    """Landmark ``i`` takes landmark ``j``'s widths after its own (a merge, c.9)."""
    if lm.narc[j] == 0:
        return
    if lm.narc[i] == 0:
        lm.arc_head[i] = lm.arc_head[j]
    else:
        arcs.nxt[lm.arc_tail[i]] = lm.arc_head[j]
    lm.arc_tail[i] = lm.arc_tail[j]
    lm.narc[i] += lm.narc[j]


@njit(cache=True, inline="always")
def arc_values(arcs, lm, j):  # pragma: no cover - compiled
    """Landmark ``j``'s widths in order: ``(d (n,), b (n,))``."""
    n = lm.narc[j]
    d = np.empty(n)
    b = np.empty(n)
    e = lm.arc_head[j]
    for q in range(n):
        d[q], b[q] = arcs.d[e], arcs.beam[e]
        e = arcs.nxt[e]
    return d, b


# ---------------------------------------------------------------------------------------- outputs
@njit(cache=True, inline="always")
def new_records(S, cap, m):  # pragma: no cover - compiled
    """The per-scan record of ``S`` scans with ``m`` odometry-bias states and map rows with room for
    ``cap`` landmarks."""
    rec = ScanRecord(np.empty((S, 3)), np.empty((S, 3, 3)), np.zeros(S, dtype=np.int64), np.zeros(S, dtype=np.int64),
                     np.zeros(S, dtype=np.int64), np.zeros(S), np.zeros(S, dtype=np.int64),
                     np.zeros(S + 1, dtype=np.int64), np.zeros(S), np.empty(cap), np.zeros(S + 1, dtype=np.int64),
                     np.zeros(S + 1, dtype=np.int64), np.empty(cap, dtype=np.int64), np.empty((cap, 2)),
                     np.empty((S, m)), np.empty((S, m, m)))
    maps = MapRows(np.empty(cap, dtype=np.int64), np.empty((cap, 2)), np.empty((cap, 2, 2)), np.empty((cap, 2, 2)),
                   np.empty((cap, 2, 2)), np.empty(cap, dtype=np.int64))
    return rec, maps


@compiled_only
def record_scan(rec, s, x, P, lm, N, m, n_assoc, nis, trace):  # pragma: no cover - compiled
    """The record after scan ``s`` (run_filter): pose, counts, the NIS of every update and, with
    ``trace``, the landmarks' ids and centroids; the odometry-bias states and their covariance (c.11).
    Returns ``rec`` (its logs may grow)."""
    p = x.shape[0] - 2 * N                                  # the platform block
    rec.poses[s] = x[:3]
    rec.pose_covs[s] = P[:3, :3]
    rec.bias[s] = x[3:p]
    rec.bias_covs[s] = P[3:p, 3:p]
    rec.n_det[s] = m
    rec.n_ass[s] = n_assoc
    rec.n_lm[s] = N
    rec.nis_sum[s] = nis.sum()
    rec.nis_cnt[s] = nis.shape[0]
    rec.map_off[s + 1] = rec.map_off[s]
    u = rec.nis_off[s]
    rec.nis_off[s + 1] = u + nis.shape[0]
    n_log = rec.nis
    if u + nis.shape[0] > n_log.shape[0]:
        n_log = _grow_rows(n_log, u + nis.shape[0])
    n_log[u:u + nis.shape[0]] = nis
    t0 = rec.trace_off[s]
    ids, pos = rec.trace_ids, rec.trace_pos
    if trace:
        ids, pos = _grow_rows(ids, t0 + N), _grow_rows(pos, t0 + N)
        for j in range(N):
            ids[t0 + j] = lm.ids[j]
            pos[t0 + j, 0], pos[t0 + j, 1] = x[p + 2 * j], x[p + 1 + 2 * j]
    rec.trace_off[s + 1] = t0 + (N if trace else 0)
    return ScanRecord(rec.poses, rec.pose_covs, rec.n_det, rec.n_ass, rec.n_lm, rec.nis_sum, rec.nis_cnt,
                      rec.map_off, rec.seconds, n_log, rec.nis_off, rec.trace_off, ids, pos, rec.bias, rec.bias_covs)


@compiled_only
def _grown_maps(maps, n):  # pragma: no cover - compiled
    """``maps`` with room for ``n`` rows."""
    if n <= maps.ids.shape[0]:
        return maps
    return MapRows(_grow_rows(maps.ids, n), _grow_rows(maps.pos, n), _grow_rows(maps.cov, n),
                   _grow_rows(maps.rma, n), _grow_rows(maps.efa, n), _grow_rows(maps.created, n))


@compiled_only
def write_map_row(maps, r, j, x, P, lm, arcs, cfg):  # pragma: no cover - compiled
    """Row ``r`` of ``maps`` is landmark ``j`` (state order) of ``x``, ``P``, ``lm``. Extents as the
    estimator's ``matrix`` and ``baseline`` read them: RMA and EFA; under the partial view
    (``cfg.pv.on``) its shape and RMA; with ``cfg.arc`` (visible-arc, a.9) the circle of the gated
    mean width (once ``cfg.arc_min_scans`` are held) and RMA."""
    i = cfg.platform + 2 * j
    maps.ids[r] = lm.ids[j]
    maps.created[r] = lm.created[j]
    maps.pos[r, 0], maps.pos[r, 1] = x[i], x[i + 1]
    maps.cov[r, 0, 0], maps.cov[r, 0, 1] = P[i, i], P[i, i + 1]
    maps.cov[r, 1, 0], maps.cov[r, 1, 1] = P[i, i + 1], P[i + 1, i + 1]
    maps.rma[r] = np.nan
    maps.efa[r] = np.nan
    if cfg.pv.on:                    # partial view (a.12.7): its shape, the RMA as baseline
        X11, X12, X22 = _exp_sym2(lm.xi[j, 0], lm.xi[j, 1], lm.xi[j, 2])
        maps.rma[r, 0, 0], maps.rma[r, 0, 1], maps.rma[r, 1, 0], maps.rma[r, 1, 1] = X11, X12, X12, X22
        if lm.einit[j]:
            maps.efa[r] = lm.X[j]
    elif cfg.arc:
        if lm.einit[j]:
            maps.efa[r] = lm.X[j]
        if lm.narc[j] >= cfg.arc_min_scans:
            d, b = arc_values(arcs, lm, j)
            dm = _gated_diameter(d, b)
            if math.isfinite(dm):
                maps.rma[r] = (0.5 * dm) ** 2 * np.eye(2)
    elif lm.einit[j]:
        maps.rma[r] = lm.X[j]
        maps.efa[r] = lm.Xefa[j]


@compiled_only
def record_map(rec, maps, s, x, P, lm, N, arcs, retired, n_retired, cfg):  # pragma: no cover - compiled
    """The map after scan ``s``, appended to ``maps`` (grown if needed, returned): the ``N``
    landmarks of the state (:func:`write_map_row`), then the ``n_retired`` rows of ``retired``, the
    landmarks retired from the state so far (c.15), as they were when they left it."""
    base = rec.map_off[s]
    rec.map_off[s + 1] = base + N + n_retired
    maps = _grown_maps(maps, base + N + n_retired)
    for j in range(N):
        write_map_row(maps, base + j, j, x, P, lm, arcs, cfg)
    for r in range(n_retired):
        q = base + N + r
        maps.ids[q] = retired.ids[r]
        maps.created[q] = retired.created[r]
        maps.pos[q] = retired.pos[r]
        maps.cov[q] = retired.cov[r]
        maps.rma[q] = retired.rma[r]
        maps.efa[q] = retired.efa[r]
    return maps


@compiled_only
def cut_records(rec, maps, s):  # pragma: no cover - compiled
    """``(rec, maps)`` cut to the first ``s`` scans."""
    n = rec.map_off[s]
    u = rec.nis_off[s]
    t = rec.trace_off[s]
    rec = ScanRecord(rec.poses[:s], rec.pose_covs[:s], rec.n_det[:s], rec.n_ass[:s], rec.n_lm[:s], rec.nis_sum[:s],
                     rec.nis_cnt[:s], rec.map_off[:s + 1], rec.seconds[:s], rec.nis[:u], rec.nis_off[:s + 1],
                     rec.trace_off[:s + 1],
                     rec.trace_ids[:t], rec.trace_pos[:t], rec.bias[:s], rec.bias_covs[:s])
    maps = MapRows(maps.ids[:n], maps.pos[:n], maps.cov[:n], maps.rma[:n], maps.efa[:n], maps.created[:n])
    return rec, maps
