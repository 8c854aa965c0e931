"""Landmark-management metrics of APSIPA Table II (docs/method.md f.4).

Matching rule (documented, [PROP]): at every scan the estimated landmarks are assigned one-to-one to
the vehicles by the Hungarian algorithm on Euclidean centre distance; pairs farther apart than the
gate (``metrics.match_gate_m``, 5 m) stay unassigned. Every vehicle ever in the scene takes part, so
the landmark of a vehicle that has left is recognised as *stale* rather than counted as false.

- *false* landmarks at k: landmarks assigned to no vehicle;
- *missed* vehicles at k: present vehicles that have been within radar range of the true platform
  for at least ``missed_grace_scans`` scans so far and have no landmark;
- *landmark position error*: at the final scan, the distance of each present vehicle's landmark
  to the vehicle centre (MAE = its mean);
- *inclusion delay* of a vehicle: first scan with a landmark minus first scan in range;
- *removal delay* of the departed vehicle: first scan (after it left) without a landmark on it,
  minus the first scan after it left at which its position is back within range.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment


def match(positions: np.ndarray, centers: np.ndarray, gate: float) -> np.ndarray:
    """Vehicle index assigned to each landmark ``(N,)``, -1 for none (Hungarian with a gate)."""
    n = positions.shape[0]
    out = np.full(n, -1, dtype=int)
    if n == 0 or centers.shape[0] == 0:
        return out
    d = np.linalg.norm(positions[:, None, :] - centers[None, :, :], axis=2)
    cost = np.where(d <= gate, d, 1e6)
    rows, cols = linear_sum_assignment(cost)
    ok = d[rows, cols] <= gate
    out[rows[ok]] = cols[ok]
    return out


def flatten(per_scan, shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """Per-scan arrays as one array of rows ``shape`` and the scans' row offsets ``(K + 1,)``."""
    parts = [np.asarray(p, dtype=float).reshape((-1,) + shape) for p in per_scan]
    offsets = np.zeros(len(parts) + 1, dtype=np.int64)
    offsets[1:] = np.cumsum([p.shape[0] for p in parts])
    return (np.concatenate(parts) if parts else np.empty((0,) + shape)), offsets


def match_flat(positions: np.ndarray, offsets: np.ndarray, centers: np.ndarray, vehicles: np.ndarray,
               gate: float, compiled: bool = True) -> np.ndarray:
    """:func:`match` of every scan at once: scan ``k``'s landmarks ``positions[offsets[k]:offsets[k + 1]]``
    against the vehicles ``centers[vehicles[k]]`` (boolean ``(K, V)``); the vehicle index (into
    ``centers``) of every landmark, -1 for none. Compiled (:mod:`._compiled`), the same matches;
    ``compiled=False`` runs :func:`match` scan by scan (a first run that does not wait for numba)."""
    centers = np.ascontiguousarray(centers, dtype=float).reshape(-1, 2)
    if not compiled:
        out = np.full(np.shape(positions)[0], -1, dtype=np.int64)
        pos = np.asarray(positions, dtype=float).reshape(-1, 2)
        vehicles = np.asarray(vehicles, dtype=bool).reshape(len(offsets) - 1, centers.shape[0])
        for k in range(len(offsets) - 1):
            a, b = int(offsets[k]), int(offsets[k + 1])
            cols = np.flatnonzero(vehicles[k])
            m = match(pos[a:b], centers[cols], gate)
            hit = m >= 0
            out[np.arange(a, b)[hit]] = cols[m[hit]]
        return out
    from radarslam.metrics._compiled import match_scans

    return match_scans(np.ascontiguousarray(positions, dtype=float).reshape(-1, 2),
                       np.ascontiguousarray(offsets, dtype=np.int64), centers,
                       np.ascontiguousarray(vehicles, dtype=np.bool_).reshape(len(offsets) - 1, centers.shape[0]),
                       float(gate))


def matches(positions_per_scan, centers: np.ndarray, gate: float, compiled: bool = True) -> list[np.ndarray]:
    """:func:`match` of every scan's landmarks ``(N_k, 2)`` to all the vehicles ``centers``
    (``compiled``: as :func:`match_flat`)."""
    pos, off = flatten(positions_per_scan, (2,))
    centers = np.asarray(centers, dtype=float).reshape(-1, 2)
    a = match_flat(pos, off, centers, np.ones((off.shape[0] - 1, centers.shape[0]), dtype=bool), gate, compiled)
    return [a[off[k]:off[k + 1]].astype(int) for k in range(off.shape[0] - 1)]


