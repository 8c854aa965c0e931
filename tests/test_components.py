"""Injectable components: registries, a toy associator and a toy extent estimator registered from
this file and selected by name in a configuration, and the compiled associator against the Python
one on random states and scans."""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.config import from_dict, load_config, to_dict
from radarslam.core.errors import ConfigError
from radarslam.core.registry import ASSOCIATORS, EXTENT_ESTIMATORS, MOTION_MODELS, Registry
from radarslam.simulation.trial import run_trial
from radarslam.models.motion import UnicycleModel
from radarslam.slam import EkfSlam, ekf
from radarslam.slam.association import BatchAssociator, NearestNeighbourAssociator, Spreads
from radarslam.slam.state import SlamState

from conftest import require


# ---------------------------------------------------------------------------------------- toys
class EuclideanAssociator:
    """Toy: each candidate goes to the Euclidean-nearest landmark within ``gate`` metres."""

    def __init__(self, gate: float):
        self.gate = gate
        self.calls = 0

    def associate(self, state, polar, candidates, R, spreads):
        self.calls += 1
        out = np.full(candidates.shape[0], -1)
        for c, i in enumerate(candidates.tolist()):
            pose = state.pose
            a = pose[2] + polar[i, 1]
            z = pose[:2] + polar[i, 0] * np.array([math.cos(a), math.sin(a)])
            d = np.linalg.norm(state.positions - z, axis=1)
            j = int(np.argmin(d))
            if d[j] < self.gate:
                h, Hs, idx = ekf.landmark_measurement(state.x, j)
                state.set(*ekf.update(state.x, state.P, ekf.innovation(polar[i], h), Hs, idx, R))
                out[c] = j
        return out, np.empty(0)

    def min_log_distance(self, state, s, R):
        return math.inf  # every cluster is new to the toy


class MomentState:
    def __init__(self):
        self.points: list[np.ndarray] = []


class MomentEstimator:
    """Toy extent: X = 4 cov of every detection associated so far (>= 3), no baseline."""

    posterior_centroid = True

    def new(self):
        return MomentState()

    def step(self, st, polar, pts, centroid, centroid_cov, pose, pose_cov, dt, k):
        if pts.shape[0]:
            st.points.append(pts)

    def merge(self, survivor, gone):
        survivor.points += gone.points
        return survivor

    def sift(self, states, points, polar, centroids, centroid_covs, pose, pose_cov):
        return None

    def spreads(self, states):
        return np.zeros((len(states), 2, 2)), np.zeros(len(states), dtype=bool)

    def initial_spread(self):
        return None

    def matrix(self, st):
        pts = np.concatenate(st.points) if st.points else np.empty((0, 2))
        return 4.0 * np.cov(pts.T) if pts.shape[0] >= 3 else None

    def baseline(self, st):
        return None


@pytest.fixture
def toys():
    made = {}

    def make_assoc(config):
        made["associator"] = EuclideanAssociator(gate=config.landmarks.sift_radius_m)
        return made["associator"]

    ASSOCIATORS.register("toy-euclidean", make_assoc)
    EXTENT_ESTIMATORS.register("toy-moments", lambda config: MomentEstimator())
    yield made
    ASSOCIATORS.unregister("toy-euclidean")
    EXTENT_ESTIMATORS.unregister("toy-moments")


def test_toy_components_selected_by_name_from_toml_run_a_trial(toys, tmp_path):
    f = tmp_path / "toy.toml"
    f.write_text('[landmarks]\nassociator = "toy-euclidean"\n\n[extent]\nestimator = "toy-moments"\n')
    cfg = load_config(f)
    cfg = from_dict({**to_dict(cfg), "trajectory": {**to_dict(cfg)["trajectory"], "n_steps": 40}})
    res = run_trial(cfg, 3)
    assert toys["associator"].calls > 0
    assert res.record.n_associated.sum() > 100          # the toy associated detections
    assert np.isfinite(res.metrics["position_avg_rmse_m"]) and res.metrics["position_avg_rmse_m"] < 5.0
    final = res.record.maps[-1]
    assert final.ids.size >= 3
    # the snapshots carry the toy's matrices (4 cov of the associated points), no baseline
    has = ~np.isnan(final.rma[:, 0, 0])
    assert has.any() and np.isnan(final.efa).all()
    lam = np.linalg.eigvalsh(final.rma[has])
    assert np.all(lam > 0) and np.all(lam < 40.0)  # car-sized: a 5 m x 2 m car has 4 cov eigenvalues ~8, 1.3


