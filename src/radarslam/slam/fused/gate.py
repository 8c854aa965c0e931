"""The fused engine's part of the Doppler gate (``filter.doppler_gate``, docs/method.md c.10.4).

Which detections of a scan belong to moving objects depends on the scan alone (its Doppler fit and
tests, c.10.2, c.10.4.1-c.10.4.2): :func:`~radarslam.slam.fused.plan._stream_arrays` runs
:meth:`~radarslam.slam.doppler_gate.DopplerGate.classify` before the engine, which gets the kept
detections and, per scan, the moving objects' detections in the platform frame. What depends on
the filter's state is here, as :class:`~radarslam.slam.doppler_gate.DopplerGate` does it: the
memory in the world frame of the pose at the scan (:func:`remember`, c.10.4.3), the young
landmarks a moving object was seen on (:func:`moving_young`, removed with step 5, c.10.4.4), and
the veto of new clusters near a remembered moving detection (:func:`veto`, step 7). ``cfg`` is
the engine's :class:`~radarslam.slam.fused.plan.FusedParams`. The three steps are compiled as
functions of their own, not inlined into ``run_stream`` (as the extent step's row kernels, ``extent.rows``): inlined,
they made the engine's cold compilation longer (about 128-143 s of CPU against 126 s, measured
under load with ``NUMBA_CACHE_DIR`` fresh).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from radarslam.core.jit import compiled_only
from radarslam.slam.fused.storage import Memory, _grow_rows


@compiled_only
def remember(mem, n_mem, seen, x, k, cfg):  # pragma: no cover - compiled
    """DopplerGate._remember of scan ``k``: its moving detections ``seen`` (platform frame) in the
    world frame of the pose ``x[:3]`` become the current ones; the memory forgets those of
    ``cfg.gate_memory`` scans ago and more, and keeps these. Returns ``(mem, n_mem, n_now)``."""
    c, s = math.cos(x[2]), math.sin(x[2])
    m = seen.shape[0]
    now = _grow_rows(mem.now, m)
    for i in range(m):
        now[i, 0] = x[0] + c * seen[i, 0] - s * seen[i, 1]
        now[i, 1] = x[1] + s * seen[i, 0] + c * seen[i, 1]
    xy, ks = mem.xy, mem.k
    q = 0
    for r in range(n_mem):
        if k - ks[r] < cfg.gate_memory:
            xy[q, 0], xy[q, 1], ks[q] = xy[r, 0], xy[r, 1], ks[r]
            q += 1
    if cfg.gate_memory > 0 and m > 0:
        xy, ks = _grow_rows(xy, q + m), _grow_rows(ks, q + m)
        for i in range(m):
            xy[q + i, 0], xy[q + i, 1], ks[q + i] = now[i, 0], now[i, 1], k
        q += m
    return Memory(xy, ks, now), q, m


@njit(cache=True, inline="always")
def _near(px, py, pts, n, r2):  # pragma: no cover - compiled
    """Whether ``(px, py)`` lies within ``sqrt(r2)`` of one of the first ``n`` rows of ``pts``."""
    for i in range(n):
        d0 = px - pts[i, 0]
        d1 = py - pts[i, 1]
        if d0 * d0 + d1 * d1 <= r2:
            return True
    return False


@compiled_only
def moving_young(x, lm, N, k, mem, n_now, cfg):  # pragma: no cover - compiled
    """DopplerGate.moving_landmarks (c.10.4.4): per landmark, whether it was created less than
    ``cfg.gate_probation`` scans before scan ``k`` and lies within ``cfg.gate_radius`` of the
    current moving detections (the first ``n_now`` rows of ``mem.now``)."""
    out = np.zeros(N, dtype=np.bool_)
    if not cfg.doppler_gate or cfg.gate_probation <= 0 or n_now == 0:
        return out
    r2 = cfg.gate_radius * cfg.gate_radius
    for j in range(N):
        if k - lm.created[j] < cfg.gate_probation:
            out[j] = _near(x[cfg.platform + 2 * j], x[cfg.platform + 1 + 2 * j], mem.now, n_now, r2)
    return out


@compiled_only
def veto(fresh, clusters, xy, mem, n_mem, cfg):  # pragma: no cover - compiled
    """DopplerGate.veto (c.10.4.3): the clusters ``fresh`` with no detection (world positions
    ``xy``) within ``cfg.gate_radius`` of a remembered moving detection, in order."""
    if not cfg.doppler_gate or n_mem == 0 or fresh.shape[0] == 0:
        return fresh
    r2 = cfg.gate_radius * cfg.gate_radius
    rest, labels = clusters.rest, clusters.labels
    out = np.empty(fresh.shape[0], dtype=np.int64)
    n = 0
    for f in range(fresh.shape[0]):
        hit = False
        for b in range(rest.shape[0]):
            if labels[b] == fresh[f] and _near(xy[rest[b], 0], xy[rest[b], 1], mem.xy, n_mem, r2):
                hit = True
                break
        if not hit:
            out[n] = fresh[f]
            n += 1
    return out[:n]
