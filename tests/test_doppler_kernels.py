"""The Doppler kernels (models/doppler_kernels.py, docs/method.md c.10.2-c.10.4) run
as Python and compiled give the same inliers, the same moving detections and the same values (to
1e-12), drawing the same numbers from the same generator; the stream loop equals the per-scan
calls; negative controls: a 1e-6 m/s change of one Doppler moves the fit by more than the
tolerance, and another seed leaves the generator elsewhere."""

from __future__ import annotations

import math

import numpy as np

from radarslam.models import _doppler_compiled as C
from radarslam.models import doppler_kernels as K

ARGS = (50, 0.3, 0.05, 0.3)                         # iterations, threshold, sigma floor, min fraction
Q = (5.991, 6.635, 1.0, 10.83, 13.82)               # q_zero, q_gate, radius, q_one, q_two


def _scan(rng, n=60, moving=8):
    """A scan of ``n`` detections: a static world seen from a sensor moving at (3, 0.4) m/s, and a
    car of ``moving`` detections at about 10 m moving at (0, 4) m/s, Doppler noise 0.1 m/s."""
    moving = min(moving, n)
    polar = np.column_stack([rng.uniform(2, 40, n), rng.uniform(-1.2, 1.2, n)])
    polar[:moving] = np.column_stack([10 + rng.uniform(0, 1.5, moving), 0.3 + rng.uniform(0, 0.1, moving)])
    U = np.column_stack([np.cos(polar[:, 1]), np.sin(polar[:, 1])])
    d = -U @ np.array([3.0, 0.4]) + 0.1 * rng.standard_normal(n)
    d[:moving] += U[:moving] @ np.array([0.0, 4.0])
    return polar, d


def _same(a, b):
    """The classify_scan outputs ``a`` and ``b`` agree: booleans exactly, values to 1e-12 (relative beyond 1: the rest statistic is ~1e4)."""
    for x, y in zip(a, b):
        x, y = np.asarray(x), np.asarray(y)
        if x.dtype == bool:
            if not np.array_equal(x, y):
                return False
        elif not np.allclose(x, y, rtol=1e-12, atol=1e-12, equal_nan=True):
            return False
    return True


def test_classify_scan_python_and_compiled_agree_with_the_same_draws():
    data = np.random.default_rng(7)
    for mount in ((0.0, 0.0, 0.0), (1.2, -0.3, 0.4)):
        r1, r2 = np.random.default_rng(11), np.random.default_rng(11)
        n_moving = 0
        for _ in range(30):
            polar, d = _scan(data)
            a = K.classify_scan(polar, d, *mount, r1, *ARGS, *Q)
            b = C.classify_scan(polar, d, *mount, r2, *ARGS, *Q)
            assert a[6] and _same(a, b)
            assert r1.bit_generator.state == r2.bit_generator.state
            n_moving += int(a[8][:8].all())
        assert n_moving >= 20                     # the car's object is found: the test exercises the groups


def test_negative_controls_a_changed_doppler_and_another_seed():
    polar, d = _scan(np.random.default_rng(8))
    a = C.classify_scan(polar, d, 0.0, 0.0, 0.0, np.random.default_rng(1), *ARGS, *Q)
    d2 = d.copy()
    d2[20] += 1e-6
    b = C.classify_scan(polar, d2, 0.0, 0.0, 0.0, np.random.default_rng(1), *ARGS, *Q)
    assert b[2][20] and not _same(a, b) and np.abs(a[0] - b[0]).max() > 1e-12
    r1, r2 = np.random.default_rng(1), np.random.default_rng(2)
    C.classify_scan(polar, d, 0.0, 0.0, 0.0, r1, *ARGS, *Q)
    K.classify_scan(polar, d, 0.0, 0.0, 0.0, r2, *ARGS, *Q)
    assert r1.bit_generator.state != r2.bit_generator.state


def test_object_statistic_equals_the_normal_equations():
    """object_stat against numpy's formulas of c.10.4.2, both branches, both forms."""
    rng = np.random.default_rng(9)
    cov = np.array([[4e-4, 1e-4], [1e-4, 3e-4]])
    U = np.column_stack([np.cos(a := rng.uniform(0, 1, 5)), np.sin(a)])
    r = 0.1 * rng.standard_normal(5)
    N = U.T @ U
    w = np.linalg.solve(N, U.T @ r)
    T = w @ np.linalg.solve(0.01 * np.linalg.inv(N) + cov, w)
    for f in (K.object_stat, C.object_stat):
        t, dof = f(U, r, 0.01, cov)
        assert dof == 2 and math.isclose(t, T, rel_tol=1e-12)
        P = np.tile(U[:1], (3, 1))
        t1, dof1 = f(P, r[:3], 0.01, cov)
        assert dof1 == 1 and math.isclose(t1, r[:3].mean() ** 2 / (0.01 / 3 + U[0] @ cov @ U[0]), rel_tol=1e-12)


