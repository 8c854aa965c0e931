"""Joint Compatibility Branch and Bound association per cluster (docs/method.md c.4.1).

JCBB (Neira and Tardos, IEEE Trans. Robot. Autom. 17(6), 2001) chooses the largest set of
pairings between observations and landmarks whose innovations are *jointly* compatible with the
filter's covariance, instead of pairing each observation with its individually nearest landmark.
Pairings that share the pose error are judged together, so an offset pose that makes each
observation look like its neighbour's landmark is recognised as one offset.

Here an observation is a cluster of the scan's candidate detections (DBSCAN in the sensor frame),
summarised by its sensor-frame mean exactly as the per-landmark batch update fuses a landmark's
detections (docs/method.md a.7.3, part 3), and each chosen pairing is applied as that batch
update. Two layers:

- :func:`jcbb`, the pure search on arrays (innovations and their joint covariance), testable on
  synthetic problems;
- :class:`JcbbAssociator`, the component registered as ``"jcbb"``, the reference
  (``filter.backend = "python"``); :mod:`radarslam.slam._jcbb_numba` is the compiled one, which
  the fused engine runs too.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError
from radarslam.landmarks.clustering import dbscan_labels
from radarslam.slam import ekf
from radarslam.slam.association import NearestNeighbourAssociator, Spreads
from radarslam.slam.state import SlamState

#: Landmarks Euclidean-nearest to a cluster's world-frame mean that are gated by Mahalanobis
#: distance (docs/method.md c.4.1 step 2): the prefilter keeps the gating O(clusters x 8).
N_PREFILTER = 8


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


def _by_observation(obs: np.ndarray, n_obs: int) -> tuple[list[list[int]], np.ndarray]:
    """The candidate pairings of each observation, and ``rest[i]``: observations ``i..`` with at
    least one candidate, the most pairings still possible."""
    by_obs: list[list[int]] = [[] for _ in range(n_obs)]
    for m, o in enumerate(obs.tolist()):
        by_obs[o].append(m)
    rest = np.zeros(n_obs + 1, dtype=int)
    for i in range(n_obs - 1, -1, -1):
        rest[i] = rest[i + 1] + (1 if by_obs[i] else 0)
    return by_obs, rest


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


def _extend(C, nu, L, y, rows, k: int, m: int, d2: float) -> float:
    """``D^2`` of the hypothesis (its Cholesky factor ``L``, ``y = L^-1 nu_h`` and ``rows`` of
    ``C`` over its first ``k`` pairings) plus pairing ``m``; writes row block ``k`` of L, y, rows
    (:func:`jcbb`, the incremental update)."""
    from scipy.linalg import solve_triangular

    r = 2 * k
    c00, c01, c11 = C[2 * m, 2 * m], 0.5 * (C[2 * m, 2 * m + 1] + C[2 * m + 1, 2 * m]), C[2 * m + 1, 2 * m + 1]
    e0, e1 = nu[m, 0], nu[m, 1]
    if k:
        b = C[rows[:r], 2 * m:2 * m + 2]                                # (2k, 2) cross-covariance
        L21T = solve_triangular(L[:r, :r], b, lower=True, check_finite=False)
        s = L21T.T @ L21T
        c00, c01, c11 = c00 - s[0, 0], c01 - s[0, 1], c11 - s[1, 1]     # Schur complement
        t = L21T.T @ y[:r]
        e0, e1 = e0 - t[0], e1 - t[1]
        L[r:r + 2, :r] = L21T.T
    return close_block(L, y, rows, r, m, c00, c01, c11, e0, e1, d2)


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
        ``exhausted=True``. The recursion is as deep as the observations with candidates.

    Returns
    -------
    JcbbResult
    """
    obs, lm, nu, C = _checked(obs, lm, nu, C, n_obs, max_nodes)
    by_obs, rest = _by_observation(obs, n_obs)
    lm_list = lm.tolist()
    depth = min(n_obs, obs.shape[0])
    L = np.zeros((2 * depth, 2 * depth))     # Cholesky factor of C over the hypothesis' rows
    y = np.zeros(2 * depth)                   # L^-1 nu_h
    rows = np.zeros(2 * depth, dtype=np.int64)  # rows of C of the hypothesis' pairings
    chosen: list[int] = []
    used: set[int] = set()
    best_pairs: list[int] = []
    best_k, best_d2, nodes, exhausted = 0, 0.0, 1, False

    def can_beat(k_max: int, d2_low: float) -> bool:
        """Whether a subtree with at most ``k_max`` pairings and ``D^2 >= d2_low`` can beat the best."""
        return k_max > best_k or (k_max == best_k and d2_low < best_d2)

    def visit(i: int, k: int, d2: float) -> None:
        nonlocal nodes, exhausted, best_pairs, best_k, best_d2
        while i < n_obs and not by_obs[i]:
            i += 1                      # an observation without candidates is not a branch point
        if i == n_obs:
            return
        if can_beat(k + rest[i], d2):                           # the pairing children
            gate = threshold(k + 1)
            for m in by_obs[i]:
                if lm_list[m] in used:
                    continue
                if not can_beat(k + rest[i], d2):
                    break
                if nodes >= max_nodes:
                    exhausted = True
                    return
                nodes += 1
                d2_new = _extend(C, nu, L, y, rows, k, m, d2)
                if not d2_new < gate:
                    continue
                chosen.append(m)
                used.add(lm_list[m])
                if can_beat(k + 1, d2_new):                     # a better hypothesis
                    best_pairs, best_k, best_d2 = list(chosen), k + 1, d2_new
                visit(i + 1, k + 1, d2_new)
                chosen.pop()
                used.discard(lm_list[m])
                if exhausted:
                    return
        # the unpaired child
        if can_beat(k + rest[i + 1], d2):
            if nodes >= max_nodes:
                exhausted = True
                return
            nodes += 1
            visit(i + 1, k, d2)
    visit(0, 0, 0.0)
    best_pairs.sort(key=lambda m: obs[m])
    return JcbbResult(tuple((int(obs[m]), lm_list[m]) for m in best_pairs), tuple(best_pairs), float(best_d2),
                      nodes, exhausted)


