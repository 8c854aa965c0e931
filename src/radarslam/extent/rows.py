"""The extent step over array-held states (docs/method.md a.8 step 6; docs/architecture.md
"Extent estimators"): written once, for the fused engine and the orchestrator alike.

Every landmark's extent state is a row of a record of arrays (:class:`ExtentRows`, or the fused
engine's :class:`~radarslam.slam.fused.storage.Landmarks`, which has the same fields by name).
The functions below are *kernels* (:mod:`radarslam.core.jit`): plain Python that the reference
backend runs as it is and :mod:`radarslam.extent._compiled` compiles as it is, so the two backends
share the arithmetic and the bookkeeping. The fused engine calls them compiled on its records;
the orchestrator's built-in estimators (:mod:`.estimator`), which hold one object per landmark for
the plug-in protocol, gather those objects into an :class:`ExtentRows`, call the same function
and write the rows back.

The scan's detections reach them as the associator left them: landmark ``j`` (a row, ``0 ..
N - 1``) has the association row ``o = old[j]``, whose detections are ``arow[aoff[o]:aoff[o + 1]]``
of ``polar`` (sensor frame) and ``xy`` (world frame of the updated pose).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from radarslam.extent.buffering import READY, buffer_and_fit
from radarslam.extent.ellipse_fit import fit_entries
from radarslam.extent.measurement import max_trace_w_entries
from radarslam.extent.random_matrix import rm_predict_alpha, rm_update_entries


class ExtentRows(NamedTuple):
    """The random-matrix and EFA states of ``N`` landmarks (a.3-a.5, Decision 5), one row each."""

    einit: np.ndarray      #: (N,) bool, extent initialised
    X: np.ndarray          #: (N, 2, 2) RMA extents
    alpha: np.ndarray      #: (N,) RMA degrees of freedom
    Xefa: np.ndarray       #: (N, 2, 2) EFA extents
    nbuf: np.ndarray       #: (N,) int64, detections held before the extent is initialised (a.3)
    buf: np.ndarray        #: (N, B, 2) those detections in the world frame


def detections(xy, aoff, arow, o):
    """The rows of ``xy`` associated in association row ``o``, as a new ``(m, 2)`` array. A kernel."""
    m = aoff[o + 1] - aoff[o]
    out = np.empty((m, 2))
    for a in range(m):
        out[a, 0] = xy[arow[aoff[o] + a], 0]
        out[a, 1] = xy[arow[aoff[o] + a], 1]
    return out


def buffer_need(E, ready, N, old, aoff):
    """The buffer length :func:`initialise_rows` needs: the largest ``nbuf + m`` over the
    landmarks not ``ready``. A kernel."""
    need = 0
    for j in range(N):
        if not ready[j]:
            need = max(need, E.nbuf[j] + aoff[old[j] + 1] - aoff[old[j]])
    return need


def initialise_rows(E, ready, born, N, old, aoff, arow, xy, n_init, gamma, alpha0):
    """a.3 for every landmark ``j < N`` not ``ready`` (extent not initialised before this scan):
    its detections are buffered (:func:`~.buffering.buffer_and_fit`; ``E.buf`` must have room for
    :func:`buffer_need`), and once fitted the extent is ``X = X_EFA`` of the fit with ``alpha_0``.
    ``born[j]`` becomes the number of detections fitted for a landmark initialised now, else 0.
    In place. A kernel."""
    for j in range(N):
        born[j] = 0
        if ready[j]:
            continue
        outcome, n, e11, e12, e22 = buffer_and_fit(E.buf[j], E.nbuf[j], detections(xy, aoff, arow, old[j]),
                                                   n_init, gamma)
        if outcome != READY:
            E.nbuf[j] = n
            continue
        E.einit[j] = True
        E.X[j, 0, 0], E.X[j, 0, 1], E.X[j, 1, 0], E.X[j, 1, 1] = e11, e12, e12, e22
        E.alpha[j] = alpha0
        E.Xefa[j] = E.X[j]
        E.nbuf[j] = 0
        born[j] = n


def rma_efa_rows(E, ready, N, old, aoff, arow, polar, xy, cents, ccovs, pose, pose_cov, R, W, w_given, dt, tau,
                 gamma, eig_floor, upper, efa):
    """a.4-a.5 and the EFA baseline of Decision 5 for every landmark ``j < N`` ``ready``: the RM
    prediction over ``dt`` (seed eqs. 8-9), and with detections the update (seed eqs. 10-20) about
    the centroid ``cents[j]`` of covariance ``ccovs[j]`` with the scan's ``W`` (seed eq. 5, the
    ``W(i)`` of largest trace, h.3; ``W[j]`` instead when ``w_given``), then, with ``efa``, the fit
    of the scan (d.3; the upper bound when ``upper``), kept when it succeeds. In place. A kernel."""
    theta = pose[2]
    for j in range(N):
        if not ready[j]:
            continue
        a = E.alpha[j]
        if dt > 0.0:
            a = rm_predict_alpha(a, dt, tau)
        E.alpha[j] = a
        o = old[j]
        if aoff[o + 1] == aoff[o]:
            continue
        pol = detections(polar, aoff, arow, o)
        pts = detections(xy, aoff, arow, o)
        if w_given:
            w00, w01, w11 = W[j, 0, 0], W[j, 0, 1], W[j, 1, 1]
        else:
            w00, w01, w11 = max_trace_w_entries(theta, pose_cov[0, 0], pose_cov[0, 1], pose_cov[0, 2], pose_cov[1, 1],
                                                pose_cov[1, 2], pose_cov[2, 2], R[0, 0], R[0, 1], R[1, 1], pol)
        n11, n12, n22, a = rm_update_entries(E.X[j, 0, 0], E.X[j, 0, 1], E.X[j, 1, 1], a, cents[j, 0], cents[j, 1],
                                             ccovs[j, 0, 0], ccovs[j, 0, 1], ccovs[j, 1, 1], pts, w00, w01, w11,
                                             gamma, eig_floor)
        E.X[j, 0, 0], E.X[j, 0, 1], E.X[j, 1, 0], E.X[j, 1, 1] = n11, n12, n12, n22
        E.alpha[j] = a
        if efa:
            ok, _, _, e11, e12, e22 = fit_entries(pts, upper, w00, w01, w11, gamma)
            if ok:
                E.Xefa[j, 0, 0], E.Xefa[j, 0, 1], E.Xefa[j, 1, 0], E.Xefa[j, 1, 1] = e11, e12, e12, e22


KERNELS = (detections, buffer_need, initialise_rows, rma_efa_rows)
