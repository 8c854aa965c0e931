"""The partial-view measurement model inside EKF-SLAM (docs/method.md a.12.4-a.12.6).

Under a partial view the detections of a landmark do not scatter about its centroid ``p`` but
about the mean ``mu = p + g(t - p, X)`` of the part of its outline that the sensor at ``t`` sees
(:mod:`radarslam.extent.partial_view`, a.12.1-a.12.3), with the arc's own spread ``S`` instead
of ``gamma_z X``. With ``G = dg/dd`` and ``B = I - G``, ``d mu / dp = B`` and ``d mu / dt = G``,
so the relative vector ``delta = mu - t`` moves as ``B (delta p - delta t)``: every
measurement of the full-view filter keeps its form with ``p - t`` replaced by ``mu - t`` and its
``(t, p)`` Jacobian columns multiplied by ``B`` (a.12.4). This module holds those measurements:

- :func:`view_terms`: ``mu``, ``B`` and ``S`` of every landmark at a state;
- per detection, in polar form (the sequential nearest-neighbour update and every log distance):
  ``h = [|delta|, atan2(delta) - theta]``, ``Hs = [-Hp B, (0, -1)^T, Hp B]``,
  ``R_j = R + Hp (S + Q_v) Hp^T`` (a.12.5);
- per landmark, in the sensor's Cartesian frame (the batch and stacked updates, a.7.3-a.7.4):
  ``h = Rot(-theta) delta``, ``Hs = [-Rot(-theta) B, (h_1, -h_0)^T, Rot(-theta) B]`` and the noise
  ``(Rot(-theta) S Rot(-theta)^T + R_xy) / m + Rot(-theta) Q_v Rot(-theta)^T``, where ``Q_v`` is
  the model-error covariance, which does not shrink with ``m`` (a.12.5);
- the names of the associator schemes that use them (the partial-view forms of ``nearest-neighbour``,
  ``batch`` and ``batch-joint``, which the filter's engine runs: ``slam/fused/view.py``), and the
  view-corrected centroid of a new landmark (a.12.6).

The shapes ``X`` come from the extent estimator (``view_shapes``); they are passed in
:class:`~radarslam.slam.association.Spreads` (``shapes``, ``model_error``).
"""

from __future__ import annotations

import numpy as np

from radarslam.core.errors import InputError
from radarslam.slam.association import (BatchAssociator, JointBatchAssociator, NearestNeighbourAssociator,
                                        Spreads)
from radarslam.slam.layout import POSE_DIM, n_landmarks
from radarslam.slam.state import SlamState
from radarslam.slam.view_kernels import SHAPE_STEP


def _kernels():
    """The compiled kernels of :mod:`radarslam.slam.view_kernels` (:mod:`radarslam.slam._view_compiled`)."""
    from radarslam.slam import _view_compiled
    return _view_compiled


def _rows(a: np.ndarray, shape) -> np.ndarray:
    """``a`` as a contiguous float array of ``shape`` (a ``(2, 2)`` one repeated for every row)."""
    return np.ascontiguousarray(np.broadcast_to(np.asarray(a, dtype=float), shape))


def view_terms(x: np.ndarray, shapes: np.ndarray, js: np.ndarray | None = None, platform: int = POSE_DIM):
    """``mu (N, 2)``, ``B (N, 2, 2)`` and ``S (N, 2, 2)`` of the landmarks ``js`` (all by default)
    of state ``x`` (its platform block of ``platform`` entries, :mod:`.layout`) seen from its pose,
    with the shapes ``shapes (N_all, 2, 2)`` (a.12.4; :func:`~radarslam.slam.view_kernels.view_rows`)."""
    n = n_landmarks(x.shape[0], platform)
    js = np.arange(n, dtype=np.int64) if js is None else np.asarray(js, dtype=np.int64)
    return _kernels().view_rows(_rows(x, x.shape), _rows(shapes, np.shape(shapes)), js, int(platform))


def _exp_sym2_many(xi: np.ndarray) -> np.ndarray:
    """``expm`` of the symmetric log-matrices ``xi (N, 3)`` (entries 11, 12, 22): ``(N, 2, 2)``."""
    return _kernels().exp_sym2_rows(_rows(xi, np.shape(xi)))


def model_errors(x: np.ndarray, spreads: Spreads, js: np.ndarray, step: float = SHAPE_STEP,
                 platform: int = POSE_DIM) -> np.ndarray:
    """``(N, 2, 2)``: the model error of each landmark's predicted mean (a.12.5), ``Q_v``, plus,
    when the shapes come with their covariances, ``J P_xi J^T`` with ``J = dg/dxi`` of the mean
    offset over the log-matrix shape (central differences of ``step``, analytic for 0, a.12.9):
    what the shape's uncertainty adds (:func:`~radarslam.slam.view_kernels.shape_error_rows`)."""
    js = np.asarray(js, dtype=np.int64)
    if spreads.shape_covs is None or js.size == 0:
        return np.repeat(spreads.model_error[None], js.size, axis=0)
    return _kernels().shape_error_rows(_rows(x, x.shape), _rows(spreads.log_shapes, np.shape(spreads.log_shapes)),
                                       _rows(spreads.shape_covs, np.shape(spreads.shape_covs)), js,
                                       _rows(spreads.model_error, (2, 2)), float(step), int(platform))