def test_unknown_component_names_are_refused_with_the_key(toys):
    base = to_dict(from_dict({}))
    for section, key, value in [("landmarks", "associator", "nope"), ("extent", "estimator", "nope"),
                                ("filter", "motion_model", "nope"), ("filter", "measurement_model", "nope")]:
        with pytest.raises(ConfigError, match=rf"{section}\.{key}: expected one of .*got 'nope'"):
            from_dict({**base, section: {**base[section], key: value}})


def test_a_component_without_a_compiled_implementation_runs_its_reference_one(toys):
    """filter.backend = "numba" (the default) picks the compiled implementation where one is
    registered and the component's own (Python) one otherwise; a name registered only for
    another backend is refused."""
    base = to_dict(from_dict({}))
    cfg = from_dict({**base, "landmarks": {**base["landmarks"], "associator": "toy-euclidean"},
                     "filter": {**base["filter"], "backend": "numba"}})
    assert cfg.filter.backend == "numba"
    slam = EkfSlam(cfg)
    assert isinstance(slam.associator, EuclideanAssociator)
    builtin = EkfSlam(from_dict({**base, "filter": {**base["filter"], "backend": "numba"}}))
    assert builtin.associator.backend == "numba"
    ASSOCIATORS.register("toy-compiled-only", lambda c: None, backend="numba")
    try:
        with pytest.raises(ConfigError, match=r"landmarks\.associator: .*'toy-compiled-only' has no 'python'"):
            ASSOCIATORS.factory("toy-compiled-only", "python")
    finally:
        ASSOCIATORS.unregister("toy-compiled-only", backend="numba")


def test_a_newly_registered_motion_model_is_selectable_from_toml(tmp_path):
    class Slow(UnicycleModel):
        name = "half-speed"

        def step(self, pose, u, dt):
            return super().step(pose, np.array([0.5 * u[0], u[1]]), dt)

    MOTION_MODELS.register("half-speed", lambda f: Slow())
    try:
        f = tmp_path / "m.toml"
        f.write_text('[filter]\nmotion_model = "half-speed"\n')
        slam = EkfSlam(load_config(f))
        assert isinstance(slam.model, Slow)
        from radarslam.core.types import Odometry

        slam.predict(Odometry(0.0, 1.0, np.array([2.0, 0.0])))
        # initial pose (0.1, 0.1, 1 deg); half of 2 m/s for 1 s along the heading
        assert slam.pose[0] == pytest.approx(0.1 + math.cos(math.radians(1.0)), rel=1e-12)
    finally:
        MOTION_MODELS.unregister("half-speed")


def test_registry_refuses_a_second_factory_under_a_taken_name():
    reg = Registry("thing", "section.thing")
    reg.register("a", lambda: 1)
    with pytest.raises(ConfigError, match="already registered"):
        reg.register("a", lambda: 2)
    reg.register("a", lambda: 3, replace=True)
    assert reg.create("a") == 3 and reg.names() == ["a"] and reg.backends("a") == ["python"]
    with pytest.raises(ConfigError, match=r"section\.thing: expected one of \['a'\], got 'b'"):
        reg.create("b")


# ------------------------------------------------------------- the associators' kernels
def _random_state(rng, n_lm: int) -> SlamState:
    pose = np.array([rng.uniform(-5, 5), rng.uniform(-5, 5), rng.uniform(0, 2 * math.pi)])
    L = pose[:2] + rng.uniform(-15, 15, (n_lm, 2))
    n = 3 + 2 * n_lm
    A = rng.normal(size=(n, n)) * 0.05
    P = A @ A.T + np.diag(np.r_[[0.05, 0.05, 1e-3], np.full(2 * n_lm, 0.2)])
    return SlamState.from_mean(np.r_[pose, L.ravel()], P)


def _scan_near(rng, st: SlamState, m: int) -> np.ndarray:
    """Detections about the landmarks (and a few far away), as range-azimuth from the pose."""
    L = st.positions
    pts = L[rng.integers(L.shape[0], size=m)] + rng.normal(0, 0.8, (m, 2))
    pts[: m // 5] += rng.uniform(-10, 10, (m // 5, 2))
    d = pts - st.x[:2]
    return np.column_stack([np.hypot(d[:, 0], d[:, 1]),
                            np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - st.x[2])))])


