"""The filter's two events as functions over one record: :func:`predict_event` (an odometer reading or a
body-velocity input, docs/method.md c.2, c.10.5, c.11.2) and :func:`scan_event` (a scan, a.8 steps 2-10,
under the partial view a.12, in its radar's frame c.13-c.13.4). :class:`Carry` is everything the filter
holds between two events; each function takes it and returns the next.

The whole-stream loop (:func:`~radarslam.slam.fused.engine.engine`) calls them once per event and
inlines them, so that its family's flags (``view``, ``jcbb``, ``bias``: engine.Family) prune the branches
it never takes. Run by the interpreter (engine.form's Python forms), they are the same code.
"""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np
from numba import njit

from radarslam.core.jit import uncompiled
from radarslam.landmarks.confirmation import Tentatives
from radarslam.slam.fused.bias import predict_step
from radarslam.slam.fused.extent import extent_step
from radarslam.slam.fused.gate import moving_young, remember, veto
from radarslam.slam.fused.mapping import alpha_test, augment, cluster, confirm, merge
from radarslam.slam.fused.sensor import enter_sensor, held, leave_sensor, rehold, scan_rate
from radarslam.slam.fused.storage import _blocks, new_arcs, new_landmarks, new_memory, new_records
from radarslam.slam.fused.tracking import _to_world, group_associations, remove_unseen
from radarslam.slam.fused.view import associate_step, sift_step, view_walk
from radarslam.slam.layout import POSE_DIM

__all__ = ["Carry", "ScanOut", "initial_carry", "new_carry", "no_scan_out", "predict_event", "scan_event"]


class Carry(NamedTuple):
    """What the filter holds between two events (the state of :func:`predict_event` and :func:`scan_event`)."""

    x: np.ndarray          #: the state mean: the platform block (pose, then c.11's bias states), the centroids
    P: np.ndarray          #: its covariance
    pose_first: np.ndarray  #: FEJ: the first estimate of the pose (c.2.1)
    lm: object             #: the landmarks' records in state order (storage.Landmarks)
    N: np.int64            #: the number of landmarks in the state
    next_id: np.int64      #: the id the next confirmed landmark takes
    tent: object           #: the tentative landmarks (Rule 2, c.7; landmarks.confirmation.Tentatives)
    retired: object        #: the landmarks retired from the state (c.15; storage.MapRows)
    n_retired: np.int64    #: their number
    arcs: object           #: visible-arc widths (a.9; storage.Arcs)
    n_arcs: np.int64       #: their number
    mem: object            #: the Doppler gate's memory of moving detections (c.10.4; storage.Memory)
    n_mem: np.int64        #: its rows
    n_now: np.int64        #: the last tested scan's moving detections in it
    dt_since: float        #: the time predicted since the last scan (the extent prediction's, a.4)
    u_last: np.ndarray     #: the odometer's latest reading (c.13.2's pose rate)
    has_u: bool            #: whether there has been one
    scans: np.int64        #: the scans run


class ScanOut(NamedTuple):
    """What a scan did to the map beyond the per-scan record: the fields of the per-event report
    (:class:`~radarslam.slam.report.ScanReport`) that only the steps know."""

    n_cand: np.int64        #: the detections sifted as candidates for association (step 3)
    n_clusters: np.int64    #: the clusters of the unclaimed detections (step 7)
    removed: np.ndarray     #: (r,) int64, the ids removed from the state (step 5), not those retired (c.15)
    merged: np.ndarray      #: (m, 2) int64, ``(kept id, dropped id)`` of each merge (step 10), in order
    first_new: np.int64     #: the id of the first landmark the scan created (the others follow in order)
    new_off: np.ndarray     #: (n + 1,) int64, new landmark a's cluster is ``new_rows[new_off[a]:new_off[a + 1]]``
    new_rows: np.ndarray    #: int64, those clusters' detections (rows of the scan's detections)


@njit(cache=True, inline="always")
def no_scan_out():  # pragma: no cover - compiled
    """The :class:`ScanOut` before any scan (the arrays typed as :func:`scan_event` makes them)."""
    zero = np.int64(0)
    return ScanOut(zero, zero, np.empty(0, dtype=np.int64)[:0], np.empty((0, 2), dtype=np.int64)[:0], zero,
                   np.zeros(1, dtype=np.int64), np.empty(0, dtype=np.int64))