def view_model_terms(x: np.ndarray, spreads: Spreads, js: np.ndarray, step: float = SHAPE_STEP,
                     platform: int = POSE_DIM):
    """``mu``, ``B``, ``S`` (:func:`view_terms`) and the model errors ``Q (n, 2, 2)``
    (:func:`model_errors`) of the landmarks ``js``: with the shapes' covariances and the analytic
    ``J`` (``step`` 0), from one quadrature pass per landmark (a.12.9 "SLAM's terms from the same
    pass", :func:`~radarslam.slam.view_kernels.view_xi_rows`)."""
    js = np.asarray(js, dtype=np.int64)
    if spreads.shape_covs is None or step != 0.0 or js.size == 0:
        mu, B, S = view_terms(x, spreads.shapes, js, platform)
        return mu, B, S, model_errors(x, spreads, js, step, platform)
    k = _kernels()
    mu, B, S, J = k.view_xi_rows(_rows(x, x.shape), _rows(spreads.shapes, np.shape(spreads.shapes)), js, int(platform))
    return mu, B, S, k.model_error_rows(J, _rows(spreads.shape_covs, np.shape(spreads.shape_covs)), js,
                                        _rows(spreads.model_error, (2, 2)))


def polar_terms(x: np.ndarray, mu: np.ndarray, B: np.ndarray, S: np.ndarray, R: np.ndarray, Qv: np.ndarray):
    """Per landmark, the polar measurement of one detection (a.12.5): ``h (N, 2)``, ``Hs (N, 2, 5)``
    over ``(x, y, theta, p_x, p_y)`` and ``R_j (N, 2, 2)`` (``Qv`` per landmark or one for all);
    ``ok (N,)`` False where ``mu`` sits on the sensor (no bearing: such a landmark cannot be
    scored). :func:`~radarslam.slam.view_kernels.polar_rows`."""
    n = mu.shape[0]
    return _kernels().polar_rows(_rows(x, x.shape), _rows(mu, (n, 2)), _rows(B, (n, 2, 2)), _rows(S, (n, 2, 2)),
                                 _rows(R, (2, 2)), _rows(Qv, (n, 2, 2)))


def sensor_xy_terms(x: np.ndarray, mu: np.ndarray, B: np.ndarray):
    """Per landmark, the sensor-frame Cartesian measurement of the batch update (a.12.5):
    ``h = Rot(-theta)(mu - t)`` ``(N, 2)`` and ``Hs (N, 2, 5)`` over ``(x, y, theta, p_x, p_y)``
    (:func:`~radarslam.slam.view_kernels.sensor_xy_rows`)."""
    n = mu.shape[0]
    return _kernels().sensor_xy_rows(_rows(x, x.shape), _rows(mu, (n, 2)), _rows(B, (n, 2, 2)))


def log_distances(z: np.ndarray, h: np.ndarray, Hs: np.ndarray, Pb: np.ndarray, Rj: np.ndarray) -> np.ndarray:
    """APSIPA eq. (9) of detections ``z (C, 2)`` against landmarks with ``h, Hs, Rj`` and covariance
    blocks ``Pb (N, 5, 5)``: ``D (C, N)``, ``inf`` where the innovation covariance is not positive
    definite (c.4; :func:`~radarslam.slam.view_kernels.log_distance_rows`)."""
    n = h.shape[0]
    return _kernels().log_distance_rows(_rows(z, np.shape(z)), _rows(h, (n, 2)), _rows(Hs, (n, 2, 5)),
                                        _rows(Pb, (n, 5, 5)), _rows(Rj, (n, 2, 2)))


class _PartialView:
    """The partial view's form of an associator scheme (a.12.5): every candidate scored against its
    ``N_s`` landmarks nearest by their predicted detection means ``mu`` (not their centroids), with
    the polar terms of :func:`polar_terms` for the scores and the nearest neighbour's updates and the
    Cartesian ones of :func:`sensor_xy_terms` for the batch updates. The filter's engine runs it, the
    one implementation (``slam/fused/view.py: view_associate``, compiled or by its Python forms);
    the class names the scheme there (``slam/fused/own.py: builtin_associators``). Called on its own
    it refuses in one line, rather than run the full view's kernel of its base class."""

    fej = False   # no first-estimates Jacobians for the partial view (docs/method.md c.2.1)
    #: The model error's ``dg/dxi``: central differences of this step, or analytic for 0 (extent.view_jacobian).
    shape_step = 0.0

    def associate(self, state, polar, candidates, R, spreads):
        raise InputError(f"{type(self).__name__}.associate: the partial view's association runs in the filter "
                         f"(EkfSlam, slam/fused/view.py: view_associate), expected it called there, got a direct call")

    def scores(self, state, polar, candidates, R, spreads):
        return self.associate(state, polar, candidates, R, spreads)

    def min_log_distance(self, state: SlamState, s: np.ndarray, R: np.ndarray) -> float:
        """The alpha test (c.6) keeps the point model with the plain ``R``, as the full view does
        (a.7.2): a new cluster is compared with the landmarks' centroids."""
        return NearestNeighbourAssociator.min_log_distance(self, state, s, R)


