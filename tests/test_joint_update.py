"""The stacked per-scan update (docs/method.md a.7.4; landmarks.associator = "batch-joint")."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from conftest import require
from radarslam.config import profile_config
from radarslam.montecarlo.trials import trial_seed
from radarslam.simulation.scenario import generate_scenario
from radarslam.slam import ekf
from radarslam.slam.filter import EkfSlam


def _problem(rng, N=12, L=5):
    """A random SPD covariance, a state, and L landmarks' sparse 2 x 5 Jacobians with noises."""
    n = 3 + 2 * N
    A = rng.normal(size=(n, n))
    P = A @ A.T / n + 0.1 * np.eye(n)
    x = rng.normal(size=n)
    x[2] = 1.0
    js = rng.choice(N, L, replace=False)
    Hs = rng.normal(size=(L, 2, 5))
    idx = np.array([[0, 1, 2, 3 + 2 * j, 4 + 2 * j] for j in js])
    C = rng.normal(size=(L, 2, 2))
    Rb = np.einsum("aij,akj->aik", C, C) + 0.05 * np.eye(2)
    H = np.zeros((2 * L, n))
    for a in range(L):
        H[2 * a:2 * a + 2, idx[a]] = Hs[a]
    return x, P, Hs, idx, Rb, H


def test_joint_equals_sequential_updates_for_a_linear_model():
    """With the Jacobians held fixed (a linear model), one stacked update equals L sequential
    Joseph updates, each with the innovation recomputed at the current state."""
    rng = np.random.default_rng(4)
    for _ in range(20):
        x, P, Hs, idx, Rb, H = _problem(rng)
        z = H @ x + rng.normal(size=H.shape[0])
        xj, Pj = x.copy(), P.copy()
        nis = ekf.joint_update_inplace(xj, Pj, z - H @ x, H, _blockdiag(Rb))
        xs, Ps = x.copy(), P.copy()
        seq = []
        for a in range(len(Rb)):
            e = z[2 * a:2 * a + 2] - H[2 * a:2 * a + 2] @ xs
            seq.append(ekf.joseph_update_inplace(xs, Ps, e, Hs[a], idx[a], Rb[a]))
        np.testing.assert_allclose(xj, xs, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(Pj, Ps, rtol=1e-10, atol=1e-10)
        # the pairwise whitened terms are the sequential updates' NIS (chain rule of the Gaussian)
        np.testing.assert_allclose(nis, seq, rtol=1e-9)
        assert np.array_equal(Pj, Pj.T)


def _blockdiag(Rb):
    q = 2 * len(Rb)
    R = np.zeros((q, q))
    for a, B in enumerate(Rb):
        R[2 * a:2 * a + 2, 2 * a:2 * a + 2] = B
    return R


def test_joint_differs_from_sequential_when_relinearised():
    """Negative control: the nonlinear batch update relinearises after every landmark, so the
    stacked update is a different (close) estimator on a real scan."""
    cfg = profile_config("apsipa")
    events = generate_scenario(cfg, np.random.default_rng(trial_seed(1, 1))).events
    poses = {}
    for name in ("batch", "batch-joint"):
        c = replace(cfg, landmarks=replace(cfg.landmarks, associator=name),
                    filter=replace(cfg.filter, backend="python"))
        slam = EkfSlam(c)
        for ev in events[:61]:
            slam.process(ev)
        poses[name] = slam.pose
    d = np.abs(poses["batch"] - poses["batch-joint"]).max()
    assert 0 < d < 0.5


def test_compiled_joint_update_equals_reference():
    require("numba")
    from radarslam.slam._numba import joint_update_loops

    rng = np.random.default_rng(9)
    for N, L in ((3, 1), (12, 5), (60, 30)):
        x, P, Hs, idx, Rb, H = _problem(rng, N, L)
        e = rng.normal(size=2 * L)
        xr, Pr = x.copy(), P.copy()
        nis_r = ekf.joint_update_inplace(xr, Pr, e, H, _blockdiag(Rb))
        xc, Pc = x.copy(), P.copy()
        nis_c = joint_update_loops(xc, Pc, e, Hs, idx, Rb)
        np.testing.assert_allclose(xc, xr, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(Pc, Pr, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(nis_c, nis_r, rtol=1e-10)
        assert np.array_equal(Pc, Pc.T)                     # exactly symmetric
        S = H @ P @ H.T + _blockdiag(Rb)
        assert np.isclose(nis_c.sum(), e @ np.linalg.solve(S, e), rtol=1e-10)


@pytest.mark.parametrize("trial", [1, 2])
def test_backends_agree_on_whole_runs(trial):
    """Python reference and the compiled engine: the same associations, states to 1e-9."""
    require("numba")
    cfg = profile_config("apsipa")
    events = generate_scenario(cfg, np.random.default_rng(trial_seed(1, trial))).events
    runs = {}
    for backend in ("python", "numba"):
        c = replace(cfg, landmarks=replace(cfg.landmarks, associator="batch-joint"),
                    extent=replace(cfg.extent, use_in_slam=True, pre_init_spread="prior"),
                    filter=replace(cfg.filter, backend=backend, fused=False))
        slam = EkfSlam(c)
        assoc = []
        for ev in events:
            rep = slam.process(ev)
            if rep is not None:
                assoc.append({k: v.tolist() for k, v in rep.associations.items()})
        runs[backend] = (assoc, slam.x.copy(), slam.P.copy())
    assert runs["python"][0] == runs["numba"][0]
    np.testing.assert_allclose(runs["python"][1], runs["numba"][1], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(runs["python"][2], runs["numba"][2], rtol=1e-9, atol=1e-9)
