"""The extent step over array-held states (docs/method.md a.8 step 6; docs/architecture.md
"Extent estimators"): written once, for the fused engine and the estimators' own methods alike.

Every landmark's extent state is a row of a record of arrays (:class:`ExtentRows`, or the fused
engine's :class:`~radarslam.slam.fused.storage.Landmarks`, which has the same fields by name).
The functions below are *kernels* (:mod:`radarslam.core.jit`): plain Python that the reference
backend runs as it is and :mod:`radarslam.extent._compiled` compiles as it is, so the two backends
share the arithmetic and the bookkeeping. The fused engine calls them compiled on its records;
the built-in estimators' own methods (:mod:`.estimator`), which hold one object per landmark for
the plug-in protocol, gather those objects into an :class:`ExtentRows`, call the same function
and write the rows back.

The scan's detections reach them as the associator left them: landmark ``j`` (a row, ``0 ..
N - 1``) has the association row ``o = old[j]``, whose detections are ``arow[aoff[o]:aoff[o + 1]]``
of ``polar`` (sensor frame) and ``xy`` (world frame of the updated pose).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from radarslam.extent.buffering import POOL, READY, TAKE, buffer_and_fit, merge_outcome
from radarslam.extent.ellipse import _ellipse_to_matrix
from radarslam.extent.ellipse_fit import fit_entries
from radarslam.extent.measurement import max_trace_w_entries
from radarslam.extent.mem_ekf_kernels import (AXIS_FLOOR, detection_cov_entries, initial_shape, mem_ekf_predict_cov,
                                              mem_ekf_scan_entries)
from radarslam.extent.random_matrix import rm_predict_alpha, rm_update_entries

#: What each MEM-EKF* detection's noise holds besides the sensor's (``extent.mem_ekf_noise``, a.10):
#: the sensor's alone; the pose's too; the centroid's too.
MEM_SENSOR, MEM_NO_CENTROID, MEM_FULL = 0, 1, 2
#: ``extent.mem_ekf_noise`` by name.
MEM_NOISE = {"sensor": MEM_SENSOR, "no-centroid": MEM_NO_CENTROID, "full": MEM_FULL}


class ExtentRows(NamedTuple):
    """The built-in extent estimators' states of ``N`` landmarks, one row each: the random-matrix
    and EFA states (a.3-a.5, Decision 5), MEM-EKF*'s shapes (a.10) and the partial view's (a.12.7)."""

    einit: np.ndarray      #: (N,) bool, extent initialised
    X: np.ndarray          #: (N, 2, 2) RMA extents (MEM-EKF*: the shapes' matrices)
    alpha: np.ndarray      #: (N,) RMA degrees of freedom
    Xefa: np.ndarray       #: (N, 2, 2) EFA extents
    nbuf: np.ndarray       #: (N,) int64, detections held before the extent is initialised (a.3)
    buf: np.ndarray        #: (N, B, 2) those detections in the world frame
    shape: np.ndarray      #: (N, 3) MEM-EKF* shapes [theta, l1, l2]
    Cs: np.ndarray         #: (N, 3, 3) their covariances
    xi: np.ndarray         #: (N, 3) partial-view log-matrix shapes
    Pxi: np.ndarray        #: (N, 3, 3) their covariances
    nview: np.ndarray      #: (N,) int64, scans that updated the partial-view shape


def empty_rows(N, B=0):
    """An :class:`ExtentRows` of ``N`` fresh rows (zeros) with buffers of ``B``."""
    return ExtentRows(np.zeros(N, dtype=np.bool_), np.zeros((N, 2, 2)), np.zeros(N), np.zeros((N, 2, 2)),
                      np.zeros(N, dtype=np.int64), np.zeros((N, B, 2)), np.zeros((N, 3)), np.zeros((N, 3, 3)),
                      np.zeros((N, 3)), np.zeros((N, 3, 3)), np.zeros(N, dtype=np.int64))


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
        w00, w01, w11 = scan_w(j, pol, pose, pose_cov, R, W, w_given)
        n11, n12, n22, a = rm_update_entries(E.X[j, 0, 0], E.X[j, 0, 1], E.X[j, 1, 1], a, cents[j, 0], cents[j, 1],
                                             ccovs[j, 0, 0], ccovs[j, 0, 1], ccovs[j, 1, 1], pts, w00, w01, w11,
                                             gamma, eig_floor)
        E.X[j, 0, 0], E.X[j, 0, 1], E.X[j, 1, 0], E.X[j, 1, 1] = n11, n12, n12, n22
        E.alpha[j] = a
        if efa:
            ok, _, _, e11, e12, e22 = fit_entries(pts, upper, w00, w01, w11, gamma)
            if ok:
                E.Xefa[j, 0, 0], E.Xefa[j, 0, 1], E.Xefa[j, 1, 0], E.Xefa[j, 1, 1] = e11, e12, e12, e22


def sliding_efa_rows(E, ready, born, N, old, aoff, arow, polar, xy, pose, pose_cov, R, W, w_given, window, gamma,
                     upper):
    """The EFA baseline of ``extent.efa_mode = "sliding"`` (Decision 5, d.3): once a landmark's
    extent is initialised its buffer rows hold the last ``window`` detections it was given (for one
    initialised now, ``born[j] > 0``, the newest of those fitted); each landmark ``ready`` with
    detections appends them, keeps the newest ``window`` and, from three on, ``Xefa`` is their fit
    (the upper bound when ``upper``, else corrected by the scan's ``W``), kept when the fit fails.
    ``E.buf`` must have room for ``window``. In place. A kernel."""
    for j in range(N):
        if born[j] > 0:
            k = min(born[j], window)
            for q in range(k):                           # forward: the source is never overwritten first
                E.buf[j, q, 0] = E.buf[j, born[j] - k + q, 0]
                E.buf[j, q, 1] = E.buf[j, born[j] - k + q, 1]
            E.nbuf[j] = k
        if not ready[j] or aoff[old[j] + 1] == aoff[old[j]]:
            continue
        pts = detections(xy, aoff, arow, old[j])
        n, m = E.nbuf[j], pts.shape[0]
        k = min(n + m, window)
        data = np.empty((k, 2))
        for q in range(k):                               # the newest k of the held rows, then the scan's
            s = n + m - k + q
            if s < n:
                data[q, 0], data[q, 1] = E.buf[j, s, 0], E.buf[j, s, 1]
            else:
                data[q, 0], data[q, 1] = pts[s - n, 0], pts[s - n, 1]
        E.buf[j, :k] = data
        E.nbuf[j] = k
        w00, w01, w11 = 0.0, 0.0, 0.0
        if not upper:
            w00, w01, w11 = scan_w(j, detections(polar, aoff, arow, old[j]), pose, pose_cov, R, W, w_given)
        ok, _, _, e11, e12, e22 = fit_entries(data, upper, w00, w01, w11, gamma)
        if ok:
            E.Xefa[j, 0, 0], E.Xefa[j, 0, 1], E.Xefa[j, 1, 0], E.Xefa[j, 1, 1] = e11, e12, e12, e22


def scan_w(j, pol, pose, pose_cov, R, W, w_given):
    """The entries ``(W11, W12, W22)`` of the scan's ``W`` for landmark ``j`` with detections
    ``pol``: the ``W(i)`` of largest trace (seed eq. 5, h.3), or ``W[j]`` when ``w_given``. A kernel."""
    if w_given:
        return W[j, 0, 0], W[j, 0, 1], W[j, 1, 1]
    return max_trace_w_entries(pose[2], pose_cov[0, 0], pose_cov[0, 1], pose_cov[0, 2], pose_cov[1, 1],
                               pose_cov[1, 2], pose_cov[2, 2], R[0, 0], R[0, 1], R[1, 1], pol)


def mem_ekf_initialise_rows(E, born, N, Cp0):
    """a.10's start for the landmarks initialised now (``born[j] > 0``): the shape of their EFA
    extent (semi-axes floored), of covariance ``Cp0``, and ``X`` its matrix. In place. A kernel."""
    for j in range(N):
        if born[j] > 0:
            th, l1, l2 = initial_shape(E.X[j, 0, 0], E.X[j, 0, 1], E.X[j, 1, 1])
            E.shape[j, 0], E.shape[j, 1], E.shape[j, 2] = th, l1, l2
            E.Cs[j] = Cp0
            E.X[j] = _ellipse_to_matrix(l1, l2, th)


def mem_ekf_rows(E, ready, N, old, aoff, arow, polar, xy, cents, ccovs, pose, pose_cov, R, W, w_given, dt, q_theta,
                 q_axis, noise, gamma, upper, efa):
    """a.10 for every landmark ``j < N`` ``ready``: the shape covariance grown over ``dt``, then the
    scan's detections one by one, each with its ``W(i)`` (of the sensor noise alone under
    ``noise = MEM_SENSOR``, else with the pose's) and with the centroid's covariance under
    ``MEM_FULL``; ``X`` the new shape's matrix; with ``efa`` the EFA baseline of the scan
    (Decision 5; its ``W`` only for the noise-corrected fit). In place. A kernel."""
    pc = np.zeros((3, 3)) if noise == MEM_SENSOR else pose_cov
    z2 = np.zeros((2, 2))
    for j in range(N):
        if not ready[j]:
            continue
        if dt > 0.0:
            E.Cs[j] = mem_ekf_predict_cov(E.Cs[j], dt, q_theta, q_axis)
        o = old[j]
        if aoff[o + 1] == aoff[o]:
            continue
        pol = detections(polar, aoff, arow, o)
        pts = detections(xy, aoff, arow, o)
        cvs = detection_cov_entries(pose[2], pc[0, 0], pc[0, 1], pc[0, 2], pc[1, 1], pc[1, 2], pc[2, 2], R[0, 0],
                                    R[0, 1], R[1, 1], pol)
        cm = ccovs[j] if noise == MEM_FULL else z2
        C, s = E.Cs[j], E.shape[j]
        th, l1, l2, C[0, 0], C[0, 1], C[0, 2], C[1, 1], C[1, 2], C[2, 2] = mem_ekf_scan_entries(
            s[0], s[1], s[2], C[0, 0], C[0, 1], C[0, 2], C[1, 1], C[1, 2], C[2, 2], cents[j, 0], cents[j, 1],
            cm[0, 0], cm[0, 1], cm[1, 1], pts, cvs, gamma, AXIS_FLOOR)
        C[1, 0], C[2, 0], C[2, 1] = C[0, 1], C[0, 2], C[1, 2]
        s[0], s[1], s[2] = th, l1, l2
        E.X[j] = _ellipse_to_matrix(l1, l2, th)
        if efa:
            w00, w01, w11 = 0.0, 0.0, 0.0
            if not upper:
                w00, w01, w11 = scan_w(j, pol, pose, pose_cov, R, W, w_given)
            ok, _, _, e11, e12, e22 = fit_entries(pts, upper, w00, w01, w11, gamma)
            if ok:
                E.Xefa[j, 0, 0], E.Xefa[j, 0, 1], E.Xefa[j, 1, 0], E.Xefa[j, 1, 1] = e11, e12, e12, e22


def merge_rows(E, keep, drop, view):
    """c.9 [PROP] for the extents when landmark ``drop`` merges into ``keep``
    (:func:`~.buffering.merge_outcome`): ``keep`` keeps its own extent, takes ``drop``'s (RMA/EFA
    and MEM-EKF*'s shape) when it has none yet, or, neither having one, appends ``drop``'s buffered
    detections to its own (``E.buf`` must have room for both). With ``view`` the partial view's
    shape of the two updated by more scans is kept. In place. A kernel."""
    outcome = merge_outcome(E.einit[keep], E.einit[drop])
    if outcome == TAKE:
        E.einit[keep], E.alpha[keep], E.nbuf[keep] = True, E.alpha[drop], E.nbuf[drop]
        E.X[keep] = E.X[drop]
        E.Xefa[keep] = E.Xefa[drop]
        E.buf[keep] = E.buf[drop]
        E.shape[keep] = E.shape[drop]
        E.Cs[keep] = E.Cs[drop]
    elif outcome == POOL:
        n, m = E.nbuf[keep], E.nbuf[drop]
        for a in range(m):
            E.buf[keep, n + a, 0] = E.buf[drop, a, 0]
            E.buf[keep, n + a, 1] = E.buf[drop, a, 1]
        E.nbuf[keep] = n + m
    if view and E.nview[drop] > E.nview[keep]:
        E.xi[keep] = E.xi[drop]
        E.Pxi[keep] = E.Pxi[drop]
        E.nview[keep] = E.nview[drop]
    return outcome


KERNELS = (detections, buffer_need, initialise_rows, scan_w, rma_efa_rows, sliding_efa_rows, mem_ekf_initialise_rows,
           mem_ekf_rows, merge_rows)