class PartialViewNearestNeighbour(_PartialView, NearestNeighbourAssociator):
    """Sequential nearest-neighbour association and point updates under the partial view (a.12.5):
    each candidate against its ``N_s`` landmarks nearest by their predicted means, with the terms of
    those landmarks at the current state (after the previous candidates' updates)."""

    name = "nearest-neighbour"


class PartialViewBatch(_PartialView, BatchAssociator):
    """The per-landmark batch update (a.7.3 part 3) under the partial view (a.12.5): each
    landmark relinearised after the previous one's update, as the full-view form."""

    name = "batch"


class PartialViewJointBatch(PartialViewBatch, JointBatchAssociator):
    """The stacked update of a scan (a.7.4) under the partial view (a.12.5)."""

    name = "batch-joint"


PARTIAL_VIEW_ASSOCIATORS = {"nearest-neighbour": PartialViewNearestNeighbour, "batch": PartialViewBatch,
                            "batch-joint": PartialViewJointBatch}


def partial_view_associator(config):
    """The partial-view form of ``landmarks.associator`` (a.12.5), or a one-line error naming it."""
    lc = config.landmarks
    cls = PARTIAL_VIEW_ASSOCIATORS.get(lc.associator)
    if cls is None:
        raise InputError(f"landmarks.associator: expected one of {sorted(PARTIAL_VIEW_ASSOCIATORS)} with "
                         f"extent.view_model = 'partial', got {lc.associator!r}")
    associator = cls(lc.beta, lc.n_nearest_assoc, lc.n_nearest_new)
    associator.shape_step = 0.0 if config.extent.view_jacobian == "analytic" else SHAPE_STEP
    return associator


def view_corrected_centroid(mean: np.ndarray, t: np.ndarray, X: np.ndarray, iterations: int = 5) -> np.ndarray:
    """The centroid ``p`` whose predicted detection mean seen from ``t`` is ``mean`` under the shape
    ``X``: the fixed point of ``p = mean - g(t - p, X)`` (a.12.6), a few iterations from
    ``p = mean`` (``g`` changes slowly with ``p`` far from the outline)."""
    p = _kernels().corrected_centroid(float(mean[0]), float(mean[1]), float(t[0]), float(t[1]), _rows(X, (2, 2)),
                                      int(iterations))
    return np.array(p)


def view_components(config, extent, associator, default_extent: bool, default_associator: bool):
    """The filter's partial-view parts (a.12.8): ``(Q_v, extent estimator, associator)``. Under
    ``extent.view_model`` partial the default ``rma-efa`` estimator becomes ``partial-view`` and a
    default associator its partial-view form; ``Q_v`` is None under the full view (the components
    are returned as they came)."""
    from radarslam.core.registry import EXTENT_ESTIMATORS

    ec = config.extent
    if not ec.partial_view:
        return None, extent, associator
    if default_extent and ec.estimator == "rma-efa":
        extent = EXTENT_ESTIMATORS.create("partial-view", config)
    if not hasattr(extent, "view_shapes"):
        raise InputError(f"extent.estimator: expected one with shapes for the partial view (partial-view), "
                         f"got {ec.estimator!r} with extent.view_model = {ec.view_model!r}")
    if default_associator:
        associator = partial_view_associator(config)
    return ec.view_model_error_m ** 2 * np.eye(2), extent, associator


def view_walk(state: SlamState, last_angle: dict[int, float], q: float) -> dict[int, float]:
    """The centroid's random walk with the viewing angle (a.12.5, ``extent.view_walk_m2_per_rad`` =
    ``q``): ``P_pp += q |delta phi| I`` for the change of the bearing from each landmark to the
    sensor since the previous scan (``last_angle`` by landmark id); returns this scan's bearings."""
    if q <= 0.0 or not state.n_landmarks:
        return last_angle
    last = np.array([last_angle.get(i, np.nan) for i in state.ids().tolist()], dtype=float)
    phi = _kernels().view_walk_rows(state.x, state.P, last, float(q), state.platform_dim)   # P in place
    return {i: float(a) for i, a in zip(state.ids().tolist(), phi)}