def test_classify_stream_equals_the_per_scan_calls():
    data = np.random.default_rng(10)
    scans = [_scan(data, n=n) for n in (60, 1, 0, 45, 30)]
    off = np.concatenate([[0], np.cumsum([p.shape[0] for p, _ in scans])]).astype(np.int64)
    polar = np.concatenate([p for p, _ in scans])
    dop = np.concatenate([d for _, d in scans])
    r1, r2 = np.random.default_rng(3), np.random.default_rng(3)
    v, cov, inl, sigma, stat, rest, valid, bad, objects, tested = C.classify_stream(
        polar, off, dop, np.array([0.5, 0.1, 0.2]), r1, *ARGS, np.array([Q[0], Q[1], Q[3], Q[4]]), Q[2])
    for s, (p, d) in enumerate(scans):
        out = C.classify_scan(p, d, 0.5, 0.1, 0.2, r2, *ARGS, *Q)
        rows = slice(off[s], off[s + 1])
        assert _same((v[s], cov[s], inl[rows], sigma[s], stat[s], rest[s], valid[s], bad[rows], objects[rows],
                      tested[s]), out)
    assert valid.tolist() == [True, False, False, True, True]
    assert r1.bit_generator.state == r2.bit_generator.state


def test_fit_stream_equals_the_per_scan_fits():
    data = np.random.default_rng(12)
    scans = [_scan(data, n=n) for n in (50, 3, 0, 40)]
    off = np.concatenate([[0], np.cumsum([p.shape[0] for p, _ in scans])]).astype(np.int64)
    r1, r2 = np.random.default_rng(4), np.random.default_rng(4)
    out = C.fit_stream(np.concatenate([p for p, _ in scans]), off, np.concatenate([d for _, d in scans]),
                       np.array([0.5, 0.1, 0.2]), r1, *ARGS, Q[0])
    for s, (p, d) in enumerate(scans):
        one = K.ego_fit(K.mounted_dirs(p, 0.5, 0.1, 0.2), d, r2, *ARGS, Q[0])
        rows = slice(off[s], off[s + 1])
        assert _same((out[0][s], out[1][s], out[2][rows], *(o[s] for o in out[3:])), one)
    assert out[6].tolist() == [True, False, False, True]
    assert r1.bit_generator.state == r2.bit_generator.state


def test_the_python_backends_gate_compiles_nothing():
    """filter.backend "python" (a first run's reference) runs the Doppler gate's reference: in a fresh
    process nothing of the gate is compiled (it compiled the ego fit, 28 s of a cold nuScenes run,
    before; a load from the session's cache would show as well), and its verdict equals the numba
    backend's (the same draws)."""
    import subprocess
    import sys

    code = (
        "import dataclasses, numpy as np\n"
        "from radarslam.config import profile_config\n"
        "from radarslam.core.types import Scan\n"
        "from radarslam.models import _doppler_compiled as C\n"
        "from radarslam.slam.doppler_gate import DopplerGate\n"
        "cfg = profile_config('automotive').filter\n"
        "rng = np.random.default_rng(3)\n"
        "az = rng.uniform(-1, 1, 40); polar = np.column_stack([rng.uniform(5, 50, 40), az])\n"
        "d = -(np.cos(az) * 8.0) + 0.05 * rng.standard_normal(40); d[:5] += 6.0\n"
        "scan = Scan(0.0, 1, polar, {'doppler_mps': d})\n"
        "out = []\n"
        "for backend in ('python', 'numba'):\n"
        "    g = DopplerGate(dataclasses.replace(cfg, backend=backend))\n"
        "    keep, bad, ego = g.classify(scan, polar)[:3]\n"
        "    out.append((keep.tolist(), bad.tolist(), ego.v.round(9).tolist()))\n"
        "    if backend == 'python': print('signatures', len(C.classify_scan.signatures))\n"
        "print('equal', out[0] == out[1])\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-800:]
    assert "signatures 0" in r.stdout and "equal True" in r.stdout, r.stdout
