"""Converted-measurement covariance W, seed eqs. (3), (5)-(7), and the per-scan choice of W (h.3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from radarslam.core.errors import InputError
from radarslam.extent import (
    converted_measurement_cov,
    converted_measurement_covs,
    select_scan_W,
)
from radarslam.extent.measurement import (
    _VECTORISE_FROM,
    W_MODES,
    _converted_measurement_covs,
    _scan_W,
    _select_scan_W,
)
from oracles import central_jacobian

R_APS = np.diag([0.5**2, (math.pi / 180) ** 2])  # docs/method.md a.2


def f(pose: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Seed eq. (3), written out independently of the library."""
    x, y, th = pose
    r, phi = s
    return np.array([x + r * math.cos(th + phi), y + r * math.sin(th + phi)])


def random_cov(rng: np.random.Generator, n: int, scale: float) -> np.ndarray:
    A = rng.normal(size=(n, n)) * scale
    return A @ A.T + 1e-6 * np.eye(n)


# theta in [0, 2pi) as the state keeps it; theta + phi sweeping through +-pi from both sides
POSES_AND_DETECTIONS = [
    (np.array([0.1, 0.1, math.pi / 180]), np.array([12.0, 0.4])),
    (np.array([-8.0, 2.0, math.radians(267)]), np.array([19.5, -2.9])),
    (np.array([3.0, -4.0, math.pi - 1e-9]), np.array([7.0, 0.0])),            # theta + phi = pi - 1e-9
    (np.array([3.0, -4.0, math.pi - 0.01]), np.array([7.0, 0.02])),           # just past +pi
    (np.array([3.0, -4.0, 2 * math.pi - 1e-6]), np.array([15.0, -math.pi + 1e-7])),  # ~ +pi
    (np.array([3.0, -4.0, 0.0]), np.array([15.0, -math.pi])),                 # exactly -pi
    (np.array([3.0, -4.0, 0.0]), np.array([15.0, math.pi])),                  # exactly +pi
    (np.array([0.0, 0.0, 4.0]), np.array([0.0, 1.0])),                        # zero range
]


@pytest.mark.parametrize("pose, s", POSES_AND_DETECTIONS)
def test_w_matches_finite_difference_jacobians(pose, s):
    rng = np.random.default_rng(3)
    for _ in range(5):
        P = random_cov(rng, 3, 0.2)
        for R in (R_APS, random_cov(rng, 2, 0.1)):  # the diagonal R of the papers and a full one
            # step 1e-5: truncation ~ h^2 r ~ 2e-9, roundoff ~ eps r / h ~ 4e-10, against entries ~ r
            Fx = central_jacobian(lambda p: f(p, s), pose, 1e-5)
            Fs = central_jacobian(lambda q: f(pose, q), s, 1e-5)
            W_fd = Fx @ P @ Fx.T + Fs @ R @ Fs.T
            W = converted_measurement_cov(pose, P, s[0], s[1], R)
            assert np.linalg.norm(W - W_fd) <= 1e-7 * np.linalg.norm(W_fd)
            assert np.array_equal(W, W.T)


def test_w_equals_written_out_seed_jacobians():
    """The Jacobians of seed eqs. (6)-(7), typed in as matrices."""
    pose = np.array([1.0, 2.0, 0.3])
    r, phi = 11.0, -0.8
    c, s = math.cos(0.3 - 0.8), math.sin(0.3 - 0.8)
    Fx = np.array([[1, 0, -r * s], [0, 1, r * c]])   # seed eq. (6)
    Fs = np.array([[c, -r * s], [s, r * c]])         # seed eq. (7)
    P = np.diag([0.15**2, 0.15**2, (math.pi / 180) ** 2])
    W = converted_measurement_cov(pose, P, r, phi, R_APS)
    np.testing.assert_allclose(W, Fx @ P @ Fx.T + Fs @ R_APS @ Fs.T, rtol=1e-13, atol=1e-15)


def test_vectorised_equals_loop():
    rng = np.random.default_rng(4)
    for m in (1, 2, 6, _VECTORISE_FROM, _VECTORISE_FROM + 1, 40):  # both sides of the loop / array switch
        pose = np.array([rng.normal(), rng.normal(), rng.uniform(0, 2 * math.pi)])
        P = random_cov(rng, 3, 0.3)
        R = random_cov(rng, 2, 0.05)
        polar = np.column_stack([rng.uniform(0, 20, m), rng.uniform(-math.pi, math.pi, m)])
        Ws = converted_measurement_covs(pose, P, polar, R)
        assert Ws.shape == (m, 2, 2)
        for i in range(m):
            np.testing.assert_allclose(Ws[i], converted_measurement_cov(pose, P, polar[i, 0], polar[i, 1], R),
                                       rtol=1e-14, atol=1e-15)
        np.testing.assert_array_equal(_converted_measurement_covs(pose, P, polar, R), Ws)
        assert np.all(np.linalg.eigvalsh(Ws) > 0)