@dataclass(frozen=True)
class Observation:
    """One cluster of a scan's candidate detections, fused in the sensor frame (docs/method.md c.4.1).

    ``members`` index the candidates; ``zbar`` is their sensor-frame mean and ``R_xy`` the mean
    sensor noise of one detection, ``mean_i J_i R J_i^T``.
    """

    members: np.ndarray  # (m,)
    zbar: np.ndarray  # (2,)
    R_xy: np.ndarray  # (2, 2)

    def noise(self, theta: float, spreads: Spreads, j: int) -> np.ndarray:
        """Covariance of ``zbar`` about landmark ``j``'s predicted centroid seen with heading ``theta``:
        ``(Rot(-theta) gamma_z X_j Rot(-theta)^T + R_xy) / m`` (docs/method.md a.7.3 part 3), the
        spread term only where ``spreads.has[j]``. Computed as the batch update does, bit for bit."""
        return ekf.batch_noise(theta, spreads.gX[j], spreads.has[j], self.R_xy, self.members.size)


def cluster_observations(polar: np.ndarray, R: np.ndarray, eps: float, min_samples: int) -> list[Observation]:
    """Group detections ``polar (m, 2)`` into observations (docs/method.md c.4.1 step 1).

    DBSCAN in the sensor's Cartesian frame (the distances are those of the world frame, so the
    clusters are those of c.6); each DBSCAN noise point is an observation of its own. Clusters in
    label order, then the noise points in input order.
    """
    pts, _ = ekf.polar_to_sensor_xy(polar, R)
    labels = dbscan_labels(pts, eps, min_samples)
    groups = [np.flatnonzero(labels == lab) for lab in np.unique(labels[labels >= 0])]
    groups += [np.array([i]) for i in np.flatnonzero(labels < 0)]
    out = []
    for rows in groups:
        p, R_xy = ekf.polar_to_sensor_xy(polar[rows], R)
        out.append(Observation(rows, p.mean(axis=0), R_xy))
    return out


