"""Components of the user's own in the fused engine (docs/architecture.md "Components of your own"): a
motion model or an associator registered through the registry and written in Python runs where the
engine's steps call the built-in one, every other step compiled.

The engine's steps form (``engine.form(family, "steps", replace)``, ``core/jit.py: uncompiled``) runs the
steps of ``slam/fused/`` in Python over their compiled kernels; :func:`user_components` gives the
``replace`` pairs, each a Python function with the signature of the step it stands in for:

- a motion model: ``_motion(x, u, dt, code, cfg) -> (pose, F_x, F_u)`` by the model's ``step`` and
  ``jacobians`` (the MotionModel protocol); with the odometry-bias states (c.11) and an ``input_bias``
  of a class of its own, also the input's correction and its Jacobians (``_correct_input``,
  ``_input_jacobians``) by that class's ``correct`` and ``jacobians``;
- an associator: step 4, ``associate_step`` (c.4, a.7.2), by the associator's ``associate`` on a
  :class:`~radarslam.slam.state.SlamState` over the engine's mean, covariance and landmark records with
  the engine's own noise inflation (``tracking._inflation``: the :class:`Spreads` of the built-in
  extents), and step 7's alpha test, ``alpha_test`` (c.6), by its ``min_log_distance``;
- an extent estimator (:class:`UserExtents`): its per-landmark states are kept beside the engine's
  records, by landmark id, and the steps that read or change extents call it: step 3's sifting test
  (``sift``), step 4's spreads (``_inflation``), step 6 (``extent_step``), and after each scan its
  ``merge`` for step 10's merges and ``new`` for the landmarks born; its ``matrix`` and ``baseline`` are
  written into the engine's extent rows after every scan, so that the record's maps and a retired
  landmark's row (c.15) carry them.
"""

from __future__ import annotations

import numpy as np

__all__ = ["UserExtents", "builtin_associators", "own_associator", "own_extent", "own_motion", "reference_kernels",
           "run_form", "user_components"]


def own_motion(slam) -> bool:
    """Whether ``slam``'s odometer predictions run a motion model of the user's own (not the unicycle or
    Ackermann model; under Doppler odometry, c.10.5, the body-velocity model drives every prediction)."""
    from radarslam.models.ackermann import AckermannModel
    from radarslam.models.motion import UnicycleModel

    return slam.config.filter.odometry == "odometer" and type(slam.model) not in (UnicycleModel, AckermannModel)


def builtin_associators() -> dict:
    """The associators whose kernels the engine's step 4 calls, each with its ``FusedParams.assoc``: the
    nearest neighbour (0), batch (1), batch-joint (2) and JCBB (3) associators, under either backend (the
    same kernels, compiled or not: slam/association.py) and in the partial view's forms."""
    from radarslam.slam import association as a
    from radarslam.slam.jcbb import CompiledJcbbAssociator, JcbbAssociator
    from radarslam.slam.partial_view import PartialViewBatch, PartialViewJointBatch, PartialViewNearestNeighbour

    return {a.NearestNeighbourAssociator: 0, a.CompiledNearestNeighbourAssociator: 0, PartialViewNearestNeighbour: 0,
            a.BatchAssociator: 1, a.CompiledBatchAssociator: 1, PartialViewBatch: 1,
            a.JointBatchAssociator: 2, a.CompiledJointBatchAssociator: 2, PartialViewJointBatch: 2,
            JcbbAssociator: 3, CompiledJcbbAssociator: 3}


def own_associator(slam) -> bool:
    """Whether ``slam``'s associator is of the user's own: none of the engine's (:func:`builtin_associators`)."""
    return type(slam.associator) not in builtin_associators()


def own_extent(slam) -> bool:
    """Whether ``slam``'s extent estimator is of the user's own: none of the engine's (RMA/EFA, the
    visible arc, MEM-EKF* and the partial view's)."""
    from radarslam.extent.estimator import RmaEfaEstimator
    from radarslam.extent.mem_ekf import MemEkfEstimator
    from radarslam.extent.view_estimator import PartialViewEstimator
    from radarslam.extent.visible_arc import VisibleArcEstimator

    return type(slam.extent) not in (RmaEfaEstimator, VisibleArcEstimator, MemEkfEstimator, PartialViewEstimator)


