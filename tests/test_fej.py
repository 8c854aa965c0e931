"""First-estimates Jacobians (docs/method.md c.2.1; Huang, Mourikis & Roumeliotis 2008/2010): the
observability of the linearised system, and the option in the filter."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from radarslam.config import from_dict, profile_config
from radarslam.core.errors import ConfigError
from radarslam.models.ackermann import AckermannModel
from radarslam.models.body_velocity import BodyVelocityModel
from radarslam.models.motion import UnicycleModel
from radarslam.slam import EkfSlam, _fused, ekf
from radarslam.landmarks.records import add_record
from radarslam.slam.state import SlamState

N_STATE = 7          # pose and two landmarks
SVD_TOL = 1e-8       # relative to the largest singular value


#: Every motion model with first-estimates Jacobians and a control that turns (c.2.1).
MODELS = {"unicycle": (UnicycleModel(), np.array([3.0, 0.3])),
          "ackermann": (AckermannModel(), np.array([3.0, 0.1])),
          "body-velocity": (BodyVelocityModel(), np.array([3.0, 0.4, 0.3]))}


def _trajectory(rng: np.random.Generator, steps: int = 5, model_name: str = "unicycle"):
    """Estimates of a short run: predicted poses x_{k|k-1}, updated poses x_{k|k} (the prediction
    plus an update's correction of a few cm / mrad), the landmarks' estimate at each step and their
    first estimates; the model's controls and dt."""
    (model, u), dt = MODELS[model_name], 0.5
    first = np.array([[8.0, 3.0], [4.0, -6.0]])
    pred, upd, lms = [np.array([0.2, -0.1, 0.4])], [], []
    for k in range(steps):
        upd.append(pred[k] + rng.normal(0.0, [0.05, 0.05, 0.01]))
        lms.append(first + (rng.normal(0.0, 0.1, first.shape) if k else 0.0))
        pred.append(model.step(upd[k], u, dt))
    return model, u, dt, pred, upd, lms, first


def _state(pose, lms, first) -> SlamState:
    st = SlamState(np.concatenate([pose, lms.ravel()]), np.eye(N_STATE))
    for j in range(len(first)):
        st.records = add_record(st.records, j, j, 1, first[j, 0], first[j, 1])
        st.extents.append(None)
    return st


def _observability(fej: bool, measurement, steps: int = 5, seed: int = 3, model_name: str = "unicycle") -> np.ndarray:
    """Singular values of M = [H_1; H_2 F_1; H_3 F_2 F_1; ...] (both landmarks each step)."""
    model, u, dt, pred, upd, lms, first = _trajectory(np.random.default_rng(seed), steps, model_name)
    rows, Phi = [], np.eye(N_STATE)
    for k in range(steps):
        st = _state(pred[k], lms[k], first)      # the update of step k is linearised at the prediction
        if fej:
            st.lin_pose = pred[k].copy()
        for j in range(2):
            Hs, idx = measurement(st.linearisation(j), j)
            H = np.zeros((2, N_STATE))
            H[:, idx] = Hs
            rows.append(H @ Phi)
        Fx = model.jacobians(upd[k], u, dt)[0]
        if fej:
            Fx = ekf.fej_motion_jacobian(Fx, pred[k + 1], pred[k])
        F = np.eye(N_STATE)
        F[:3, :3] = Fx
        Phi = F @ Phi
    return np.linalg.svd(np.vstack(rows), compute_uv=False)


def _null_dim(s: np.ndarray) -> int:
    return int(np.sum(s < SVD_TOL * s[0])) + (N_STATE - s.size)


def _range_azimuth(x, j):
    return ekf.sparse_jacobian(x, j)


def _sensor_xy(x, j):
    return ekf.sensor_xy_measurement(x, j)[1:]


@pytest.mark.parametrize("measurement", [_range_azimuth, _sensor_xy], ids=["range-azimuth", "sensor-xy"])
def test_fej_keeps_the_three_unobservable_directions(measurement):
    """FEJ: the observability matrix of 5 steps has a 3-dimensional nullspace (global translation
    and rotation, the true system's); the third-smallest singular value is below 1e-8 of the largest.
    Standard Jacobians (negative control): 2, the rotation is wrongly observable, its singular value
    above 1e-3 of the largest."""
    s_fej = _observability(True, measurement)
    s_std = _observability(False, measurement)
    assert _null_dim(s_fej) == 3, s_fej
    assert _null_dim(s_std) == 2, s_std
    assert s_std[-3] > 1e-3 * s_std[0]


@pytest.mark.parametrize("model_name", sorted(MODELS))
def test_every_motion_model_moves_by_a_position_free_increment(model_name):
    """What FEJ assumes of a model (c.2.1): F_x's heading column is (-dy, dx) of the step's own
    position increment, at any pose; and F_x matches central differences."""
    model, u = MODELS[model_name]
    rng = np.random.default_rng(5)
    for _ in range(20):
        pose = np.array([*rng.uniform(-50, 50, 2), rng.uniform(0, 2 * np.pi)])
        dt = rng.uniform(0.02, 0.5)
        Fx = model.jacobians(pose, u, dt)[0]
        d = model.step(pose, u, dt)[:2] - pose[:2]
        assert np.allclose(Fx[:2, 2], [-d[1], d[0]], atol=1e-12)
        assert np.allclose(Fx[:2, :2], np.eye(2)) and np.allclose(Fx[2], [0, 0, 1])
        for i in range(3):
            e = np.zeros(3)
            e[i] = 1e-6
            fd = (model.step(pose + e, u, dt) - model.step(pose - e, u, dt)) / 2e-6
            assert np.allclose(fd[:2], Fx[:2, i], atol=1e-7)


@pytest.mark.parametrize("model_name", ["ackermann", "body-velocity"])
def test_fej_keeps_the_three_unobservable_directions_for_every_model(model_name):
    """The nullspace test of the unicycle for the Ackermann and body-velocity models: FEJ 3, the
    standard Jacobians (negative control) 2."""
    s_fej = _observability(True, _range_azimuth, model_name=model_name)
    s_std = _observability(False, _range_azimuth, model_name=model_name)
    assert _null_dim(s_fej) == 3, s_fej
    assert _null_dim(s_std) == 2, s_std
    assert s_std[-3] > 1e-3 * s_std[0]


def test_fej_nullspace_is_translation_and_rotation():
    """The FEJ nullspace holds the global translations and the rotation about the origin evaluated
    at the first estimates, N = [I2 0; J t_1 1; I2 J p_first] (J = 90 deg rotation)."""
    model, u, dt, pred, upd, lms, first = _trajectory(np.random.default_rng(3))
    J = np.array([[0.0, -1.0], [1.0, 0.0]])
    N = np.zeros((N_STATE, 3))
    N[0:2, 0:2] = np.eye(2)
    N[0:2, 2] = J @ pred[0][:2]
    N[2, 2] = 1.0
    for j in range(2):
        N[3 + 2 * j:5 + 2 * j, 0:2] = np.eye(2)
        N[3 + 2 * j:5 + 2 * j, 2] = J @ first[j]
    rows, Phi = [], np.eye(N_STATE)
    for k in range(5):
        st = _state(pred[k], lms[k], first)
        st.lin_pose = pred[k].copy()
        for j in range(2):
            Hs, idx = ekf.sparse_jacobian(st.linearisation(j), j)
            H = np.zeros((2, N_STATE))
            H[:, idx] = Hs
            rows.append(H @ Phi)
        F = np.eye(N_STATE)
        F[:3, :3] = ekf.fej_motion_jacobian(model.jacobians(upd[k], u, dt)[0], pred[k + 1], pred[k])
        Phi = F @ Phi
    M = np.vstack(rows)
    assert np.max(np.abs(M @ N)) < 1e-10


def test_fej_equals_standard_without_updates():
    """Two predictions in a row: the first estimate is the estimate, and the Jacobians agree."""
    model, u, dt = UnicycleModel(), np.array([4.0, 0.32]), 0.16
    x0 = np.array([1.0, 2.0, 0.3])
    x1 = model.step(x0, u, dt)
    Fx = model.jacobians(x0, u, dt)[0]
    assert np.allclose(ekf.fej_motion_jacobian(Fx, x1, x0), Fx, atol=1e-14)


def _short(jacobians: str, **filt):
    cfg = profile_config("apsipa")
    return replace(cfg, trajectory=replace(cfg.trajectory, n_steps=40),
                   filter=replace(cfg.filter, jacobians=jacobians, **filt),
                   extent=replace(cfg.extent, use_in_slam=True, pre_init_spread="prior"),
                   landmarks=replace(cfg.landmarks, init="cluster", associator="batch"))


def test_fej_filter_runs_and_the_fused_engine_covers_it():
    """The consistent variant with FEJ runs 40 scans of a trial (finite, within 1 m of the standard
    run's pose, and not the standard run); the fused engine covers it (tests/test_fused.py checks
    that it makes the steps form's run)."""
    from radarslam.simulation.trial import run_trial

    fej = run_trial(_short("fej"), 777)
    std = run_trial(_short("standard"), 777)
    assert np.all(np.isfinite(fej.record.poses)) and np.all(np.isfinite(fej.record.pose_covs))
    assert not np.array_equal(fej.record.poses, std.record.poses)
    assert np.max(np.linalg.norm(fej.record.poses[:, :2] - std.record.poses[:, :2], axis=1)) < 1.0


@pytest.mark.parametrize("associator", ["nearest-neighbour", "batch", "batch-joint"])
def test_compiled_fej_associators_equal_the_python_ones(associator):
    """The compiled associators evaluate the Jacobians at the first estimates as the Python
    reference does (``SlamState.linearisation_all`` against ``linearisation(j)``): 60 scans of a
    trial, form by form, the same associations and poses to rounding; and not the
    standard Jacobians' run (negative control)."""
    from radarslam.simulation.trial import run_trial

    def run(backend, jacobians="fej"):
        cfg = _short(jacobians, backend=backend, fused=False)
        cfg = replace(cfg, trajectory=replace(cfg.trajectory, n_steps=60),
                      landmarks=replace(cfg.landmarks, associator=associator))
        return run_trial(cfg, 5).record

    py, nb, std = run("python"), run("numba"), run("numba", "standard")
    assert np.array_equal(py.n_associated, nb.n_associated) and np.array_equal(py.n_landmarks, nb.n_landmarks)
    assert py.n_associated.sum() > 300
    np.testing.assert_allclose(nb.poses, py.poses, rtol=0, atol=1e-9)
    np.testing.assert_allclose(nb.pose_covs, py.pose_covs, rtol=1e-9, atol=1e-12)
    assert np.abs(std.poses - py.poses).max() > 1e-6


def test_fej_is_refused_where_it_is_not_built():
    slam = EkfSlam(from_dict({"filter": {"jacobians": "fej", "motion_model": "ackermann"}}))   # built: no error
    assert slam.fej and slam.model.name == "ackermann"
    with pytest.raises(ConfigError, match=r"filter.jacobians: expected 'standard' with associator 'jcbb'"):
        EkfSlam(from_dict({"filter": {"jacobians": "fej"}, "landmarks": {"associator": "jcbb"}}))
    with pytest.raises(ConfigError, match=r"filter.jacobians: expected one of \['standard', 'fej'\], got 'first'"):
        from_dict({"filter": {"jacobians": "first"}})
