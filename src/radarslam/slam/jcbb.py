"""Joint Compatibility Branch and Bound association per cluster (docs/method.md c.4.1).

JCBB (Neira and Tardos, IEEE Trans. Robot. Autom. 17(6), 2001) chooses the largest set of
pairings between observations and landmarks whose innovations are *jointly* compatible with the
filter's covariance, instead of pairing each observation with its individually nearest landmark.
Pairings that share the pose error are judged together, so an offset pose that makes each
observation look like its neighbour's landmark is recognised as one offset.

Here an observation is a cluster of the scan's candidate detections (DBSCAN in the sensor frame),
summarised by its sensor-frame mean exactly as the per-landmark batch update fuses a landmark's
detections (docs/method.md a.7.3, part 3), and each chosen pairing is applied as that batch
update. Three layers:

- :func:`~radarslam.slam.jcbb_search.jcbb`, the pure search on arrays (innovations and their joint
  covariance), testable on synthetic problems (:mod:`radarslam.slam.jcbb_search`);
- :func:`~radarslam.slam._jcbb_numba.jcbb_associate_scan`, one scan's clustering, gating, search and
  updates, the kernel the fused engine's step 4 calls;
- :class:`JcbbAssociator`, the component registered as ``"jcbb"``, which runs that kernel compiled
  or, under ``filter.backend = "python"``, in the interpreter (:func:`~radarslam.slam.association.kernel_form`).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.errors import InputError
from radarslam.slam._jcbb_numba import jcbb_associate_scan, joint_gates
from radarslam.slam.association import NearestNeighbourAssociator, kernel_form
from radarslam.slam.jcbb_search import JcbbResult, chi2_quantile, jcbb, joint_covariance, joint_gate

__all__ = ["N_PREFILTER", "CompiledJcbbAssociator", "JcbbAssociator", "JcbbResult", "chi2_quantile", "jcbb",
           "joint_covariance", "joint_gate", "make_compiled_jcbb", "make_jcbb"]

#: Landmarks Euclidean-nearest to a cluster's world-frame mean that are gated by Mahalanobis
#: distance (docs/method.md c.4.1 step 2): the prefilter keeps the gating O(clusters x 8).
N_PREFILTER = 8


class JcbbAssociator(NearestNeighbourAssociator):
    """JCBB data association per cluster with per-landmark batch updates (docs/method.md c.4.1).

    The scan's candidates are clustered (DBSCAN in the sensor frame); each cluster is gated against
    its :data:`N_PREFILTER` Euclidean-nearest landmarks with the chi-square test of the batch
    measurement (individual compatibility); the branch and bound picks the jointly compatible
    hypothesis with the most pairings; each pairing is applied as one Joseph update with the
    cluster's mean, exactly as :class:`~radarslam.slam.association.BatchAssociator` updates a
    landmark. The alpha test (:meth:`min_log_distance`) is the nearest-neighbour one, unchanged.

    Parameters
    ----------
    beta : float
        Kept for the nearest-neighbour interface; JCBB gates by ``gate_probability`` instead.
    n_nearest : int
        ``N_s`` of the nearest-neighbour interface (unused by the JCBB association itself).
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
    backend : {"python", "numba"}
        How the kernel runs; the class's own by default.

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
                 n_prefilter: int = N_PREFILTER, backend: str | None = None):
        super().__init__(beta, n_nearest, n_nearest_new, backend)
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
        self._gates = joint_gates(self.gate_probability, 64)

    def gates(self, depth: int) -> np.ndarray:
        """:func:`~radarslam.slam._jcbb_numba.joint_gates` to at least ``depth`` pairings (kept and grown)."""
        if self._gates.shape[0] <= depth:
            self._gates = joint_gates(self.gate_probability, max(depth, 2 * (self._gates.shape[0] - 1)))
        return self._gates

    def associate(self, state, polar, candidates, R, spreads):
        self.last = None
        if not state.n_landmarks or candidates.size == 0:
            return np.full(candidates.shape[0], -1, dtype=int), np.empty(0)
        x, P, out, nis, (rows, obs, lm, d2, nodes, exhausted) = kernel_form(jcbb_associate_scan, self.backend)(
            state.x, state.P, polar, candidates.astype(np.int64), R, spreads.gX, spreads.has, state.platform_dim,
            self.cluster_eps, self.cluster_min_samples, self.n_prefilter, self.gates(candidates.size),
            self.max_nodes)
        state.set(x, P)
        self.last = JcbbResult(tuple(zip(obs.tolist(), lm.tolist())), tuple(rows.tolist()), float(d2), int(nodes),
                               bool(exhausted))
        self.nodes += self.last.nodes
        self.budget_hits += int(self.last.exhausted)
        return out, nis


class CompiledJcbbAssociator(JcbbAssociator):
    """:class:`JcbbAssociator`, its kernel compiled (``filter.backend = "numba"``)."""

    backend = "numba"


def _factory(cls):
    def make(config):
        """From the ``landmarks`` section: ``beta``, ``n_nearest_assoc``, ``n_nearest_new``,
        ``jcbb_gate_probability``, ``jcbb_max_nodes``, ``cluster_eps_m``, ``cluster_min_samples``."""
        lc = config.landmarks
        return cls(lc.beta, lc.n_nearest_assoc, lc.n_nearest_new, lc.jcbb_gate_probability, lc.jcbb_max_nodes,
                   lc.cluster_eps_m, lc.cluster_min_samples)
    return make


# The factories core.registry.BUILT_INS names, per backend.
make_jcbb = _factory(JcbbAssociator)
make_compiled_jcbb = _factory(CompiledJcbbAssociator)