@njit(cache=True, inline="always")
def _removed(ids0, old, retired, r0, r1):  # pragma: no cover - compiled
    """The ids of ``ids0`` (the landmarks before step 5) whose rows are not among the survivors'
    former rows ``old`` nor retired (``retired.ids[r0:r1]``)."""
    gone = np.ones(ids0.shape[0], dtype=np.bool_)
    for a in range(old.shape[0]):
        gone[old[a]] = False
    out = np.empty(ids0.shape[0], dtype=np.int64)
    n = 0
    for j in range(ids0.shape[0]):
        if gone[j]:
            kept = False
            for q in range(r0, r1):
                kept = kept or retired.ids[q] == ids0[j]
            if not kept:
                out[n] = ids0[j]
                n += 1
    return out[:n]


@njit(cache=True, inline="always")
def _new_members(confirmed, clusters):  # pragma: no cover - compiled
    """The detections of each confirmed cluster, in order: ``(offsets, rows)``."""
    off = np.zeros(confirmed.shape[0] + 1, dtype=np.int64)
    for a in range(confirmed.shape[0]):
        off[a + 1] = off[a] + clusters.size[confirmed[a]]
    rows = np.empty(off[-1], dtype=np.int64)
    for a in range(confirmed.shape[0]):
        q = off[a]
        for b in range(clusters.rest.shape[0]):
            if clusters.labels[b] == confirmed[a]:
                rows[q] = clusters.rest[b]
                q += 1
    return off, rows


@njit(cache=True, inline="always")
def new_carry(x0, P0, buf_len):  # pragma: no cover - compiled
    """The filter before its first event: the state ``(x0, P0)``, no landmark; a landmark holds up to
    ``buf_len`` detections before its extent is initialised (a.3)."""
    zero = np.int64(0)    # counters: from a literal 0 numba compiles each callee twice (Literal[int](0), int64)
    tent = Tentatives(np.empty((0, 2)), np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64),
                      np.empty(0, dtype=np.int64))
    return Carry(x0.copy(), P0.copy(), x0[:3].copy(), new_landmarks(16, buf_len), zero, zero, tent,
                 new_records(0, 16, 0)[1], zero, new_arcs(64), zero, new_memory(16), zero, zero, 0.0, np.zeros(2),
                 False, zero)


def initial_carry(x0, P0, buf_len) -> Carry:
    """:func:`new_carry` built by the interpreter (nothing compiled): the carry a run starts from."""
    return _new_carry_python()(np.asarray(x0, dtype=float), np.asarray(P0, dtype=float), np.int64(buf_len))


@functools.lru_cache(maxsize=None)
def _new_carry_python():
    return uncompiled(new_carry)


@njit(cache=True, inline="always")
def predict_event(c, u, dt, U, Q, model, odometer, cfg, bias):  # pragma: no cover - compiled
    """One prediction (c.2, with the bias states c.11.2 under ``bias``) with input ``u`` over ``dt`` under
    the noises ``U`` and ``Q`` by motion model ``model`` (``odometer``: an odometer's reading, kept for
    c.13.2's rate; else a body-velocity input, c.10.5). Returns ``(ok, carry)``; not ``ok`` when the
    prediction would make the state non-finite (the state is then unchanged and the carry the same)."""
    u_last, has_u = (u, True) if odometer else (c.u_last, c.has_u)
    if not predict_step(c.x, c.P, u, dt, U, Q, c.pose_first, model, cfg, bias):      # c.2, c.11.2
        return False, c
    return True, Carry(c.x, c.P, c.pose_first, c.lm, c.N, c.next_id, c.tent, c.retired, c.n_retired, c.arcs,
                       c.n_arcs, c.mem, c.n_mem, c.n_now, c.dt_since + dt, u_last, has_u, c.scans)


