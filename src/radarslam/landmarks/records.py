"""The confirmed landmarks' bookkeeping as arrays: ids, creation scans, the M/N windows and the
first estimates, in state order (docs/method.md a.8 steps 5, 9 and 10; c.5, c.8, c.9, c.2.1).

One :class:`Records` holds them for :class:`~radarslam.slam.state.SlamState`
and for the fused engine (:mod:`radarslam.slam.fused.storage`) alike; the functions below are the
only code that adds, moves or grows the rows. They are kernels (``core.jit``): the state
calls them as Python, the fused engine compiles them as they are (:mod:`radarslam.landmarks._compiled`).
Rows ``0 .. n - 1`` are in use; the arrays' length is the capacity (grown by doubling), so that a
landmark's birth does not copy the others' records.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from radarslam.core.arrays import grown


class Records(NamedTuple):
    """Bookkeeping of the confirmed landmarks in state order (rows ``0 .. n - 1`` in use)."""

    ids: np.ndarray        #: (L,) int64, landmark ids
    created: np.ndarray    #: (L,) int64, the scan of each landmark's birth
    mbits: np.ndarray      #: (L,) int64, M/N window of associations (c.5), newest scan in bit 0
    rbits: np.ndarray      #: (L,) int64, M/N window of scans in view or associated (c.5)
    first: np.ndarray      #: (L, 2) first estimates: the centroids at birth (FEJ, c.2.1)


def new_records(cap):
    """Empty records with room for ``cap`` landmarks; a kernel."""
    return Records(np.zeros(cap, dtype=np.int64), np.zeros(cap, dtype=np.int64), np.zeros(cap, dtype=np.int64),
                   np.zeros(cap, dtype=np.int64), np.zeros((cap, 2)))


def with_room(rec, n):
    """``rec`` with room for at least ``n`` landmarks: ``rec`` itself, or every array grown alike
    by :func:`radarslam.core.arrays.grown` (doubling), the old rows kept; a kernel."""
    if n <= rec.ids.shape[0]:
        return rec
    return Records(grown(rec.ids, n), grown(rec.created, n), grown(rec.mbits, n), grown(rec.rbits, n),
                   grown(rec.first, n))


def add_record(rec, n, lid, created, fx, fy):
    """Step 9 (c.8): record landmark ``lid`` born at scan ``created`` with first estimate
    ``[fx, fy]`` in row ``n``; its M/N windows hold the birth scan's association (c.5). Returns
    the records (new arrays when they had to grow); a kernel."""
    rec = with_room(rec, n + 1)
    rec.ids[n] = lid
    rec.created[n] = created
    rec.mbits[n] = 1
    rec.rbits[n] = 1
    rec.first[n, 0] = fx
    rec.first[n, 1] = fy
    return rec


def compact_records(rec, keep):
    """Steps 5 and 10 (c.5, c.9): move the rows ``j < keep.shape[0]`` whose ``keep[j]`` is True to
    the front, in order, in place. Returns each survivor's row before the move ``(n_keep,)``, by
    which the owner of any other per-landmark state moves it alike; a kernel."""
    n = keep.shape[0]
    old = np.empty(n, dtype=np.int64)
    q = 0
    for j in range(n):
        if keep[j]:
            old[q] = j
            if q != j:
                rec.ids[q] = rec.ids[j]
                rec.created[q] = rec.created[j]
                rec.mbits[q] = rec.mbits[j]
                rec.rbits[q] = rec.rbits[j]
                rec.first[q, 0] = rec.first[j, 0]
                rec.first[q, 1] = rec.first[j, 1]
            q += 1
    return old[:q]


KERNELS = (new_records, with_room, add_record, compact_records)