def user_components(slam) -> tuple:
    """The components of the user's own in ``slam`` (one ``plan.why_not`` accepts) as the ``replace``
    pairs of :func:`~radarslam.slam.fused.engine.form` (module docstring). Empty when every component
    is built in."""
    from radarslam.models.input_bias import InputBias

    pairs = []
    if own_motion(slam):
        pairs.append(("_motion", _user_motion(slam.model)))
        spec = None if slam.bias_model is None else slam.bias_model.spec
        if spec is not None and type(spec) is not InputBias:
            pairs += _user_input_bias(spec)
    extents = UserExtents(slam.extent) if own_extent(slam) else None
    if own_associator(slam):
        pairs += [("associate_step", _user_association(slam.associator, extents)),
                  ("alpha_test", _user_alpha_test(slam.associator))]
    if extents is not None:
        pairs.append(("scan_event", extents.scan_event(dict(pairs))))
    return tuple(pairs)


def reference_kernels(how: str) -> tuple:
    """The ``replace`` pairs of the engine's Python form (``how`` "python"; none otherwise): the EKF
    updates and ``R_eff`` in the reference's numpy form (``slam/ekf.py: joseph_update_inplace``, ``r_eff``,
    ``joint_update_inplace``), of which ``slam/_numba.py``'s loops are numba's form (``core.jit.
    compile_kernels``' ``replace``, ``joint_update_loops``; they agree to rounding, tests/test_backends.py).
    The interpreter runs the n x n pass as numpy's whole-array operations rather than element by element
    (a car-park trial 0.36 s instead of 1.6 s; benchmarks/bench_forms.py)."""
    if how != "python":
        return ()
    from radarslam.slam import ekf

    def joint_update(x, P, e, Hs, idx, Rb):
        """``joint_update_loops``' sparse blocks as the reference's dense ``H`` and block-diagonal ``R``."""
        q = 2 * Hs.shape[0]
        H, R = np.zeros((q, x.shape[0])), np.zeros((q, q))
        for a in range(Hs.shape[0]):
            H[2 * a:2 * a + 2, idx[a]] = Hs[a]
            R[2 * a:2 * a + 2, 2 * a:2 * a + 2] = Rb[a]
        return ekf.joint_update_inplace(x, P, e, H, R)

    return (("_joseph_update_inplace", ekf.joseph_update_inplace), ("_r_eff", ekf.r_eff),
            ("joint_update_loops", joint_update))


def run_form(slam, how: str = "compiled") -> str:
    """The form ``plan.run`` runs ``slam`` in when asked for ``how``: the Python form under the reference
    backend (``filter.backend = "python"``: every step and kernel by the interpreter); the steps form in
    the place of the compiled one where ``slam`` has a component of the user's own (the user's component
    in Python, every kernel around it compiled); else ``how``."""
    if slam.config.filter.backend == "python":
        return "python"
    return "steps" if how == "compiled" and (own_motion(slam) or own_associator(slam) or own_extent(slam)) else how


def _user_motion(model):
    """The steps' ``_motion(x, u, dt, code, cfg) -> (pose, F_x, F_u)`` of an odometer reading by
    ``model``'s own ``step`` and ``jacobians`` (the MotionModel protocol) (``code`` is the built-in model's, unused)."""

    def motion(x, u, dt, code, cfg):
        pose = x[:3].copy()
        Fx, Fu = model.jacobians(pose, u, dt)
        return (np.asarray(model.step(pose, u, dt), dtype=float), np.asarray(Fx, dtype=float),
                np.asarray(Fu, dtype=float))

    return motion


def _user_input_bias(spec) -> list:
    """The bias steps' input correction ``c(u, b)`` and its Jacobians ``(C_u, C_b)`` (c.11.1) by ``spec``'s
    own ``correct`` and ``jacobians`` (the kernels' index arguments, the built-in class's, unused)."""

    def correct_input(u, b, scaled, offset, turn):
        return np.asarray(spec.correct(u, b), dtype=float)

    def input_jacobians(u, b, scaled, offset, turn):
        Cu, Cb = spec.jacobians(u, b)
        return np.asarray(Cu, dtype=float), np.asarray(Cb, dtype=float)

    return [("_correct_input", correct_input), ("_input_jacobians", input_jacobians)]