def test_no_detections_gives_empty_stack():
    assert converted_measurement_covs([0, 0, 0], np.eye(3), np.empty((0, 2)), R_APS).shape == (0, 2, 2)
    assert converted_measurement_covs([0, 0, 0], np.eye(3), [], R_APS).shape == (0, 2, 2)


def test_select_max_trace_vs_max_det_vs_mean():
    W_long = np.diag([10.0, 0.01])   # trace 10.01, det 0.1
    W_round = np.diag([3.0, 3.0])    # trace 6,     det 9
    W_small = np.array([[1.0, 0.2], [0.2, 0.5]])
    Ws = np.stack([W_small, W_round, W_long])
    np.testing.assert_array_equal(select_scan_W(Ws), W_long)            # default is max_trace
    np.testing.assert_array_equal(select_scan_W(Ws, "max_trace"), W_long)
    np.testing.assert_array_equal(select_scan_W(Ws, "max_det"), W_round)
    np.testing.assert_allclose(select_scan_W(Ws, "mean"), (W_small + W_round + W_long) / 3, rtol=1e-15)
    out = select_scan_W(Ws)
    out[0, 0] = -1.0
    assert Ws[2, 0, 0] == 10.0  # a copy, not a view


def test_max_trace_picks_farthest_detection_with_diagonal_noise():
    """With P^m = 0 and R diagonal, tr W(i) = R11 + r^2 R22 grows with range (docs/method.md h.3)."""
    polar = np.array([[5.0, 0.1], [17.0, -2.0], [9.0, 3.0]])
    Ws = converted_measurement_covs([1, 1, 1], np.zeros((3, 3)), polar, R_APS)
    np.testing.assert_array_equal(select_scan_W(Ws), Ws[1])


@pytest.mark.parametrize("mode", W_MODES)
def test_fused_scan_W_equals_select_of_covs(mode):
    rng = np.random.default_rng(5)
    for _ in range(50):
        m = int(rng.integers(1, 12))
        pose = np.array([rng.normal(), rng.normal(), rng.uniform(0, 2 * math.pi)])
        P = random_cov(rng, 3, 0.3)
        R = random_cov(rng, 2, 0.05)
        polar = np.column_stack([rng.uniform(0, 20, m), rng.uniform(-math.pi, math.pi, m)])
        expected = select_scan_W(converted_measurement_covs(pose, P, polar, R), mode)
        np.testing.assert_allclose(_scan_W(pose, P, polar, R, mode), expected, rtol=1e-13, atol=1e-15)
        np.testing.assert_array_equal(_select_scan_W(converted_measurement_covs(pose, P, polar, R), mode), expected)


# --------------------------------------------------------------------------- bad input

GOOD = dict(pose=np.zeros(3), pose_cov=np.eye(3) * 0.01, r=5.0, phi=0.1, R=R_APS)


@pytest.mark.parametrize("name, value", [
    ("pose", np.zeros(2)),
    ("pose", np.array([0.0, np.nan, 0.0])),
    ("pose_cov", np.eye(2)),
    ("pose_cov", np.full((3, 3), np.nan)),
    ("pose_cov", -np.eye(3)),
    ("pose_cov", np.triu(np.ones((3, 3)))),
    ("r", -1.0),
    ("r", np.nan),
    ("phi", np.inf),
    ("R", np.eye(3)),
    ("R", np.array([[1.0, 2.0], [2.0, 1.0]])),
    ("R", np.array([[np.nan, 0.0], [0.0, 1.0]])),
])
def test_converted_measurement_cov_rejects_bad_input(name, value):
    kwargs = dict(GOOD, **{name: value})
    with pytest.raises(InputError, match=name):
        converted_measurement_cov(**kwargs)


@pytest.mark.parametrize("name, value", [
    ("pose", np.zeros(4)),
    ("pose_cov", np.diag([1.0, 1.0, -1.0])),
    ("polar", np.zeros((3, 3))),
    ("polar", np.array([[1.0, np.nan]])),
    ("polar", np.array([[-1.0, 0.0]])),
    ("R", np.array([[1.0, 0.0], [0.5, 1.0]])),
])
def test_converted_measurement_covs_rejects_bad_input(name, value):
    kwargs = dict(pose=np.zeros(3), pose_cov=np.eye(3) * 0.01, polar=np.array([[5.0, 0.1]]), R=R_APS)
    kwargs[name] = value
    with pytest.raises(InputError, match=name):
        converted_measurement_covs(**kwargs)


@pytest.mark.parametrize("Ws", [
    np.empty((0, 2, 2)),
    np.eye(2),
    np.zeros((2, 3, 3)),
    np.array([[[1.0, np.nan], [np.nan, 1.0]]]),
    np.array([[[1.0, 2.0], [2.0, 1.0]]]),
    np.array([[[1.0, 0.3], [0.0, 1.0]]]),
])
def test_select_scan_W_rejects_bad_Ws(Ws):
    with pytest.raises(InputError, match="Ws"):
        select_scan_W(Ws)


def test_select_scan_W_rejects_unknown_mode():
    with pytest.raises(InputError, match="mode"):
        select_scan_W(np.eye(2)[None], "elementwise_max")
