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

- :func:`~radarslam.slam.jcbb_search.jcbb`, the pure search on arrays (innovations and their joint
  covariance), testable on synthetic problems (:mod:`radarslam.slam.jcbb_search`);
- :class:`JcbbAssociator`, the component registered as ``"jcbb"``, the reference
  (``filter.backend = "python"``); :mod:`radarslam.slam._jcbb_numba` is the compiled one, which
  the fused engine runs too.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from radarslam.core.errors import InputError
from radarslam.landmarks.clustering import dbscan_labels
from radarslam.slam import ekf
from radarslam.slam.association import NearestNeighbourAssociator, Spreads
from radarslam.slam.jcbb_search import JcbbResult, chi2_quantile, jcbb, joint_covariance, joint_gate
from radarslam.slam.state import SlamState

__all__ = ["N_PREFILTER", "JcbbAssociator", "JcbbResult", "Observation", "chi2_quantile", "cluster_observations", "jcbb",
           "joint_covariance", "joint_gate", "make_jcbb"]

#: Landmarks Euclidean-nearest to a cluster's world-frame mean that are gated by Mahalanobis
#: distance (docs/method.md c.4.1 step 2): the prefilter keeps the gating O(clusters x 8).
N_PREFILTER = 8


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
