"""Extent metrics: ground-truth ellipses of the cars and the per-step GWD (method.md e, Decision 7).

Ground-truth ellipse of an L x W car, centred on the rectangle, oriented along its long side
(Decision 7): ``moment`` (L/sqrt 3, W/sqrt 3), the ellipse whose uniform-surface covariance equals
the rectangle's and what a perfect estimator converges to; ``inscribed`` (L/2, W/2); ``enclosing``
(L/sqrt 2, W/sqrt 2); ``full`` (L, W), the convention that reproduces the magnitude of the seed's
Fig. 3 (h.9).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.extent.ellipse import ellipse_to_matrix
from radarslam.metrics.gwd import _gwds
from radarslam.metrics.landmarks import match

#: Semi-axis factors (on L and W) of each ground-truth convention.
CONVENTIONS: dict[str, float] = {
    "moment": 1.0 / math.sqrt(3.0),
    "inscribed": 0.5,
    "enclosing": 1.0 / math.sqrt(2.0),
    "full": 1.0,
}


def ground_truth_extents(vehicles, convention: str = "moment") -> np.ndarray:
    """``(V, 2, 2)`` extent matrices X of the vehicles' ground-truth ellipses."""
    if convention not in CONVENTIONS:
        from radarslam.core.errors import InputError

        raise InputError(f"convention: expected one of {sorted(CONVENTIONS)}, got {convention!r}")
    f = CONVENTIONS[convention]
    return np.array([ellipse_to_matrix(np.array([f * v.length, f * v.width]), v.orientation)
                     for v in vehicles]).reshape(-1, 2, 2)


def gwd_per_step(maps, centers: np.ndarray, present: np.ndarray, gt_extents: np.ndarray | dict[str, np.ndarray],
                 gate: float, include_stale: bool = False):
    """Mean GWD over the matched landmarks with an initialised extent, per scan (method.md e).

    Landmarks are matched one-to-one to the vehicles present at the scan (Hungarian, ``gate``);
    with ``include_stale`` departed vehicles take part too (h.10). The estimate's centre is the
    EKF centroid for both RMA and EFA.

    Parameters
    ----------
    gt_extents : ndarray (V, 2, 2) or dict of them
        Ground-truth extents; with a dict (convention -> extents) the matching is done once per
        scan and every convention is evaluated on it.

    Returns
    -------
    rma, efa : ndarray, shape (K,)
        ``g_bar_k`` of the RMA and EFA estimates; NaN where no landmark qualifies (dicts keyed
        like ``gt_extents`` when it is a dict).
    count : ndarray of int, shape (K,)
        Number of landmarks averaged.
    """
    single = not isinstance(gt_extents, dict)
    gts = {"_": gt_extents} if single else gt_extents
    K = len(maps)
    rma = {c: np.full(K, np.nan) for c in gts}
    efa = {c: np.full(K, np.nan) for c in gts}
    count = np.zeros(K, dtype=int)
    for k, mp in enumerate(maps):
        cand = np.arange(centers.shape[0]) if include_stale else np.flatnonzero(present[k])
        a = match(mp.positions, centers[cand], gate)
        ok = (a >= 0) & np.isfinite(mp.rma[:, 0, 0]) & np.isfinite(mp.efa[:, 0, 0])
        if not np.any(ok):
            continue
        v = cand[a[ok]]
        n = int(ok.sum())
        count[k] = n
        # One vectorised GWD call per scan: (RMA, EFA) x every convention, stacked.
        nc = len(gts)
        est = np.concatenate([mp.rma[ok], mp.efa[ok]] * nc)
        ref = np.concatenate([g[v] for g in gts.values() for _ in (0, 1)])
        pos = np.tile(mp.positions[ok], (2 * nc, 1))
        d = _gwds(pos, est, np.tile(centers[v], (2 * nc, 1)), ref).reshape(nc, 2, n).mean(axis=2)
        for ci, c in enumerate(gts):
            rma[c][k], efa[c][k] = float(d[ci, 0]), float(d[ci, 1])
    if single:
        return rma["_"], efa["_"], count
    return rma, efa, count


def extent_metrics(maps, vehicles, present: np.ndarray, gate: float, include_stale: bool = False,
                   conventions=("moment", "full", "inscribed", "enclosing")) -> dict:
    """Per-step and final mean GWD of RMA and EFA in each ground-truth convention."""
    from radarslam.simulation.world import vehicle_centers

    centers = vehicle_centers(vehicles)
    gts = {c: ground_truth_extents(vehicles, c) for c in conventions}
    rma, efa, count = gwd_per_step(maps, centers, present, gts, gate, include_stale)
    out: dict = {"gwd_count": count}
    for conv in conventions:
        out[f"gwd_rma_{conv}"] = rma[conv]
        out[f"gwd_efa_{conv}"] = efa[conv]
        out[f"gwd_rma_final_{conv}"] = float(rma[conv][-1]) if len(rma[conv]) else float("nan")
        out[f"gwd_efa_final_{conv}"] = float(efa[conv][-1]) if len(efa[conv]) else float("nan")
    return out

