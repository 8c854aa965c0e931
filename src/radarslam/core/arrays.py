"""Arrays that grow by doubling, written once for every layer (docs/architecture.md "Backends").

The landmark records (:mod:`radarslam.landmarks.records`), the fused engine's per-landmark and
per-scan arrays (:mod:`radarslam.slam.fused.storage`) and the extent estimators' detection buffers
(:mod:`radarslam.extent.estimator`) keep a capacity larger than the rows in use, so that adding a
row does not copy the others. :func:`grown` is the one rule by which they grow (:func:`grown_inner`
along the second axis, for the per-landmark buffers). It is a kernel
(:mod:`radarslam.core.jit`): the Python backend calls it as it is, the compiled code compiles it.
"""

from __future__ import annotations

import numpy as np


def grown(a, n):
    """``a`` with room for at least ``n`` rows along its first axis: ``a`` itself when it has
    them, else a new array of ``max(n, 2 * len(a))`` rows, of ``a``'s dtype, holding ``a``'s rows
    first and zeros after. A kernel."""
    cap = a.shape[0]
    if n <= cap:
        return a
    out = np.zeros((max(n, 2 * cap),) + a.shape[1:], dtype=a.dtype)
    out[:cap] = a
    return out


def grown_inner(a, n):
    """``a (L, B, ...)`` with room for at least ``n`` entries along its second axis (a buffer per
    row): ``a`` itself when it has them, else a new array of ``max(n, 2 * B)`` columns, ``a``'s
    first and zeros after. A kernel."""
    cap = a.shape[1]
    if n <= cap:
        return a
    out = np.zeros((a.shape[0], max(n, 2 * cap)) + a.shape[2:], dtype=a.dtype)
    out[:, :cap] = a
    return out


#: The kernels of this module.
KERNELS = (grown, grown_inner)