def _state(x, P, lm, cfg, pose_first=None):
    """A :class:`~radarslam.slam.state.SlamState` over the engine's mean ``x`` and covariance ``P`` (the same
    arrays) and, with ``lm``, its landmarks' records; under first-estimates Jacobians (``cfg.fej``, c.2.1)
    the prediction ``pose_first`` as the pose the Jacobians are taken at."""
    from radarslam.landmarks.records import Records, new_records
    from radarslam.slam.state import SlamState

    records = new_records(1) if lm is None else Records(lm.ids, lm.created, lm.mbits, lm.rbits, lm.first)
    lin = None if pose_first is None or not cfg.fej else np.array(pose_first, dtype=float)
    return SlamState(x, P, records=records, platform_dim=int(cfg.platform), lin_pose=lin)


def _user_association(associator, extents=None):
    """Step 4 (``view.associate_step``) by ``associator.associate`` (the Associator protocol) with the
    association noise ``n_c R`` (c.11.9) and the spreads of the engine's inflation (a.7.2, c.17's
    ``offset_k``), or of an extent estimator of the user's own (``extents``, :class:`UserExtents`).
    Returns ``(x, P, landmark per candidate or -1, NIS values)`` as the step does."""
    from radarslam.slam.association import Spreads
    from radarslam.slam.fused.tracking import _inflation

    inflation = _inflation if extents is None else extents.inflation

    def associate_step(x, P, polar, cidx, lm, N, pose_first, shapes, terms, noise, cfg, view, jcbb):
        if N == 0:
            return x, P, np.full(cidx.shape[0], -1, dtype=np.int64), np.empty(0)
        gX, has = inflation(lm, N, noise, cfg)
        st = _state(x, P, lm, cfg, pose_first)
        out, nis = associator.associate(st, polar, cidx, noise.R_assoc, Spreads(gX, has, offset_k=cfg.offset_k))
        return (np.ascontiguousarray(st.x, dtype=float), np.ascontiguousarray(st.P, dtype=float),
                np.asarray(out, dtype=np.int64), np.asarray(nis, dtype=float).reshape(-1))

    return associate_step


def _user_alpha_test(associator):
    """Step 7's alpha test (``mapping.alpha_test``) by ``associator.min_log_distance`` with the plain R
    (a.7.2 inflates only association and update): the clusters whose centre is farther than
    ``cfg.alpha`` from every landmark, in order. The state it reads holds the mean and covariance; the
    engine's step gives it no landmark records (the test needs none)."""

    def alpha_test(x, P, polar, clusters, noise, cfg):
        st = _state(x, P, None, cfg)
        fresh = [c for c, i in enumerate(clusters.centre.tolist())
                 if associator.min_log_distance(st, polar[i], noise.R) > cfg.alpha]
        return np.array(fresh, dtype=np.int64)

    return alpha_test


