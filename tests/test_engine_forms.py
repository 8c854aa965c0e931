"""The fused engine's one code in three forms (slam/fused/engine.py ``form``, docs/speed.md "The
engine's three forms"): compiled, its steps run by the interpreter over the compiled kernels, and
all of it run by the interpreter (``core/jit.py: uncompiled``). The Python forms are the same
functions, not a second implementation, so a car-park trial of every family gives the compiled
engine's record to rounding; a changed parameter moves it (the comparison can fail)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import require

require("numba")

from numba import njit  # noqa: E402

from radarslam.config import profile_config  # noqa: E402
from radarslam.config.variants import Variant, apply_variant  # noqa: E402
from radarslam.core.errors import ConfigError  # noqa: E402
from radarslam.core.jit import compiled_only, uncompiled  # noqa: E402
from radarslam.core.types import Odometry  # noqa: E402
from radarslam.simulation.scenario import generate_scenario  # noqa: E402
from radarslam.slam import _fused  # noqa: E402
from radarslam.slam.driver import run_filter  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402


@njit
def _leaf(a):  # a module global, reached through the caller's globals
    return 2.0 * a + 1.0


@njit
def _caller(a):
    return _leaf(a) - 3.0


def test_uncompiled_runs_the_whole_call_graph_in_python_and_compiles_nothing():
    """Through globals and through a closure's cells: the Python form gives the compiled value and
    leaves every dispatcher without a signature (nothing was compiled to get it)."""
    inner = njit(lambda a: a * a)

    @njit
    def outer(a):
        return inner(a) + _caller(a)

    f = uncompiled(outer)
    assert f(3.0) == 9.0 + 4.0
    assert outer.signatures == [] and inner.signatures == [] and _caller.signatures == [] and _leaf.signatures == []
    assert outer(3.0) == f(3.0)          # and compiled, the same value


def test_a_kept_callee_stays_compiled_and_a_compiled_only_one_never_does():
    """``keep`` leaves a callee compiled (it compiles when the Python form calls it); a function
    without a Python entry point (``compiled_only``) refuses a Python call but runs in the Python form."""
    kept = njit(lambda a: a + 1.0)
    inner = compiled_only(lambda a: a * 10.0)

    @njit
    def outer(a):
        return kept(a) + inner(a)

    with pytest.raises(TypeError, match="compiled without a Python entry point"):
        inner(1.0)
    f = uncompiled(outer, keep=lambda d: True)
    assert f(2.0) == 3.0 + 20.0
    assert len(kept.signatures) == 1 and outer.signatures == [] and inner.signatures == []


#: One configuration per family of the fused engine (view, jcbb, bias; slam/fused/engine.py Family).
FAMILIES = {
    "default": None,
    "view": {"extent": {"use_in_slam": True, "spread_model": "visible-faces"}},
    "jcbb": {"landmarks": {"associator": "jcbb"}},
    "bias": {"filter": {"odometry_bias": "states"}},
}


def _same_record(rec, ref, bias: bool = False) -> None:
    """``rec`` is ``ref``'s record: the same landmark counts and associations after every scan, the poses,
    their covariances, every NIS and (``bias``) the bias states to 1e-9."""
    np.testing.assert_array_equal(rec.n_landmarks, ref.n_landmarks)
    np.testing.assert_array_equal(rec.n_associated, ref.n_associated)
    np.testing.assert_allclose(rec.poses, ref.poses, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.pose_covs, ref.pose_covs, rtol=0, atol=1e-9)
    np.testing.assert_allclose(rec.nis_rows, ref.nis_rows, rtol=0, atol=1e-9)
    if bias:
        np.testing.assert_allclose(rec.bias, ref.bias, rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def scenario():
    return generate_scenario(profile_config(), np.random.default_rng(7))


@pytest.mark.parametrize("name", list(FAMILIES))
def test_each_form_gives_the_compiled_engines_record(name, scenario):
    """A car-park trial through each family in each form: the same landmarks after every scan, the
    poses and their covariances equal to 1e-9 (the interpreter's and LLVM's rounding may differ;
    measured: bit-identical on this trial)."""
    cfg = profile_config()
    if FAMILIES[name] is not None:
        cfg = apply_variant(cfg, Variant(name, name, FAMILIES[name]))
    family = _fused.family(EkfSlam(cfg))
    assert (family.view, family.jcbb, family.bias) == (name == "view", name == "jcbb", name == "bias")
    ref = run_filter(cfg, scenario.events)
    assert ref.engine == "fused"
    for how in ("fused-steps", "fused-python"):
        rec = run_filter(cfg, scenario.events, engine=how)
        assert rec.engine == how
        np.testing.assert_array_equal(rec.n_landmarks, ref.n_landmarks)
        np.testing.assert_array_equal(rec.n_associated, ref.n_associated)
        np.testing.assert_array_equal(rec.maps[-1].ids, ref.maps[-1].ids)
        np.testing.assert_allclose(rec.poses, ref.poses, rtol=0, atol=1e-9)
        np.testing.assert_allclose(rec.pose_covs, ref.pose_covs, rtol=0, atol=1e-9)
        np.testing.assert_allclose(rec.nis_rows, ref.nis_rows, rtol=0, atol=1e-9)


def test_the_comparison_sees_a_changed_parameter(scenario):
    """Negative control: the Python form with the association gate moved (landmarks.beta) does not
    give the compiled engine's record on the default configuration."""
    cfg = profile_config()
    moved = apply_variant(cfg, Variant("beta", "beta", {"landmarks": {"beta": cfg.landmarks.beta * 0.5}}))
    ref = run_filter(cfg, scenario.events)
    rec = run_filter(moved, scenario.events, engine="fused-python")
    assert np.abs(rec.poses - ref.poses).max() > 1e-6


