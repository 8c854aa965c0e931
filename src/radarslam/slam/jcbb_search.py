"""The search of Joint Compatibility Branch and Bound (docs/method.md c.4.1; Neira and Tardos, IEEE
Trans. Robot. Autom. 17(6), 2001) on arrays: innovations of candidate pairings and their joint
covariance in, the largest jointly compatible set of pairings out. :func:`jcbb` checks its inputs
and runs :func:`jcbb_search`, a kernel that :mod:`radarslam.slam._jcbb_numba` compiles as it is for
the associator and the fused engine; :func:`radarslam.slam._jcbb_numba.jcbb_associate_scan` builds the
problem from a scan (the observations, the individual gate, the batch updates).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError


@functools.lru_cache(maxsize=256)
def chi2_quantile(probability: float, dof: int) -> float:
    """``chi2.ppf(probability, dof)`` (scipy, imported on first use), cached per ``(probability, dof)``."""
    from scipy.stats import chi2

    return float(chi2.ppf(probability, dof))


def joint_gate(probability: float) -> Callable[[int], float]:
    """The joint-compatibility threshold of ``k`` pairings: ``chi2.ppf(probability, 2 k)``.

    Raises
    ------
    InputError
        Unless ``0 < probability < 1``.
    """
    if not isinstance(probability, (int, float)) or not 0.0 < probability < 1.0:
        raise InputError(f"gate_probability: expected a value in (0, 1), got {probability!r}")
    p = float(probability)
    return lambda k: chi2_quantile(p, 2 * int(k))


@dataclass(frozen=True)
class JcbbResult:
    """The outcome of one :func:`jcbb` search.

    Attributes
    ----------
    pairs : tuple of (int, int)
        The best hypothesis as ``(observation, landmark)`` pairings, observations ascending; empty
        when no pairing is jointly compatible (or the budget ran out before one was found).
    pair_index : tuple of int
        The rows of the search's input arrays that those pairings are.
    d2 : float
        Its joint Mahalanobis distance ``nu^T C^-1 nu`` (0 for the empty hypothesis).
    nodes : int
        Hypothesis nodes visited, the root included.
    exhausted : bool
        Whether the node budget stopped the search before it was complete (the result is then the
        best hypothesis found so far, still jointly compatible).
    """

    pairs: tuple[tuple[int, int], ...]
    pair_index: tuple[int, ...]
    d2: float
    nodes: int
    exhausted: bool


def joint_covariance(H: np.ndarray, P: np.ndarray, N: np.ndarray) -> np.ndarray:
    """Covariance ``(2M, 2M)`` of the stacked innovations of ``M`` candidate pairings.

    ``C = H P H^T + blockdiag(N_1, ..., N_M)`` with ``H (M, 2, d)`` the pairings' Jacobians over a
    common state of dimension ``d`` (docs/method.md c.4.1 eq. JC). Two pairings of the same
    observation never meet in one hypothesis, so their shared-noise block is never read.
    """
    M, d = H.shape[0], P.shape[0]
    Hf = H.reshape(2 * M, d)
    C = Hf @ P @ Hf.T
    for m in range(M):
        C[2 * m:2 * m + 2, 2 * m:2 * m + 2] += N[m]
    return 0.5 * (C + C.T)


def _checked(obs, lm, nu, C, n_obs, max_nodes):
    """The inputs of :func:`jcbb` as arrays, checked: ``(obs, lm, nu, C)``."""
    obs = np.asarray(obs, dtype=np.int64)
    lm = np.asarray(lm, dtype=np.int64)
    M = obs.shape[0]
    if obs.ndim != 1 or lm.shape != (M,):
        raise InputError(f"lm: expected shape ({M},) like obs, got {lm.shape}")
    nu = np.asarray(nu, dtype=float)
    C = np.asarray(C, dtype=float)
    if nu.shape != (M, 2):
        raise InputError(f"nu: expected shape ({M}, 2), got {nu.shape}")
    if C.shape != (2 * M, 2 * M):
        raise InputError(f"C: expected shape ({2 * M}, {2 * M}), got {C.shape}")
    if isinstance(n_obs, bool) or not isinstance(n_obs, (int, np.integer)) or n_obs < 0:
        raise InputError(f"n_obs: expected an integer >= 0, got {n_obs!r}")
    if M and (obs.min() < 0 or obs.max() >= n_obs):
        raise InputError(f"obs: expected values in [0, {n_obs}), got {obs.min()}..{obs.max()}")
    if isinstance(max_nodes, bool) or not isinstance(max_nodes, (int, np.integer)) or max_nodes < 1:
        raise InputError(f"max_nodes: expected an integer >= 1, got {max_nodes!r}")
    return obs, lm, nu, C


def close_block(L, y, rows, r, m, c00, c01, c11, e0, e1, d2):
    """The new pairing's 2 x 2 diagonal block of the joint factor: the Cholesky factor of its Schur
    complement ``[[c00, c01], [c01, c11]]`` into ``L[r:r+2, r:r+2]``, ``y[r:r+2]`` from the reduced
    innovation ``(e0, e1)`` and ``rows[r:r+2]``; returns ``d2 + |y_new|^2``, or ``inf`` when the
    complement is not positive definite. A kernel: :func:`_extend` calls it and numba compiles it
    as it is for :func:`radarslam.slam._jcbb_numba.extend_loops` (one arithmetic, docs/method.md c.4.1)."""
    if not c00 > 0.0:
        return math.inf
    l00 = math.sqrt(c00)
    l10 = c01 / l00
    q = c11 - l10 * l10
    if not q > 0.0:
        return math.inf
    l11 = math.sqrt(q)
    y0 = e0 / l00
    y1 = (e1 - l10 * y0) / l11
    L[r, r], L[r, r + 1], L[r + 1, r], L[r + 1, r + 1] = l00, 0.0, l10, l11
    y[r], y[r + 1] = y0, y1
    rows[r], rows[r + 1] = 2 * m, 2 * m + 1
    return d2 + y0 * y0 + y1 * y1


def extend_loops(C, nu, L, y, rows, k, m, d2):
    """``D^2`` of the hypothesis (Cholesky factor ``L``,
    ``y = L^-1 nu_h``, ``rows`` of ``C`` over its first ``k`` pairings) plus pairing ``m``; writes row
    block ``k`` of ``L``, ``y``, ``rows``; ``inf`` when the Schur complement is not positive
    definite. ``L21 = (L^-1 b)^T`` for the cross-covariance ``b = C[rows, 2m:2m+2]`` by forward
    substitution, then :func:`close_block` (docs/method.md c.4.1). A kernel."""
    r = 2 * k
    c00 = C[2 * m, 2 * m]
    c01 = 0.5 * (C[2 * m, 2 * m + 1] + C[2 * m + 1, 2 * m])
    c11 = C[2 * m + 1, 2 * m + 1]
    e0, e1 = nu[m, 0], nu[m, 1]
    if k:
        z = np.empty((r, 2))                    # L^-1 b, b = C[rows, 2m:2m+2], by forward substitution
        for i in range(r):
            a0 = C[rows[i], 2 * m]
            a1 = C[rows[i], 2 * m + 1]
            for q in range(i):
                a0 -= L[i, q] * z[q, 0]
                a1 -= L[i, q] * z[q, 1]
            z[i, 0] = a0 / L[i, i]
            z[i, 1] = a1 / L[i, i]
        s00 = s01 = s11 = t0 = t1 = 0.0
        for i in range(r):
            s00 += z[i, 0] * z[i, 0]
            s01 += z[i, 0] * z[i, 1]
            s11 += z[i, 1] * z[i, 1]
            t0 += z[i, 0] * y[i]
            t1 += z[i, 1] * y[i]
            L[r, i] = z[i, 0]
            L[r + 1, i] = z[i, 1]
        c00, c01, c11 = c00 - s00, c01 - s01, c11 - s11          # Schur complement
        e0, e1 = e0 - t0, e1 - t1
    return close_block(L, y, rows, r, m, c00, c01, c11, e0, e1, d2)


def _can_beat(k_max, d2_low, best_k, best_d2):
    """Whether a subtree with at most ``k_max`` pairings and ``D^2 >= d2_low`` can beat the best
    (the most pairings, then the smallest ``D^2``: ``D^2`` never decreases down the tree). A kernel."""
    return k_max > best_k or (k_max == best_k and d2_low < best_d2)


def jcbb_search(obs, lm, nu, C, n_obs, gates, max_nodes):
    """The branch and bound of :func:`jcbb` on checked arrays, depth first as a loop over a stack of
    frames ``(observation, pairings, D^2, next candidate, phase)``: phase 0 enters a node, 1 tries
    its pairing children in input order, 2 its unpaired child, 3 returns. ``gates[k]`` is the joint
    gate of ``k`` pairings. Returns ``(pair rows by observation, D^2, nodes, exhausted)``. A kernel:
    :func:`jcbb` calls it as Python, :mod:`radarslam.slam._jcbb_numba` compiles it as it is."""
    M = obs.shape[0]
    cnt = np.zeros(n_obs + 1, dtype=np.int64)                  # candidates by observation (input order)
    for a in range(M):
        cnt[obs[a] + 1] += 1
    off = np.cumsum(cnt)
    by_obs = np.empty(M, dtype=np.int64)
    fill = off[:-1].copy()
    for a in range(M):
        by_obs[fill[obs[a]]] = a
        fill[obs[a]] += 1
    rest = np.zeros(n_obs + 1, dtype=np.int64)
    for i in range(n_obs - 1, -1, -1):
        rest[i] = rest[i + 1] + (1 if off[i + 1] > off[i] else 0)
    labels = np.unique(lm)
    code = np.searchsorted(labels, lm)                         # landmark labels as 0 .. U - 1
    used = np.zeros(labels.shape[0], dtype=np.bool_)
    depth = min(n_obs, M)
    L = np.zeros((2 * depth + 2, 2 * depth + 2))
    y = np.zeros(2 * depth + 2)
    rows = np.zeros(2 * depth + 2, dtype=np.int64)
    chosen = np.empty(depth + 1, dtype=np.int64)
    best = np.empty(depth + 1, dtype=np.int64)
    n_chosen, best_k, best_d2, nodes, exhausted = 0, 0, 0.0, 1, False
    F = n_obs + 2
    f_i, f_k, f_p, f_phase = (np.zeros(F, dtype=np.int64), np.zeros(F, dtype=np.int64),
                              np.zeros(F, dtype=np.int64), np.zeros(F, dtype=np.int64))
    f_d2 = np.zeros(F)
    f_pend = np.zeros(F, dtype=np.bool_)                       # a pairing child is on the stack above
    top = 1
    while top > 0 and not exhausted:
        f = top - 1
        i, k, d2 = f_i[f], f_k[f], f_d2[f]
        if f_phase[f] == 0:                                    # enter: skip observations without candidates
            while i < n_obs and off[i + 1] == off[i]:
                i += 1
            f_i[f] = i
            if i == n_obs:
                top -= 1
                continue
            f_phase[f] = 1 if _can_beat(k + rest[i], d2, best_k, best_d2) else 2
            f_p[f] = 0
            continue
        if f_phase[f] == 1:                                    # the pairing children
            if f_pend[f]:                                      # back from one: undo its pairing
                n_chosen -= 1
                used[code[chosen[n_chosen]]] = False
                f_pend[f] = False
            pushed = False
            while f_p[f] < off[i + 1] - off[i]:
                m = by_obs[off[i] + f_p[f]]
                f_p[f] += 1
                if used[code[m]]:
                    continue
                if not _can_beat(k + rest[i], d2, best_k, best_d2):
                    break
                if nodes >= max_nodes:
                    exhausted = True
                    break
                nodes += 1
                d2_new = extend_loops(C, nu, L, y, rows, k, m, d2)
                if not d2_new < gates[k + 1]:
                    continue
                chosen[n_chosen] = m
                n_chosen += 1
                used[code[m]] = True
                if _can_beat(k + 1, d2_new, best_k, best_d2):   # a better hypothesis
                    best[:n_chosen] = chosen[:n_chosen]
                    best_k, best_d2 = k + 1, d2_new
                f_pend[f] = True
                f_i[top], f_k[top], f_d2[top], f_phase[top], f_pend[top] = i + 1, k + 1, d2_new, 0, False
                top += 1
                pushed = True
                break
            if not pushed:
                f_phase[f] = 2
            continue
        if f_phase[f] == 2:                                    # the unpaired child
            f_phase[f] = 3
            if _can_beat(k + rest[i + 1], d2, best_k, best_d2):
                if nodes >= max_nodes:
                    exhausted = True
                    break
                nodes += 1
                f_i[top], f_k[top], f_d2[top], f_phase[top], f_pend[top] = i + 1, k, d2, 0, False
                top += 1
            continue
        top -= 1                                               # phase 3: return
    pairs = best[:best_k].copy()
    key = np.empty(best_k, dtype=np.int64)
    for a in range(best_k):
        key[a] = obs[pairs[a]]
    return pairs[np.argsort(key)], best_d2, nodes, exhausted


def jcbb(obs: np.ndarray, lm: np.ndarray, nu: np.ndarray, C: np.ndarray, n_obs: int,
         threshold: Callable[[int], float], max_nodes: int) -> JcbbResult:
    """Joint Compatibility Branch and Bound over candidate pairings (Neira and Tardos 2001).

    The search walks the interpretation tree depth first: at depth ``i`` observation ``i`` is
    paired with each of its candidate landmarks not yet taken by the hypothesis (in the order of
    the input rows), then left unpaired. A pairing child is kept only if the hypothesis stays
    jointly compatible, ``D^2 = nu^T C^-1 nu < threshold(k)`` for its ``k`` pairings, so every
    prefix (in observation order) of a hypothesis found is jointly compatible. The best hypothesis
    has the most pairings, then the smallest ``D^2``. A subtree is pruned when even pairing all of
    its remaining observations that have candidates could not beat the best (fewer pairings, or as
    many with a ``D^2`` already no smaller: ``D^2`` never decreases down the tree).

    ``D^2`` is updated incrementally (docs/method.md c.4.1): with ``C_h = L L^T`` and
    ``y = L^-1 nu_h`` for the hypothesis ``h``, adding pairing ``m`` with cross-covariance
    ``b = C[h, m]`` gives ``L21 = (L^-1 b)^T``, ``L22 = chol(C_mm - L21 L21^T)``,
    ``y_m = L22^-1 (nu_m - L21 y)`` and ``D^2 += |y_m|^2``: ``O(k^2)`` per node instead of a new
    ``O(k^3)`` Cholesky.

    Parameters
    ----------
    obs : ndarray of int, shape (M,)
        Observation of each candidate pairing, in ``[0, n_obs)``; observations are searched in
        index order (the caller chooses the order).
    lm : ndarray of int, shape (M,)
        Landmark of each candidate pairing (any labels; a landmark takes at most one observation).
    nu : ndarray, shape (M, 2)
        Innovation of each pairing.
    C : ndarray, shape (2M, 2M)
        Joint covariance of the stacked innovations (:func:`joint_covariance`).
    n_obs : int
        Number of observations.
    threshold : callable
        ``threshold(k)``: the joint gate of ``k`` pairings (:func:`joint_gate`).
    max_nodes : int
        Budget of hypothesis nodes visited, at least 1: the root and every child generated (paired,
        compatible or not, and unpaired; observations without candidates are passed over). When it
        runs out the search stops and returns the best hypothesis found so far with
        ``exhausted=True``. The search is :func:`jcbb_search`, the kernel the compiled associator
        and the fused engine run compiled.

    Returns
    -------
    JcbbResult
    """
    obs, lm, nu, C = _checked(obs, lm, nu, C, n_obs, max_nodes)
    depth = min(n_obs, obs.shape[0])
    gates = np.array([0.0] + [float(threshold(k)) for k in range(1, depth + 2)])
    rows, d2, nodes, exhausted = jcbb_search(obs, lm, nu, C, n_obs, gates, max_nodes)
    lm_list = lm.tolist()
    return JcbbResult(tuple((int(obs[m]), lm_list[m]) for m in rows.tolist()), tuple(rows.tolist()), float(d2),
                      int(nodes), bool(exhausted))