@pytest.mark.parametrize("kind", ["nearest-neighbour", "batch", "batch-joint"])
@pytest.mark.parametrize("seed", range(12))
def test_associator_kernels_match_the_numpy_oracle_on_random_states(seed, kind):
    """Each scheme's one kernel (slam/_numba.py), compiled and run in the interpreter (the reference
    backend), against the scheme written in numpy over slam/ekf.py (tests/associator_oracles.py): the
    same landmarks, states to 1e-12, NIS to 1e-9, the alpha test to 1e-12."""
    require("numba")
    import associator_oracles as oracle
    from radarslam.slam.association import JointBatchAssociator

    rng = np.random.default_rng(seed)
    n_lm = int(rng.integers(1, 25))
    st0 = _random_state(rng, n_lm)
    polar = _scan_near(rng, st0, int(rng.integers(1, 40)))
    cand = np.flatnonzero(rng.random(polar.shape[0]) < 0.8)
    R = np.diag([rng.uniform(0.05, 0.5) ** 2, math.radians(rng.uniform(0.5, 2)) ** 2])
    X = rng.normal(size=(n_lm, 2, 2))
    spreads = Spreads(0.25 * (X @ X.transpose(0, 2, 1)), rng.random(n_lm) < 0.5)
    beta = float(rng.choice([3.0, 20.0]))
    cls, reference = {"nearest-neighbour": (NearestNeighbourAssociator, oracle.sequential),
                      "batch": (BatchAssociator, oracle.batch),
                      "batch-joint": (JointBatchAssociator, oracle.joint_batch)}[kind]
    st_or = SlamState.from_mean(st0.x.copy(), st0.P.copy())
    out_or, nis_or = reference(st_or, polar, cand, R, spreads, beta, 3)
    assert (out_or >= 0).sum() >= 1  # the case exercised updates
    n_updates = {"nearest-neighbour": (out_or >= 0).sum(), "batch": np.unique(out_or[out_or >= 0]).size}.get(kind)
    for backend in ("numba", "python"):
        assoc = cls(beta, 3, 5, backend=backend)
        st = SlamState.from_mean(st0.x.copy(), st0.P.copy())
        out, nis = assoc.associate(st, polar, cand, R, spreads)
        assert np.array_equal(out, out_or), backend
        if n_updates is not None:
            assert nis.shape == (n_updates,) and np.all(nis >= 0)
        np.testing.assert_allclose(nis, nis_or, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(st.x, st_or.x, rtol=0, atol=1e-12)
        np.testing.assert_allclose(st.P, st_or.P, rtol=0, atol=1e-12)
        for s in polar[:5]:
            assert assoc.min_log_distance(st0, s, R) == pytest.approx(
                oracle.best_match(st0, s, 5, R)[1], rel=1e-12)


def test_compiled_associator_without_landmarks_associates_nothing():
    require("numba")
    from radarslam.slam.association import CompiledNearestNeighbourAssociator

    st = SlamState(np.zeros(3), np.eye(3))
    out, nis = CompiledNearestNeighbourAssociator(20.0, 3, 5).associate(st, np.array([[5.0, 0.1]]), np.array([0]),
                                                                          np.eye(2), Spreads.none(0))
    assert out.tolist() == [-1] and nis.size == 0
    assert CompiledNearestNeighbourAssociator(20.0, 3, 5).min_log_distance(st, np.array([5.0, 0.1]), np.eye(2)) \
        == math.inf


def test_cli_loads_a_plugin_module_named_in_the_environment(tmp_path):
    """RADARSLAM_PLUGINS imports a module that registers an associator; the CLI then selects it."""
    import os
    import subprocess
    import sys

    (tmp_path / "toy_plugin.py").write_text(
        "from radarslam.core.registry import ASSOCIATORS\n"
        "from radarslam.slam.association import NearestNeighbourAssociator\n"
        "ASSOCIATORS.register('strict-nn', lambda c: NearestNeighbourAssociator(1.0, 1, 5))\n")
    (tmp_path / "c.toml").write_text('[landmarks]\nassociator = "strict-nn"\n[trajectory]\nn_steps = 20\n')
    env = {**os.environ, "RADARSLAM_PLUGINS": "toy_plugin",
           "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    cmd = [sys.executable, "-m", "radarslam", "run", "--config", str(tmp_path / "c.toml"), "--no-plot",
           "--out", str(tmp_path / "o")]
    done = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert 'associator = "strict-nn"' in (tmp_path / "o" / "config.toml").read_text()
    # negative control: without the plug-in the name is unknown, one line, exit 1
    env.pop("RADARSLAM_PLUGINS")
    done = subprocess.run(cmd[:-1] + [str(tmp_path / "o2")], env=env, capture_output=True, text=True)
    assert done.returncode == 1 and "landmarks.associator: expected one of" in done.stderr
    assert done.stderr.count("\n") == 1