def test_an_unknown_form_is_refused_in_one_line(scenario):
    """``engine`` names a form of the engine; another value is refused naming the choices."""
    with pytest.raises(ConfigError, match="engine: expected one of auto, fused-steps, fused-python, got 'orchestrator'"):
        run_filter(profile_config(), scenario.events, engine="orchestrator")


def test_a_motion_model_of_the_users_own_runs_in_the_steps_form_with_every_kernel_compiled(scenario):
    """A motion model registered through the registry, written in Python, runs where the steps call
    the built-in one (plan.py ``user_components``): the run is the steps form's (every kernel around
    it compiled), its model called once per odometry event. Oracle: a model of the user's own that
    computes what the built-in unicycle does gives the compiled built-in's record; the slower one's run
    differs from it (the model was used)."""
    from radarslam.core.registry import MOTION_MODELS
    from radarslam.models.motion import UnicycleModel

    calls = []

    class Slower(UnicycleModel):
        name = "slower"

        def step(self, pose, u, dt):
            calls.append(dt)
            return super().step(pose, np.array([0.9 * u[0], u[1]]), dt)

    class Plain(UnicycleModel):
        name = "plain"

        def step(self, pose, u, dt):
            calls.append(dt)
            return super().step(pose, u, dt)

    MOTION_MODELS.register("slower", lambda f: Slower())
    MOTION_MODELS.register("plain", lambda f: Plain())
    try:
        cfg = profile_config()
        n_odometry = sum(isinstance(e, Odometry) for e in scenario.events)
        builtin = run_filter(cfg, scenario.events)
        plain = run_filter(apply_variant(cfg, Variant("plain", "plain", {"filter": {"motion_model": "plain"}})),
                           scenario.events)
        assert (builtin.engine, plain.engine) == ("fused", "fused-steps") and len(calls) == n_odometry
        _same_record(plain, builtin)
        calls[:] = []
        mine = apply_variant(cfg, Variant("slower", "slower", {"filter": {"motion_model": "slower"}}))
        rec = run_filter(mine, scenario.events)
        assert rec.engine == "fused-steps" and len(calls) == n_odometry
        assert np.abs(builtin.poses[:, :2] - rec.poses[:, :2]).max() > 0.1
    finally:
        MOTION_MODELS.unregister("slower")
        MOTION_MODELS.unregister("plain")


