"""The Doppler gate's steps that depend on the filter's state (docs/method.md c.10.4.3-c.10.4.4) as
kernels: the memory of the moving objects' detections in the world frame, the young landmarks a
moving object was seen on, the veto of a new cluster near a remembered moving detection.
:class:`~radarslam.slam.doppler_gate.DopplerGate` calls them as Python (its unit tests) and the
fused engine (:mod:`radarslam.slam.fused.gate`) compiled, so each is written once.
"""

from __future__ import annotations

import math

import numpy as np


def near_any(px, py, pts, n, r2):
    """Whether ``(px, py)`` lies within ``sqrt(r2)`` of one of the first ``n`` rows of ``pts``. A kernel."""
    for i in range(n):
        d0 = px - pts[i, 0]
        d1 = py - pts[i, 1]
        if d0 * d0 + d1 * d1 <= r2:
            return True
    return False


def remember_rows(xy, ks, n_mem, seen, pose, k, memory):
    """c.10.4.3 for scan ``k``: its moving detections ``seen (m, 2)`` (platform frame) in the world frame
    of ``pose`` become the current ones ``now``; of the remembered ``xy[:n_mem]`` (scans ``ks``, oldest
    first) those of ``memory`` scans ago and more are forgotten, and with ``memory > 0`` the current
    ones are kept after them. Returns ``(xy, ks, n, now)``: the arrays (new ones when they had no
    room), the count remembered. A kernel."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    m = seen.shape[0]
    now = np.empty((m, 2))
    for i in range(m):
        now[i, 0] = pose[0] + c * seen[i, 0] - s * seen[i, 1]
        now[i, 1] = pose[1] + s * seen[i, 0] + c * seen[i, 1]
    q = 0
    for r in range(n_mem):
        if k - ks[r] < memory:
            xy[q, 0], xy[q, 1], ks[q] = xy[r, 0], xy[r, 1], ks[r]
            q += 1
    if memory > 0 and m > 0:
        if xy.shape[0] < q + m:                          # room for them: double, at least
            cap = max(2 * xy.shape[0], q + m)
            xy2, ks2 = np.empty((cap, 2)), np.empty(cap, dtype=np.int64)
            xy2[:q], ks2[:q] = xy[:q], ks[:q]
            xy, ks = xy2, ks2
        for i in range(m):
            xy[q + i, 0], xy[q + i, 1], ks[q + i] = now[i, 0], now[i, 1], k
        q += m
    return xy, ks, q, now


def moving_young_rows(pos, created, k, now, probation, r2):
    """c.10.4.4: per landmark (positions ``pos (N, 2)``, created at scans ``created``), whether it
    was created less than ``probation`` scans before scan ``k`` and lies within ``sqrt(r2)`` of a
    detection of this scan's moving objects ``now``. A kernel."""
    N = pos.shape[0]
    out = np.zeros(N, dtype=np.bool_)
    if probation <= 0 or now.shape[0] == 0:
        return out
    for j in range(N):
        if k - created[j] < probation:
            out[j] = near_any(pos[j, 0], pos[j, 1], now, now.shape[0], r2)
    return out


def any_near(pts, mem, n_mem, r2):
    """Whether one of the points ``pts (m, 2)`` lies within ``sqrt(r2)`` of one of the first
    ``n_mem`` rows of ``mem`` (the veto of a cluster, c.10.4.3). A kernel."""
    for a in range(pts.shape[0]):
        if near_any(pts[a, 0], pts[a, 1], mem, n_mem, r2):
            return True
    return False


KERNELS = (near_any, remember_rows, moving_young_rows, any_near)