def in_range_matrix(true_poses: np.ndarray, centers: np.ndarray, max_range: float) -> np.ndarray:
    """``(K, V)``: vehicle centre within ``max_range`` of the true platform position."""
    d = np.linalg.norm(true_poses[:, None, :2] - centers[None, :, :], axis=2)
    return d <= max_range


def landmark_metrics(positions_per_scan: list[np.ndarray], true_poses: np.ndarray, centers: np.ndarray,
                     present: np.ndarray, max_range: float, gate: float, grace: int,
                     matched: list[np.ndarray] | None = None) -> dict:
    """APSIPA Table II quantities of one run.

    Parameters
    ----------
    positions_per_scan : list of ndarray (N_k, 2)
        Landmark centroids after each scan k = 1..K.
    true_poses : ndarray (K, 3)
    centers : ndarray (V, 2)
    present : ndarray of bool (K, V)
    max_range : float
    gate : float
    grace : int
    matched : list of ndarray, optional
        :func:`matches` of ``positions_per_scan`` (computed here when not given).

    Returns
    -------
    dict
        ``false_per_scan``, ``missed_per_scan``, ``stale_per_scan`` (K,), ``final_errors`` (V,)
        (NaN where unmapped or absent), ``inclusion_delay`` (V,) (NaN where undefined),
        ``removal_delay`` (V,) (NaN except for mapped departed vehicles), plus scalar summaries.
    """
    K, V = present.shape
    inr = in_range_matrix(true_poses, centers, max_range)
    seen = np.cumsum(inr, axis=0)
    mapped = np.zeros((K, V), dtype=bool)
    false = np.zeros(K, dtype=int)
    stale = np.zeros(K, dtype=int)
    final_err = np.full(V, np.nan)
    if matched is None:
        matched = matches(positions_per_scan, centers, gate)
    a, off = flatten(matched, ())
    a = a.astype(np.int64)
    scan = np.repeat(np.arange(K), np.diff(off))
    hit = a >= 0
    mapped[scan[hit], a[hit]] = True
    false[:] = np.bincount(scan[~hit], minlength=K)
    stale[:] = np.bincount(scan[hit][~present[scan[hit], a[hit]]], minlength=K)
    if K:
        pos = np.asarray(positions_per_scan[K - 1], dtype=float).reshape(-1, 2)
        last = a[off[K - 1]:]
        for i in np.flatnonzero(last >= 0):
            if present[K - 1, last[i]]:
                final_err[last[i]] = np.linalg.norm(pos[i] - centers[last[i]])
    missed = np.sum(present & (seen >= max(grace, 1)) & ~mapped, axis=1)
    inclusion = np.full(V, np.nan)
    removal = np.full(V, np.nan)
    for v in range(V):
        first_in = np.flatnonzero(inr[:, v] & present[:, v])
        first_map = np.flatnonzero(mapped[:, v] & present[:, v])
        if first_in.size and first_map.size:
            inclusion[v] = first_map[0] - first_in[0]
        gone = np.flatnonzero(~present[:, v])
        if gone.size and gone[0] > 0 and mapped[gone[0] - 1, v]:
            back = gone[inr[gone, v]]
            if back.size:
                after = np.flatnonzero(~mapped[back[0]:, v])
                # Not removed by the last scan: censored, reported as NaN.
                removal[v] = after[0] if after.size else np.nan
    return {
        "false_per_scan": false,
        "missed_per_scan": missed,
        "stale_per_scan": stale,
        "final_errors": final_err,
        "inclusion_delay": inclusion,
        "removal_delay": removal,
        "landmark_mae_m": float(np.nanmean(final_err)) if np.any(np.isfinite(final_err)) else float("nan"),
        "mean_inclusion_delay": float(np.nanmean(inclusion)) if np.any(np.isfinite(inclusion)) else float("nan"),
        "mean_removal_delay": float(np.nanmean(removal)) if np.any(np.isfinite(removal)) else float("nan"),
        "mean_false": float(false.mean()),
        "max_false": int(false.max()),
        "mean_missed": float(missed.mean()),
        "max_missed": int(missed.max()),
        "final_false": int(false[-1]),
        "final_missed": int(missed[-1]),
    }
