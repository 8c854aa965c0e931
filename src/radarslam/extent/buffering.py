"""The extent's initialisation (docs/method.md a.3) and what a merge does with it (c.9): kernels
that the extent estimators (:mod:`radarslam.extent.estimator` and its subclasses) call as Python
and the fused engine (:mod:`radarslam.slam.fused.extent`, :mod:`~radarslam.slam.fused.mapping`)
compiles as they are (:mod:`radarslam.extent._compiled`).

A landmark without an extent holds its associated detections (world frame) in a buffer, an
``(B, 2)`` array whose first ``n`` rows are in use, in order of arrival.
"""

from __future__ import annotations

import numpy as np

from radarslam.extent.ellipse_fit import fit_entries

#: Outcomes of :func:`buffer_and_fit`: still waiting; fitted (initialise with the entries);
#: the fit failed and the buffer was cut to the newest ``n_init`` detections.
WAIT, READY, RETRY = 0, 1, 2
#: Outcomes of :func:`merge_outcome`: the survivor keeps its extent; takes the other's; the two
#: buffers are pooled (the survivor's first).
KEEP, TAKE, POOL = 0, 1, 2


def buffer_and_fit(buf, n, pts, n_init, gamma):
    """a.3 for one landmark and one scan: append the detections ``pts (m, 2)`` to ``buf`` after its
    ``n`` held rows (room for ``n + m`` assumed), then, once more than ``n_init`` are held, fit the
    EFA upper bound (Decision 4) with spread factor ``gamma`` (a.11) to all of them. A degenerate
    fit keeps only the newest ``n_init`` (moved to the front, in order) and waits for more.

    Returns ``(outcome, n_held, X11, X12, X22)``: :data:`WAIT` with the count held; :data:`READY`
    with the count fitted (still in ``buf``) and the extent's entries; :data:`RETRY` with
    ``n_init``. A kernel."""
    m = pts.shape[0]
    for a in range(m):
        buf[n + a, 0] = pts[a, 0]
        buf[n + a, 1] = pts[a, 1]
    n += m
    if n <= n_init:
        return WAIT, n, 0.0, 0.0, 0.0
    ok, _, _, e11, e12, e22 = fit_entries(buf[:n], True, 0.0, 0.0, 0.0, gamma)
    if ok:
        return READY, n, e11, e12, e22
    for q in range(n_init):                              # forward: the source is never overwritten first
        buf[q, 0] = buf[n - n_init + q, 0]
        buf[q, 1] = buf[n - n_init + q, 1]
    return RETRY, n_init, 0.0, 0.0, 0.0


def merge_outcome(survivor_ready, gone_ready):
    """c.9 [PROP]: what the surviving landmark of a merge does with the extents: keeps its own
    (:data:`KEEP`), takes the other's when it has none yet (:data:`TAKE`), and two landmarks
    without one pool their buffered detections (:data:`POOL`). A kernel."""
    if survivor_ready:
        return KEEP
    return TAKE if gone_ready else POOL


def buffered_scatter(buf, n):
    """The sample covariance (2, 2) of the ``n >= 2`` buffered detections ``buf[:n]`` (divisor ``n - 1``,
    as ``np.cov``): the spread of a landmark not yet initialised under ``extent.pre_init_spread =
    "scatter"`` (docs/method.md a.7.2). A kernel."""
    m0, m1 = 0.0, 0.0
    for i in range(n):
        m0 += buf[i, 0]
        m1 += buf[i, 1]
    m0 /= n
    m1 /= n
    s00, s01, s11 = 0.0, 0.0, 0.0
    for i in range(n):
        d0, d1 = buf[i, 0] - m0, buf[i, 1] - m1
        s00 += d0 * d0
        s01 += d0 * d1
        s11 += d1 * d1
    out = np.empty((2, 2))
    out[0, 0], out[0, 1], out[1, 0], out[1, 1] = s00 / (n - 1), s01 / (n - 1), s01 / (n - 1), s11 / (n - 1)
    return out


KERNELS = (buffer_and_fit, merge_outcome, buffered_scatter)
