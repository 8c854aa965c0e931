"""Confirmation of new landmarks (Rule 1 / Rule 2, docs/method.md c.7) and M/N removal windows (c.5)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from radarslam.core.angles import wrap_pi_scalar


class Tentatives(NamedTuple):
    """The unconfirmed landmarks of Rule 2 (c.7), one row each, as
    :class:`~radarslam.slam.state.SlamState` and the fused engine keep them."""

    centre: np.ndarray     #: (T, 2) the last matched cluster's centre detection, world frame [m]
    count: np.ndarray      #: (T,) int64, scans in which it was matched
    window: np.ndarray     #: (T,) int64, scans since it was created
    npts: np.ndarray       #: (T,) int64, points of the last matched cluster


def no_tentatives() -> Tentatives:
    """No tentatives."""
    return Tentatives(np.empty((0, 2)), np.empty(0, dtype=np.int64), np.empty(0, dtype=np.int64),
                      np.empty(0, dtype=np.int64))


def rule12(t_centre, t_count, t_window, t_npts, c_centre, c_size, gate, confirm_points, window, hits):
    """One scan of Rule 2 then Rule 1 (c.7) over arrays; a kernel (``core.jit``) that the fused
    engine compiles as it is.

    Tentative ``t`` is ``(t_centre[t], t_count[t], t_window[t], t_npts[t])``; cluster ``c`` (one
    that passed the alpha test) has its centre detection ``c_centre[c]`` and ``c_size[c]`` points.

    1. Greedy one-to-one matching, closest pair first (distances in row-major order, a stable
       sort), while the distance is below ``gate`` (gamma_a): the tentative's count grows by one,
       its centre and points become the cluster's; it is confirmed with ``count >= hits`` or
       ``npts >= confirm_points``.
    2. The tentatives not confirmed age (``window + 1``) and are dropped at ``window >= window``
       or when ``count + window - age < hits`` (they can no longer reach ``hits``).
    3. An unmatched cluster is confirmed at once with ``size >= confirm_points`` (Rule 1), else it
       becomes a tentative with count and age 1.

    Returns ``(confirmed clusters in order, new t_centre, t_count, t_window, t_npts)``."""
    T, C = t_count.shape[0], c_size.shape[0]
    confirmed = np.empty(C, dtype=np.int64)
    n_conf = 0
    count, npts, centre = t_count.copy(), t_npts.copy(), t_centre.copy()
    matched_c = np.zeros(C, dtype=np.bool_)
    consumed = np.zeros(T, dtype=np.bool_)
    if T > 0 and C > 0:
        d = np.empty(T * C)
        for t in range(T):
            for c in range(C):
                d0 = t_centre[t, 0] - c_centre[c, 0]
                d1 = t_centre[t, 1] - c_centre[c, 1]
                d[t * C + c] = math.sqrt(d0 * d0 + d1 * d1)
        matched_t = np.zeros(T, dtype=np.bool_)
        for flat in np.argsort(d, kind="mergesort"):
            if d[flat] >= gate:
                break
            t, c = flat // C, flat % C
            if matched_t[t] or matched_c[c]:
                continue
            matched_t[t] = True
            matched_c[c] = True
            count[t] += 1
            centre[t, 0], centre[t, 1] = c_centre[c, 0], c_centre[c, 1]
            npts[t] = c_size[c]
            if count[t] >= hits or npts[t] >= confirm_points:
                confirmed[n_conf] = c
                n_conf += 1
                consumed[t] = True
    o_centre = np.empty((T + C, 2))
    o_count = np.empty(T + C, dtype=np.int64)
    o_window = np.empty(T + C, dtype=np.int64)
    o_npts = np.empty(T + C, dtype=np.int64)
    n = 0
    for t in range(T):
        age = t_window[t] + 1
        if consumed[t] or age >= window or count[t] + window - age < hits:
            continue
        o_centre[n, 0], o_centre[n, 1] = centre[t, 0], centre[t, 1]
        o_count[n], o_window[n], o_npts[n] = count[t], age, npts[t]
        n += 1
    for c in range(C):
        if matched_c[c]:
            continue
        if c_size[c] >= confirm_points:
            confirmed[n_conf] = c
            n_conf += 1
        else:
            o_centre[n, 0], o_centre[n, 1] = c_centre[c, 0], c_centre[c, 1]
            o_count[n], o_window[n], o_npts[n] = 1, 1, c_size[c]
            n += 1
    return (confirmed[:n_conf].copy(), o_centre[:n].copy(), o_count[:n].copy(), o_window[:n].copy(),
            o_npts[:n].copy())


def popcount(v):
    """Number of set bits of the non-negative integer ``v``; a kernel (``core.jit``)."""
    c = 0
    while v:
        c += v & 1
        v >>= 1
    return c


def push_bit(window, bit, length):
    """Shift a newest-first bit window (bit 0 = this scan) and keep ``length`` bits; a kernel."""
    return ((window << 1) | (1 if bit else 0)) & ((1 << length) - 1)


def should_remove(k, created, assoc, in_range, window, max_hits):
    """M/N removal (c.5): old enough, in range in all of the last M scans, associated in <= N; a
    kernel."""
    return k - window + 1 >= created and popcount(in_range) == window and popcount(assoc) <= max_hits


def mn_windows(assoc, in_range, created, hit, in_view, k, window, max_hits):
    """One scan of the M/N removal windows (c.5, every scan, Decision 8) over arrays, in place; a
    kernel that the fused engine
    compiles as it is. Landmark ``j`` pushes whether it was associated (``hit[j]``) and whether it
    was in range (``in_view[j]``; an associated landmark counts as in range) into its windows
    ``assoc[j]``, ``in_range[j]``. Returns which landmarks stay (boolean)."""
    n = assoc.shape[0]
    keep = np.ones(n, dtype=np.bool_)
    for j in range(n):
        h = bool(hit[j])
        assoc[j] = push_bit(assoc[j], h, window)
        in_range[j] = push_bit(in_range[j], h or bool(in_view[j]), window)
        if should_remove(k, created[j], assoc[j], in_range[j], window, max_hits):
            keep[j] = False
    return keep


def in_view(x, platform, n, max_range, half_fov):
    """Which of the ``n`` landmarks of the state ``x`` (centroids after the ``platform`` block) the
    sensor at ``x``'s pose covers: within ``max_range`` and, for a sensor that does not see all
    around (``half_fov < pi``, rad), within the field of view centred on the heading (the "in
    range" of the M/N removal, c.5). Boolean ``(n,)``; a kernel that the fused engine
    compiles as it is."""
    out = np.empty(n, dtype=np.bool_)
    for j in range(n):
        i = platform + 2 * j
        dx = x[i] - x[0]
        dy = x[i + 1] - x[1]
        v = math.hypot(dx, dy) <= max_range
        if half_fov < math.pi:
            v = v and abs(wrap_pi_scalar(math.atan2(dy, dx) - x[2])) <= half_fov
        out[j] = v
    return out