def test_a_motion_model_of_the_users_own_with_the_bias_states_and_an_input_bias_of_its_own(scenario):
    """With the odometry-bias states (c.11) a motion model of the user's own runs in the steps form too,
    and an ``input_bias`` of a class of its own (here: the speed scale applied twice over) is called
    where the bias steps correct the input. Oracle: the model of the user's own with the built-in input
    bias gives the compiled built-in unicycle's record with the same bias states, and the doubled
    correction's differs from it (the user's correction was used)."""
    from dataclasses import dataclass

    from radarslam.core.registry import MOTION_MODELS
    from radarslam.models.input_bias import InputBias
    from radarslam.models.motion import UnicycleModel

    corrected = []

    @dataclass(frozen=True)
    class Doubled(InputBias):
        def correct(self, u, b):
            corrected.append(1)
            return super().correct(u, 2.0 * np.asarray(b))

        def jacobians(self, u, b):
            Cu, Cb = super().jacobians(u, 2.0 * np.asarray(b))
            return Cu, 2.0 * Cb

    class Own(UnicycleModel):
        name = "own"

    class OwnDoubled(UnicycleModel):
        name = "own-doubled"
        input_bias = Doubled(**{k: getattr(UnicycleModel.input_bias, k) for k in
                                ("scaled", "offset", "names", "units", "offset_keys")})

    MOTION_MODELS.register("own", lambda f: Own())
    MOTION_MODELS.register("own-doubled", lambda f: OwnDoubled())
    try:
        cfg = profile_config()
        recs = {}
        for name in ("own", "own-doubled"):
            mine = apply_variant(cfg, Variant(name, name, {"filter": {"motion_model": name, "odometry_bias": "states",
                                                                      "bias_scale_std": 0.1}}))
            rec = run_filter(mine, scenario.events)
            assert rec.engine == "fused-steps"
            assert len(corrected) == (0 if name == "own" else sum(isinstance(e, Odometry) for e in scenario.events))
            recs[name] = rec
            corrected[:] = []
        builtin = run_filter(apply_variant(cfg, Variant("b", "b", {"filter": {"odometry_bias": "states",
                                                                              "bias_scale_std": 0.1}})), scenario.events)
        assert builtin.engine == "fused"
        _same_record(recs["own"], builtin, bias=True)
        assert np.abs(recs["own"].bias - recs["own-doubled"].bias).max() > 1e-4
    finally:
        MOTION_MODELS.unregister("own")
        MOTION_MODELS.unregister("own-doubled")


def test_an_associator_of_the_users_own_runs_in_the_steps_form_with_every_kernel_compiled(scenario):
    """An associator registered through the registry, written in Python (the reference backend's
    batch-joint associator with a quarter of the gate), runs where the engine's steps call step 4 and
    step 7's alpha test (slam/fused/own.py): the run is the steps form's and the associator is called
    on scans with landmarks and on clusters' centres. Oracle: the same associator with the built-in's
    gate gives the compiled built-in batch-joint associator's record; the narrow gate's run associates
    less (the user's gate was used)."""
    from radarslam.core.registry import ASSOCIATORS
    from radarslam.slam.association import JointBatchAssociator

    calls = {"associate": 0, "alpha": 0}

    class Narrow(JointBatchAssociator):
        def associate(self, state, polar, candidates, R, spreads):
            calls["associate"] += 1
            return super().associate(state, polar, candidates, R, spreads)

        def min_log_distance(self, state, s, R):
            calls["alpha"] += 1
            return super().min_log_distance(state, s, R)

    ASSOCIATORS.register("narrow", lambda c: Narrow(c.landmarks.beta / 4.0, c.landmarks.n_nearest_assoc,
                                                    c.landmarks.n_nearest_new))
    ASSOCIATORS.register("same", lambda c: Narrow(c.landmarks.beta, c.landmarks.n_nearest_assoc,
                                                  c.landmarks.n_nearest_new))
    try:
        cfg = profile_config()
        builtin = run_filter(apply_variant(cfg, Variant("bj", "bj", {"landmarks": {"associator": "batch-joint"}})),
                             scenario.events)
        same = run_filter(apply_variant(cfg, Variant("same", "same", {"landmarks": {"associator": "same"}})),
                          scenario.events)
        assert (builtin.engine, same.engine) == ("fused", "fused-steps")
        assert calls["associate"] > 100 and calls["alpha"] > 100
        _same_record(same, builtin)
        mine = apply_variant(cfg, Variant("narrow", "narrow", {"landmarks": {"associator": "narrow"}}))
        rec = run_filter(mine, scenario.events)
        assert rec.engine == "fused-steps"
        assert int(builtin.n_associated.sum()) > int(rec.n_associated.sum())
    finally:
        ASSOCIATORS.unregister("narrow")
        ASSOCIATORS.unregister("same")


class _ScatterState:
    def __init__(self):
        self.n, self.s1, self.s2 = 0, np.zeros(2), np.zeros((2, 2))