class JcbbAssociator(NearestNeighbourAssociator):
    """JCBB data association per cluster with per-landmark batch updates (docs/method.md c.4.1).

    The scan's candidates are clustered (:func:`cluster_observations`); each cluster is gated
    against its :data:`N_PREFILTER` Euclidean-nearest landmarks with the chi-square test of the
    batch measurement (individual compatibility); :func:`jcbb` picks the jointly compatible
    hypothesis with the most pairings; each pairing is applied as one Joseph update with the
    cluster's mean, exactly as :class:`~radarslam.slam.association.BatchAssociator` updates a
    landmark. The alpha test (:meth:`min_log_distance`) is the nearest-neighbour one, unchanged.

    Parameters
    ----------
    beta : float
        Kept for the nearest-neighbour interface; JCBB gates by ``gate_probability`` instead.
    n_nearest : int
        ``N_s`` of the inherited :meth:`best_match` (unused by the JCBB association itself).
    n_nearest_new : int
        ``N_a``: landmarks scored by the alpha test.
    gate_probability : float
        Chi-square gate probability of individual and joint compatibility, in (0, 1).
    max_nodes : int
        Hypothesis nodes the search may visit per scan, at least 1.
    cluster_eps : float
        DBSCAN radius of the observations (m), > 0.
    cluster_min_samples : int
        DBSCAN minimum neighbourhood (the point included), at least 1.
    n_prefilter : int
        Euclidean-nearest landmarks gated per observation, at least 1.

    Attributes
    ----------
    budget_hits : int
        Scans whose search the node budget cut short.
    nodes : int
        Hypothesis nodes visited over all scans.
    last : JcbbResult or None
        The latest scan's search.
    """

    fej = False   # its updates are evaluated at the estimate (no first-estimates Jacobians, c.2.1)

    name = "jcbb"

    def __init__(self, beta: float, n_nearest: int, n_nearest_new: int, gate_probability: float = 0.99,
                 max_nodes: int = 2000, cluster_eps: float = 2.5, cluster_min_samples: int = 2,
                 n_prefilter: int = N_PREFILTER):
        super().__init__(beta, n_nearest, n_nearest_new)
        self.gate = joint_gate(gate_probability)
        self.gate_probability = float(gate_probability)
        for name, value in (("max_nodes", max_nodes), ("cluster_min_samples", cluster_min_samples),
                            ("n_prefilter", n_prefilter)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise InputError(f"{name}: expected an integer >= 1, got {value!r}")
        if not isinstance(cluster_eps, (int, float)) or not cluster_eps > 0.0 or not math.isfinite(cluster_eps):
            raise InputError(f"cluster_eps: expected a finite value > 0, got {cluster_eps!r}")
        self.max_nodes = int(max_nodes)
        self.cluster_eps = float(cluster_eps)
        self.cluster_min_samples = int(cluster_min_samples)
        self.n_prefilter = int(n_prefilter)
        self.budget_hits = 0
        self.nodes = 0
        self.last: JcbbResult | None = None

    def candidate_pairs(self, state: SlamState, observations: Sequence[Observation], spreads: Spreads):
        """Individually compatible ``(observation, landmark)`` pairings (docs/method.md c.4.1 step 2).

        Returns a list (one entry per observation) of lists of ``(j, d2, nu, Hs, idx, N)``, the
        landmark, its individual ``D^2``, innovation, sparse Jacobian and noise, by ``d2`` ascending.
        """
        x, P = state.x, state.P
        c, s = math.cos(x[2]), math.sin(x[2])
        rot = np.array([[c, -s], [s, c]])
        positions = state.positions
        n_lm = positions.shape[0]
        gate1 = self.gate(1)
        out = []
        for ob in observations:
            w = x[:2] + rot @ ob.zbar                                       # world-frame mean
            d = np.sum((positions - w) ** 2, axis=1)
            near = np.argsort(d, kind="stable")[:min(self.n_prefilter, n_lm)]
            cands = []
            for j in near.tolist():
                h, Hs, idx = ekf.sensor_xy_measurement(x, j, state.platform_dim)
                N = ob.noise(x[2], spreads, j)
                S = ekf.innovation_cov(P, Hs, idx, N)
                e = ob.zbar - h
                a, b, dd = S[0, 0], 0.5 * (S[0, 1] + S[1, 0]), S[1, 1]
                det = a * dd - b * b
                if not (a > 0.0 and det > 0.0):
                    continue
                d2 = (dd * e[0] * e[0] - 2.0 * b * e[0] * e[1] + a * e[1] * e[1]) / det
                if d2 < gate1:
                    cands.append((j, d2, e, Hs, idx, N))
            cands.sort(key=lambda t: (t[1], t[0]))
            out.append(cands)
        return out

    def associate(self, state: SlamState, polar: np.ndarray, candidates: np.ndarray, R: np.ndarray,
                  spreads: Spreads) -> tuple[np.ndarray, np.ndarray]:
        out = np.full(candidates.shape[0], -1, dtype=int)
        self.last = None
        if not state.n_landmarks or candidates.size == 0:
            return out, np.empty(0)
        observations = cluster_observations(polar[candidates], R, self.cluster_eps, self.cluster_min_samples)
        cands = self.candidate_pairs(state, observations, spreads)
        # Search order: observations with candidates only, fewest candidates first (ties: cluster
        # order), so the tree branches least near its root (docs/method.md c.4.1 step 3).
        order = sorted((o for o in range(len(observations)) if cands[o]), key=lambda o: (len(cands[o]), o))
        flat = [(rank, o, t) for rank, o in enumerate(order) for t in cands[o]]
        if flat:
            # The common state of the pairings: the pose and every candidate landmark.
            lms = sorted({t[0] for _, _, t in flat})
            G = np.r_[0, 1, 2, np.ravel([[state.index(j), state.index(j) + 1] for j in lms])]
            col = {int(g): c for c, g in enumerate(G)}
            H = np.zeros((len(flat), 2, G.size))
            for m, (_, _, t) in enumerate(flat):
                H[m][:, [col[int(i)] for i in t[4]]] = t[3]
            C = joint_covariance(H, state.P[np.ix_(G, G)], np.array([t[5] for _, _, t in flat]))
            res = jcbb(np.array([r for r, _, _ in flat]), np.array([t[0] for _, _, t in flat]),
                       np.array([t[2] for _, _, t in flat]), C, len(order), self.gate, self.max_nodes)
        else:
            res = JcbbResult((), (), 0.0, 1, False)
        self.last = res
        self.nodes += res.nodes
        self.budget_hits += int(res.exhausted)
        # The updates: one per paired landmark, landmarks ascending, each freshly linearised with
        # its cluster's mean and noise, as the batch update (docs/method.md a.7.3 part 3).
        nis = []
        for rank, j in sorted(res.pairs, key=lambda p: p[1]):
            ob = observations[order[rank]]
            h, Hs, idx = ekf.sensor_xy_measurement(state.x, j, state.platform_dim)
            nis.append(ekf.joseph_update_inplace(state.x, state.P, ob.zbar - h, Hs, idx,
                                                 ob.noise(state.x[2], spreads, j)))
            out[ob.members] = j
        return out, np.array(nis)


def make_jcbb(config) -> JcbbAssociator:
    """From the ``landmarks`` section: ``beta``, ``n_nearest_assoc``, ``n_nearest_new``,
    ``jcbb_gate_probability``, ``jcbb_max_nodes``, ``cluster_eps_m``, ``cluster_min_samples``."""
    lc = config.landmarks
    return JcbbAssociator(lc.beta, lc.n_nearest_assoc, lc.n_nearest_new, lc.jcbb_gate_probability,
                          lc.jcbb_max_nodes, lc.cluster_eps_m, lc.cluster_min_samples)


# The compiled backend's is radarslam.slam._jcbb_numba (the same search, one compiled call a scan).