@njit(cache=True, inline="always")
def scan_event(c, stream, s, a_rows, n_arows, noise, cfg, view, jcbb, bias):  # pragma: no cover - compiled
    """Scan ``s`` of ``stream`` (a :class:`~radarslam.slam.fused.stream.Stream`) through a.8 steps 2-10 in
    the order of docs/method.md a.8, in its radar's frame at its time (c.13-c.13.4). ``a_rows[:n_arows]`` are
    the ``(scan, detection, landmark id)`` rows of the associations so far, this scan's appended.
    Returns ``(carry, polar, n_assoc, nis, a_rows, n_arows, out)``: the scan's detections, the number
    associated, the NIS of each update (2 dof) and what else the scan did (:class:`ScanOut`)."""
    x, P, lm, N = c.x, c.P, c.lm, c.N
    polar = stream.polar[stream.scan_off[s]:stream.scan_off[s + 1]]
    k = stream.scan_k[s]
    no_rate = np.zeros(3)
    rate = scan_rate(x, c.u_last, cfg) if bias and c.has_u and stream.tau_i[s] >= 0 else no_rate  # c.13.2
    x_held, P_held = held(x, P, POSE_DIM, cfg.held_end)                             # c.13.4
    pose_first = enter_sensor(x, P, stream, s, c.pose_first, rate)                # c.13: its radar, its time
    mem, n_mem, n_now = c.mem, c.n_mem, c.n_now
    if cfg.doppler_gate and stream.remember[s]:                                    # c.10.4.3
        seen = stream.seen[stream.seen_off[s]:stream.seen_off[s + 1]]
        mem, n_mem, n_now = remember(mem, n_mem, seen, x, k, cfg)
    dt = c.dt_since if c.scans > 0 else 0.0
    view_walk(x, P, lm, N, cfg)                                                    # a.12.5 (partial view)
    prior = _blocks(x, P, cfg.platform)                                            # Decision 3
    cand, shapes, terms = sift_step(x, P, polar, lm, N, prior, noise, cfg, view)  # 3
    cidx = np.flatnonzero(cand)
    x, P, out, nis = associate_step(x, P, polar, cidx, lm, N, pose_first, shapes, terms, noise, cfg,
                                    view, jcbb)                                    # 4
    rehold(x, P, x_held, P_held, stream, s, rate)                                  # c.13.4
    n_assoc, aoff, arow, a_rows, n_arows = group_associations(out, cidx, N, lm.ids, s, a_rows, n_arows)
    young = moving_young(x, lm, N, k, mem, n_now, cfg)                             # c.10.4.4
    retired, n_retired, arcs, n_arcs = c.retired, c.n_retired, c.arcs, c.n_arcs
    ids0 = lm.ids[:N].copy()
    x, P, N, old, retired, n_retired = remove_unseen(x, P, lm, N, aoff, k, young, stream.sensor_view[s],
                                                     retired, n_retired, arcs, cfg)  # 5, c.15
    xy = _to_world(x, polar)                                                       # seed eq. (3), updated pose
    lm, arcs, n_arcs = extent_step(x, P, polar, xy, lm, N, old, aoff, arow, prior, dt, arcs, n_arcs,
                                   noise, cfg, view)                               # 6
    clusters = cluster(xy, polar, cand, cfg)                                       # 7
    fresh = alpha_test(x, P, polar, clusters, noise, cfg)                          # 7
    fresh = veto(fresh, clusters, xy, mem, n_mem, cfg)                             # c.10.4.3
    confirmed, tent = confirm(c.tent, fresh, clusters, xy, cfg)                    # 8
    x, P, lm, N, next_id = augment(x, P, lm, N, c.next_id, confirmed, clusters, polar, k, noise, cfg)  # 9
    x, P, lm, N, merged = merge(x, P, lm, N, arcs, cfg)                            # 10
    leave_sensor(x, P, stream, s, rate, x_held, P_held)                            # c.13, c.13.4
    nxt = Carry(x, P, c.pose_first, lm, N, next_id, tent, retired, n_retired, arcs, n_arcs, mem, n_mem, n_now,
                0.0, c.u_last, c.has_u, c.scans + 1)
    new_off, new_rows = _new_members(confirmed, clusters)
    out = ScanOut(np.int64(cidx.shape[0]), np.int64(clusters.size.shape[0]),
                  _removed(ids0, old, retired, c.n_retired, n_retired), merged, c.next_id, new_off, new_rows)
    return nxt, polar, n_assoc, nis, a_rows, n_arows, out