class UserExtents:
    """The extent states of an estimator of the user's own (``extent``, the ExtentEstimator protocol of
    docs/architecture.md) beside the engine's records, by landmark id, and the steps that use them (module
    docstring), each at its step of docs/method.md a.8 (sift, associate and update, extent step,
    augment, merge). One per run."""

    def __init__(self, extent):
        self.extent = extent
        self.states: dict[int, object] = {}
        self.k = 0

    def of(self, lm, N) -> list:
        """The states of the engine's ``N`` landmarks in state order; a landmark born since, ``extent.new()``."""
        out = []
        for lid in lm.ids[:N].tolist():
            if lid not in self.states:
                self.states[lid] = self.extent.new()
            out.append(self.states[lid])
        return out

    def sift(self, x, P, polar, lm, N, prior, noise, cfg):
        """Step 3 (``tracking.sift``): the estimator's own test where it has one, the radius test otherwise."""
        from radarslam.landmarks._compiled import compiled_candidates
        from radarslam.slam.fused.tracking import _to_world

        m = polar.shape[0]
        if N == 0 or m == 0:
            return np.zeros(m, dtype=np.bool_)
        pos_prior, cov_prior = prior
        xy = _to_world(x, polar)
        test = self.extent.sift(self.of(lm, N), xy, polar, pos_prior, cov_prior, x[:3].copy(), P[:3, :3].copy())
        inside, has = (np.zeros((1, 1), dtype=np.bool_), np.zeros(N, dtype=np.bool_)) if test is None else test
        return compiled_candidates(xy, pos_prior, cfg.sift_radius * cfg.sift_radius,
                                   np.asarray(inside, dtype=np.bool_), np.asarray(has, dtype=np.bool_))

    def inflation(self, lm, N, noise, cfg):
        """Step 4's ``(gX, has)`` (``tracking._inflation``): the estimator's ``spreads``."""
        gX, has = self.extent.spreads(self.of(lm, N))
        return np.asarray(gX, dtype=float).reshape(N, 2, 2), np.asarray(has, dtype=np.bool_).reshape(N)

    def extent_step(self, x, P, polar, xy, lm, N, old, aoff, arow, prior, dt, arcs, n_arcs, noise, cfg, view):
        """Step 6 (``extent.extent_step``): the estimator's ``step_all``, or ``step`` for each landmark, with
        its detections, its centroid (posterior, or the prediction's) and the pose."""
        ext = self.extent
        if not getattr(ext, "active", True) or N == 0:
            return lm, arcs, n_arcs
        from radarslam.slam.fused.storage import _blocks

        states = self.of(lm, N)
        if ext.posterior_centroid:
            cents, covs = _blocks(x, P, cfg.platform)
        else:
            rows = old[:N]
            cents, covs = prior[0][rows], prior[1][rows]
        pose, pose_cov = x[:3].copy(), P[:3, :3].copy()
        assoc = [arow[aoff[j]:aoff[j + 1]].tolist() for j in range(N)]
        step_all = getattr(ext, "step_all", None)
        if step_all is not None:
            step_all(states, polar, xy, assoc, cents, covs, pose, pose_cov, dt, self.k)
        else:
            for j, st in enumerate(states):
                ext.step(st, polar[assoc[j]], xy[assoc[j]], cents[j], covs[j], pose, pose_cov, dt, self.k)
        return lm, arcs, n_arcs

    def after_scan(self, lm, N, merged) -> None:
        """Step 10's merges by the estimator's ``merge`` (in order), the states of the landmarks gone
        dropped, and every landmark's ``matrix`` and ``baseline`` written into the engine's rows (RMA
        and EFA of the record's maps; NaN for None)."""
        for kept, gone in np.asarray(merged).reshape(-1, 2).tolist():
            self.states[kept] = self.extent.merge(self.states[kept], self.states.pop(gone))
        states = self.of(lm, N)
        self.states = dict(zip(lm.ids[:N].tolist(), states))
        nan = np.full((2, 2), np.nan)
        for j, st in enumerate(states):
            X, B = self.extent.matrix(st), self.extent.baseline(st)
            lm.einit[j] = X is not None or B is not None
            lm.X[j] = nan if X is None else X
            lm.Xefa[j] = nan if B is None else B

    def scan_event(self, others: dict):
        """``events.scan_event`` in Python with this estimator's steps (and ``others``, the user's other
        components) in the place of the built-in ones, :meth:`after_scan` after it."""
        from radarslam.core.jit import uncompiled
        from radarslam.slam.fused import events
        from radarslam.slam.fused.engine import _kernels_kept

        inner = uncompiled(events.scan_event, _kernels_kept("steps"),
                           {**others, "sift": self.sift, "_inflation": self.inflation, "extent_step": self.extent_step})

        def scan_event(c, stream, s, a_rows, n_arows, noise, cfg, view, jcbb, bias):
            self.k = int(stream.scan_k[s])
            res = inner(c, stream, s, a_rows, n_arows, noise, cfg, view, jcbb, bias)
            self.after_scan(res[0].lm, int(res[0].N), res[6].merged)
            return res

        scan_event.extents = self            # the states, for the filter run event by event (slam/per_event.py)
        return scan_event
