"""The rig fit's compiled sums (models/_doppler_compiled.py rig_residual, rig_normal, segment_sum) against the
numpy and scipy.sparse forms they replaced, to the bit; moving.csv's and ego_velocity.csv's writers against
their line-by-line forms; the map figure's extent contours against viz.carpark's."""

from __future__ import annotations

import math

import numpy as np
import pytest


def _windows(rng, n=3000, K=40):
    lo = np.sort(rng.integers(0, n - 200, K)).astype(np.int64)
    hi = lo + rng.integers(0, 200, K)
    hi[3] = lo[3]                                      # an empty window
    return lo, hi


@pytest.mark.parametrize("p", [2, 3])
def test_compiled_sums_equal_the_numpy_forms_to_the_bit(p):
    sparse = pytest.importorskip("scipy.sparse")
    from radarslam.models._rig_consensus import Pairs

    rng = np.random.default_rng(p)
    n = 3000
    A, d = rng.normal(size=(n, p)), rng.normal(size=n) * 3
    lo, hi = _windows(rng, n)
    pairs = Pairs(A, d, lo, hi)
    m = hi - lo
    start = np.concatenate([[0], np.cumsum(m)[:-1]])
    P = int(m.sum())
    row = np.arange(P) - np.repeat(start, m) + np.repeat(lo, m)
    Ap, dp = A[row], d[row]
    theta = rng.normal(size=(lo.size, p))
    # the residual: numpy's row product
    ref_r = dp - np.einsum("ij,ij->i", Ap, np.repeat(theta, m, axis=0))
    assert pairs.residual(theta).tobytes() == ref_r.tobytes()
    # the weighted sums: scipy's CSR product over the pairs' a a^T (upper half) and a d
    iu = np.triu_indices(p)
    X = np.concatenate([Ap[:, iu[0]] * Ap[:, iu[1]], Ap * dp[:, None]], axis=1)
    w = np.where(rng.random(P) < 0.2, 0.0, rng.random(P))
    seg = sparse.csr_matrix((w, np.arange(P), np.append(start, P)), shape=(lo.size, P))
    S = seg @ X
    N, g = pairs.normal(w)
    assert N[:, iu[0], iu[1]].tobytes() == S[:, :iu[0].size].tobytes()
    assert g.tobytes() == S[:, iu[0].size:].tobytes()
    seg.data = (w > 0.5).astype(float)
    assert pairs.wsum(w > 0.5).tobytes() == (seg @ np.ones(P)).tobytes()
    # Tukey's weights within the pass: the same as the weights computed first
    cs = rng.uniform(0.5, 6.0, lo.size)
    u = ref_r / cs[pairs.win]
    wt = np.where(np.abs(u) < 1.0, (1.0 - u * u) ** 2, 0.0)
    Nt, gt = pairs.normal(None, theta, cs)
    N2, g2 = pairs.normal(wt)
    assert Nt.tobytes() == N2.tobytes() and gt.tobytes() == g2.tobytes()


def test_moving_csv_equals_the_line_by_line_form(tmp_path):
    from radarslam.runs.detection_flags import DetectionFlags, write_moving_csv

    rng = np.random.default_rng(0)
    n = 5000
    t = np.repeat(np.sort(rng.random(n // 10)) * 100, 10)
    t[:3] = [-0.0, 0.0, 1e-10]
    sid = rng.integers(0, 4, n)
    flags = DetectionFlags(rng.random(n) < 0.2, np.where(rng.random(n) < 0.5, rng.integers(-1, 300, n), -1),
                           rng.random(n) < 0.9)
    write_moving_csv(tmp_path / "moving.csv", t, sid, flags)
    lines = ["t_s,sensor_id,moving,landmark,used"] + [
        f"{a:.9f},{b},{c},{d},{e}" for a, b, c, d, e in zip(t.tolist(), sid.tolist(), flags.moving.astype(int).tolist(),
                                                             flags.landmark.tolist(), flags.used.astype(int).tolist())]
    assert (tmp_path / "moving.csv").read_text() == "\n".join(lines) + "\n"
    e = np.zeros(0)
    write_moving_csv(tmp_path / "empty.csv", e, e.astype(int),
                     DetectionFlags(e.astype(bool), e.astype(np.int64), e.astype(bool)))
    assert (tmp_path / "empty.csv").read_text() == "t_s,sensor_id,moving,landmark,used\n"


def test_ego_velocity_csv_equals_the_row_by_row_form(tmp_path):
    from radarslam.egomotion.rig import RigVelocitySeries, write_ego_velocity_csv
    from radarslam.models.rig_velocity import STATUS_WORDS

    rng = np.random.default_rng(1)
    K = 60
    th, cov = rng.normal(size=(K, 3)), rng.normal(size=(K, 3, 3))
    th[::7], cov[::7] = np.nan, np.nan
    s = RigVelocitySeries(np.sort(rng.random(K)) * 10, th, cov, rng.integers(0, 6, K),
                          np.where(rng.random(K) < 0.1, np.nan, rng.random(K)), rng.integers(0, 900, K),
                          rng.integers(0, 900, K))
    write_ego_velocity_csv(tmp_path / "ego.csv", s)
    iu = np.triu_indices(3)
    fmt = lambda v: "" if not np.isfinite(v) else repr(float(v))
    rows = [",".join([repr(float(s.t[k]))] + [fmt(v) for v in [*th[k], *cov[k][iu], s.sigma_mps[k]]]
                     + [str(int(s.n_inliers[k])), str(int(s.n_used[k])), STATUS_WORDS[int(s.status[k])]]) for k in range(K)]
    got = (tmp_path / "ego.csv").read_text().splitlines()
    assert got[1:] == rows


def test_extent_contours_are_carparks_ellipses():
    from radarslam.viz.carpark import _ellipse_xy
    from radarslam.viz.recording import _extent_contours

    rng = np.random.default_rng(2)
    c, B = rng.normal(size=(9, 2)), rng.normal(size=(9, 2, 2))
    X = B @ np.swapaxes(B, 1, 2)
    X[4] = np.nan
    xy = _extent_contours(c, X, 24)
    ref = np.concatenate([np.vstack([_ellipse_xy(ci, Xi, 24), [[math.nan, math.nan]]])
                          for ci, Xi in zip(c, X) if np.all(np.isfinite(Xi))])
    np.testing.assert_allclose(xy, ref, rtol=0, atol=1e-12)
    assert _extent_contours(c[:1], X[4:5], 24).shape == (0, 2)
