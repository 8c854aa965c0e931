"""Extent metrics: ground-truth ellipses of the cars and the per-step GWD (docs/method.md e, Decision 7).

Every input is a plain array: the cars are axis-aligned rectangles ``[x_left, y_bottom, size_x,
size_y]`` (V, 4), the estimates per scan are centroids (N_k, 2) and extent matrices (N_k, 2, 2).

Ground-truth ellipse of an L x W car, centred on the rectangle, oriented along its long side
(Decision 7): ``moment`` (L/sqrt 3, W/sqrt 3), the ellipse whose uniform-surface covariance equals
the rectangle's and what a perfect estimator converges to; ``inscribed`` (L/2, W/2); ``enclosing``
(L/sqrt 2, W/sqrt 2); ``full`` (L, W), the convention that reproduces the magnitude of the seed's
Fig. 3 (h.9). The extent matrix of semi-axes ``(l1, l2)`` along ``o`` is
``X = R(o) diag(l1^2, l2^2) R(o)^T`` (docs/method.md d.1), written out below as its three entries.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.validation import as_array
from radarslam.metrics.gwd import _gwds
from radarslam.metrics.landmarks import flatten, match_flat

#: Semi-axis factors (on L and W) of each ground-truth convention.
CONVENTIONS: dict[str, float] = {
    "moment": 1.0 / math.sqrt(3.0),
    "inscribed": 0.5,
    "enclosing": 1.0 / math.sqrt(2.0),
    "full": 1.0,
}


#: The extra "convention" of :func:`extent_metrics`: the moment ellipse compared centred (shape only).
SHAPE = "shape"


def _rectangles(rectangles) -> np.ndarray:
    r = as_array("rectangles", rectangles, (None, 4))
    if np.any(r[:, 2:] <= 0):
        raise InputError(f"rectangles: expected sizes size_x, size_y > 0, got {r[:, 2:][np.any(r[:, 2:] <= 0, axis=1)].tolist()}")
    return r


def rectangle_centers(rectangles) -> np.ndarray:
    """Centres ``(V, 2)`` of rectangles ``[x_left, y_bottom, size_x, size_y]`` ``(V, 4)``."""
    r = _rectangles(rectangles)
    return np.column_stack([r[:, 0] + 0.5 * r[:, 2], r[:, 1] + 0.5 * r[:, 3]])


def _ellipse_matrix(l1: float, l2: float, o: float) -> np.ndarray:
    """``R(o) diag(l1^2, l2^2) R(o)^T`` (docs/method.md d.1) from trusted floats."""
    co, so = math.cos(o), math.sin(o)
    q1, q2 = l1 * l1, l2 * l2
    x11 = q1 * co * co + q2 * so * so
    x22 = q1 * so * so + q2 * co * co
    x12 = (q1 - q2) * so * co
    return np.array(((x11, x12), (x12, x22)))


def ground_truth_extents(rectangles, convention: str = "moment") -> np.ndarray:
    """``(V, 2, 2)`` extent matrices X of the ground-truth ellipses of rectangles ``(V, 4)``.

    The long side L = max(size_x, size_y) lies along x (orientation 0) when ``size_x >= size_y``,
    else along y (pi/2); the semi-axes are ``f L`` and ``f W`` with ``f = CONVENTIONS[convention]``.
    """
    if convention not in CONVENTIONS:
        raise InputError(f"convention: expected one of {sorted(CONVENTIONS)}, got {convention!r}")
    f = CONVENTIONS[convention]
    r = _rectangles(rectangles)
    out = np.empty((r.shape[0], 2, 2))
    for i, (_, _, sx, sy) in enumerate(r.tolist()):
        length, width = max(sx, sy), min(sx, sy)
        out[i] = _ellipse_matrix(f * length, f * width, 0.0 if sx >= sy else 0.5 * math.pi)
    return out


def gwd_per_step(positions: Sequence[np.ndarray], rma: Sequence[np.ndarray], efa: Sequence[np.ndarray],
                 centers: np.ndarray, present: np.ndarray, gt_extents: np.ndarray | Mapping[str, np.ndarray],
                 gate: float, include_stale: bool = False, matched: Sequence[np.ndarray] | None = None,
                 centred: Sequence[str] = (), compiled: bool = True):
    """Mean GWD over the matched landmarks with an initialised extent, per scan (docs/method.md e).

    Landmarks are matched one-to-one to the vehicles present at the scan (Hungarian, ``gate``);
    with ``include_stale`` departed vehicles take part too (h.10). The estimate's centre is the
    EKF centroid for both RMA and EFA; a landmark counts when both its extents are finite.

    Parameters
    ----------
    positions : sequence of K arrays (N_k, 2)
        Landmark centroids after each scan.
    rma, efa : sequence of K arrays (N_k, 2, 2)
        RMA and EFA extent matrices of the same landmarks (NaN where not initialised).
    centers : ndarray (V, 2)
        Vehicle centres (:func:`rectangle_centers`).
    present : ndarray of bool (K, V)
    gt_extents : ndarray (V, 2, 2) or mapping of them
        Ground-truth extents; with a mapping (convention -> extents) the matching is done once per
        scan and every convention is evaluated on it.
    gate : float
    include_stale : bool
    matched : sequence of K arrays, optional
        The matches of every scan's landmarks to *all* the vehicles
        (:func:`radarslam.metrics.landmarks.matches`); reused for the scans where every vehicle
        takes part, instead of matching again.
    centred : sequence of str
        Keys of ``gt_extents`` compared *centred*: the ground-truth ellipse is placed on the
        estimate's centroid, so that the GWD measures the shape alone (docs/method.md e).

    Returns
    -------
    rma, efa : ndarray, shape (K,)
        ``g_bar_k`` of the RMA and EFA estimates; NaN where no landmark qualifies (dicts keyed
        like ``gt_extents`` when it is a mapping).
    count : ndarray of int, shape (K,)
        Number of landmarks averaged.
    """
    K = len(positions)
    if len(rma) != K or len(efa) != K:
        raise InputError(f"rma, efa: expected {K} scans like positions, got {len(rma)} and {len(efa)}")
    present = np.asarray(present, dtype=bool)
    centers = np.asarray(centers, dtype=float).reshape(-1, 2)
    if present.shape != (K, centers.shape[0]):
        raise InputError(f"present: expected shape ({K}, {centers.shape[0]}), got {present.shape}")
    single = not isinstance(gt_extents, Mapping)
    gts = {"_": np.asarray(gt_extents, dtype=float)} if single else {c: np.asarray(g, dtype=float)
                                                                      for c, g in gt_extents.items()}
    for c, g in gts.items():
        if g.shape != (centers.shape[0], 2, 2):
            raise InputError(f"gt_extents: expected shape ({centers.shape[0]}, 2, 2), got {g.shape}"
                             + ("" if single else f" for {c!r}"))
    rma_out = {c: np.full(K, np.nan) for c in gts}
    efa_out = {c: np.full(K, np.nan) for c in gts}
    # Every scan's landmarks as rows; each matched to the vehicles of its scan (all of them, or
    # those present), all scans in one compiled call; then the qualifying (landmark, vehicle) pairs
    # of all scans in one vectorised GWD call: (RMA, EFA) x every convention.
    pos_all, off = flatten(positions, (2,))
    xr_all, off_r = flatten(rma, (2, 2))
    xe_all, off_e = flatten(efa, (2, 2))
    if not (np.array_equal(off, off_r) and np.array_equal(off, off_e)):
        raise InputError("rma, efa: expected as many extents as positions at every scan, got other counts")
    everyone = np.ones(K, dtype=bool) if include_stale else present.all(axis=1)
    reuse = everyone & (matched is not None)
    vehicles = np.where(everyone[:, None], True, present) & ~reuse[:, None]
    a = match_flat(pos_all, off, centers, vehicles, gate, compiled)
    if reuse.any():
        given, off_m = flatten(matched, ())
        if not np.array_equal(off_m, off):
            raise InputError("matched: expected one match per landmark at every scan, got other counts")
        rows = np.repeat(reuse, np.diff(off))
        a[rows] = given[rows].astype(np.int64)
    ok = (a >= 0) & np.isfinite(xr_all[:, 0, 0]) & np.isfinite(xe_all[:, 0, 0])
    count = np.bincount(np.repeat(np.arange(K), np.diff(off))[ok], minlength=K).astype(int)
    scans = np.flatnonzero(count).tolist()
    if scans:
        nc = len(gts)
        pos, xr, xe, v = pos_all[ok], xr_all[ok], xe_all[ok], a[ok]
        n = pos.shape[0]
        est = np.concatenate([xr, xe] * nc)
        ref = np.concatenate([g[v] for g in gts.values() for _ in (0, 1)])
        ref_centres = np.concatenate([pos if c in centred else centers[v] for c in gts for _ in (0, 1)])
        d = _gwds(np.tile(pos, (2 * nc, 1)), est, ref_centres, ref).reshape(nc, 2, n)
        starts = np.concatenate([[0], np.cumsum(count[scans])[:-1]])
        means = np.add.reduceat(d, starts, axis=2) / count[scans]     # (conventions, 2, scans)
        for ci, c in enumerate(gts):
            rma_out[c][scans] = means[ci, 0]
            efa_out[c][scans] = means[ci, 1]
    if single:
        return rma_out["_"], efa_out["_"], count
    return rma_out, efa_out, count


def extent_metrics(positions: Sequence[np.ndarray], rma: Sequence[np.ndarray], efa: Sequence[np.ndarray],
                   rectangles, present: np.ndarray, gate: float, include_stale: bool = False,
                   conventions=("moment", "full", "inscribed", "enclosing"),
                   matched: Sequence[np.ndarray] | None = None, compiled: bool = True) -> dict:
    """Per-step and final mean GWD of RMA and EFA in each ground-truth convention.

    Parameters
    ----------
    positions, rma, efa : sequences of K arrays
        As in :func:`gwd_per_step`.
    rectangles : array_like (V, 4)
        The vehicles ``[x_left, y_bottom, size_x, size_y]``.
    present : ndarray of bool (K, V)
    matched : sequence of K arrays, optional
        As in :func:`gwd_per_step`.

    Returns
    -------
    dict
        ``gwd_count`` (K,), ``gwd_{rma,efa}_{convention}`` (K,) and ``gwd_{rma,efa}_final_{convention}``,
        and the same for ``shape``: the moment ellipse centred on the estimate (the shape alone,
        without the centroid's error).
    """
    centers = rectangle_centers(rectangles)
    gts = {c: ground_truth_extents(rectangles, c) for c in conventions}
    gts[SHAPE] = gts["moment"] if "moment" in gts else ground_truth_extents(rectangles, "moment")
    g_rma, g_efa, count = gwd_per_step(positions, rma, efa, centers, present, gts, gate, include_stale,
                                       matched, centred=(SHAPE,), compiled=compiled)
    out: dict = {"gwd_count": count}
    for conv in (*conventions, SHAPE):
        out[f"gwd_rma_{conv}"] = g_rma[conv]
        out[f"gwd_efa_{conv}"] = g_efa[conv]
        out[f"gwd_rma_final_{conv}"] = float(g_rma[conv][-1]) if len(g_rma[conv]) else float("nan")
        out[f"gwd_efa_final_{conv}"] = float(g_efa[conv][-1]) if len(g_efa[conv]) else float("nan")
    return out
