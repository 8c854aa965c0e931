"""The fused engine's part of the Doppler gate (``filter.doppler_gate``, docs/method.md c.10.4).

Which detections of a scan belong to moving objects depends on the scan alone (its Doppler fit and
tests, c.10.2, c.10.4.1-c.10.4.2): :func:`~radarslam.slam.fused.plan._stream_arrays` runs
:meth:`~radarslam.slam.doppler_gate.DopplerGate.classify` before the engine, which gets the kept
detections and, per scan, the moving objects' detections in the platform frame. What depends on
the filter's state is here, as :class:`~radarslam.slam.doppler_gate.DopplerGate` does it: the
memory in the world frame of the pose at the scan (:func:`remember`, c.10.4.3), the young
landmarks a moving object was seen on (:func:`moving_young`, removed with step 5, c.10.4.4), and
the veto of new clusters near a remembered moving detection (:func:`veto`, step 7), each over the
kernels of :mod:`radarslam.slam.gate_kernels`. ``cfg``
is the engine's :class:`~radarslam.slam.fused.plan.FusedParams`.
"""

from __future__ import annotations

import numpy as np

from radarslam.core.jit import compile_kernels, compiled_only
from radarslam.slam import gate_kernels
from radarslam.slam.fused.storage import Memory


#: The gate's kernels (slam/gate_kernels.py), compiled as they are.
_K = compile_kernels(*gate_kernels.KERNELS)
near_any, remember_rows, moving_young_rows = _K["near_any"], _K["remember_rows"], _K["moving_young_rows"]


@compiled_only
def remember(mem, n_mem, seen, x, k, cfg):  # pragma: no cover - compiled
    """DopplerGate._remember of scan ``k`` (:func:`~radarslam.slam.gate_kernels.remember_rows`):
    returns ``(mem, n_mem, n_now)``."""
    xy, ks, q, now = remember_rows(mem.xy, mem.k, n_mem, seen, x[:3], k, cfg.gate_memory)
    return Memory(xy, ks, now), q, now.shape[0]


@compiled_only
def moving_young(x, lm, N, k, mem, n_now, cfg):  # pragma: no cover - compiled
    """DopplerGate.moving_landmarks (c.10.4.4, :func:`~radarslam.slam.gate_kernels.moving_young_rows`):
    per landmark, whether it is young and near a moving detection of this scan (``mem.now[:n_now]``)."""
    if not cfg.doppler_gate or cfg.gate_probation <= 0 or n_now == 0:   # nothing seen moving: none young
        return np.zeros(N, dtype=np.bool_)
    pos = np.empty((N, 2))
    for j in range(N):
        pos[j, 0], pos[j, 1] = x[cfg.platform + 2 * j], x[cfg.platform + 1 + 2 * j]
    return moving_young_rows(pos, lm.created[:N], k, mem.now[:n_now], cfg.gate_probation,
                             cfg.gate_radius * cfg.gate_radius)


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
            if labels[b] == fresh[f] and near_any(xy[rest[b], 0], xy[rest[b], 1], mem.xy, n_mem, r2):
                hit = True
                break
        if not hit:
            out[n] = fresh[f]
            n += 1
    return out[:n]