class _Scatter:
    """An extent estimator of the user's own: 4 x the scatter of every detection associated so far (at
    least 3), which widens association (its spreads) and sifts by a Mahalanobis contour of its own."""

    posterior_centroid = False

    def __init__(self, calls):
        self.calls = calls

    def new(self):
        return _ScatterState()

    def step(self, st, polar, pts, centroid, centroid_cov, pose, pose_cov, dt, k):
        self.calls["step"] += 1
        st.n += pts.shape[0]
        st.s1 = st.s1 + pts.sum(axis=0)
        st.s2 = st.s2 + pts.T @ pts

    def merge(self, survivor, gone):
        self.calls["merge"] += 1
        survivor.n, survivor.s1, survivor.s2 = survivor.n + gone.n, survivor.s1 + gone.s1, survivor.s2 + gone.s2
        return survivor

    def matrix(self, st):
        if st.n < 3:
            return None
        m = st.s1 / st.n
        return 4.0 * (st.s2 / st.n - np.outer(m, m)) + 0.01 * np.eye(2)

    def baseline(self, st):
        return None

    def spreads(self, states):
        X = [self.matrix(s) for s in states]
        has = np.array([x is not None for x in X], dtype=bool)
        return np.array([0.25 * x if x is not None else np.zeros((2, 2)) for x in X]).reshape(-1, 2, 2), has

    def sift(self, states, points, polar, centroids, centroid_covs, pose, pose_cov):
        self.calls["sift"] += 1
        X = [self.matrix(s) for s in states]
        has = np.array([x is not None for x in X], dtype=bool)
        inside = np.zeros((points.shape[0], len(states)), dtype=bool)
        for j, x in enumerate(X):
            if x is not None:
                d = points - centroids[j]
                inside[:, j] = np.einsum("ni,ij,nj->n", d, np.linalg.inv(x + centroid_covs[j]), d) < 9.0
        return inside, has

    def initial_spread(self):
        return None


def test_an_extent_estimator_of_the_users_own_runs_in_the_steps_form_with_every_kernel_compiled(scenario):
    """An extent estimator registered through the registry, written in Python (the scatter of the
    associated detections, which sifts by its own contour and widens association by its own spreads),
    runs where the engine's steps read or change extents (slam/fused/own.py: UserExtents): the run is
    the steps form's and the estimator is called (sift, step, merge). Oracle: the same filter event by
    event (EkfSlam, its extents the estimator's own live states) gives the whole stream's record, and
    every landmark's extent in the map is the estimator's ``matrix`` of its state; the built-in
    estimator's run differs (the user's extents were used)."""
    from radarslam.core.registry import EXTENT_ESTIMATORS

    calls = {"sift": 0, "step": 0, "merge": 0}
    EXTENT_ESTIMATORS.register("scatter", lambda c: _Scatter(calls))
    try:
        cfg = profile_config()
        mine = apply_variant(cfg, Variant("scatter", "scatter", {"extent": {"estimator": "scatter"},
                                                                 "landmarks": {"merge_distance_m": 6.0}}))
        rec = run_filter(mine, scenario.events)
        assert rec.engine == "fused-steps"
        steps_calls = dict(calls)
        calls.update(sift=0, step=0, merge=0)
        slam = EkfSlam(mine)
        ref = run_filter(mine, scenario.events, slam=slam)
        assert steps_calls == calls and calls["sift"] > 100 and calls["step"] > 500 and calls["merge"] > 0, calls
        _same_record(rec, ref)
        for a, b in zip(rec.maps, ref.maps):
            np.testing.assert_array_equal(a.ids, b.ids)
            np.testing.assert_allclose(a.rma, b.rma, rtol=0, atol=1e-9)
            assert np.isnan(a.efa).all() and np.isnan(b.efa).all()
        last, n = rec.maps[-1], slam.state.n_landmarks
        est = slam.extent
        for j in range(n):
            X = est.matrix(slam.state.extents[j])
            want = np.full((2, 2), np.nan) if X is None else X
            np.testing.assert_allclose(last.rma[j], want, rtol=0, atol=1e-12)
        assert (~np.isnan(last.rma[:n, 0, 0])).sum() >= 5
        builtin = run_filter(apply_variant(mine, Variant("rma", "rma", {"extent": {"estimator": "rma-efa"}})),
                             scenario.events)
        assert builtin.engine == "fused" and np.abs(builtin.poses[:, :2] - rec.poses[:, :2]).max() > 1e-3
    finally:
        EXTENT_ESTIMATORS.unregister("scatter")
