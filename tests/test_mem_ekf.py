"""MEM-EKF* shape estimation (docs/method.md a.10; Yang & Baum 2019): the kernel against an
independent evaluation of its moments, its Jacobians against central differences, shape <-> matrix
round trips, convergence on a static ellipse with a wrong-spread negative control, and the
estimator component inside EKF-SLAM on a short car-park run."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from radarslam.config import from_dict
from radarslam.core.errors import ConfigError, InputError
from radarslam.core.registry import EXTENT_ESTIMATORS
from radarslam.slam.driver import run_filter
from radarslam.extent.mem_ekf import (
    AXIS_FLOOR,
    MemEkfEstimator,
    MemEkfState,
    mem_ekf_predict,
    mem_ekf_update,
    mem_ekf_update_scan,
    pseudo_measurement_jacobian,
    shape_from_matrix,
    shape_jacobians,
    shape_matrix,
)
from radarslam.metrics.gwd import gaussian_wasserstein_distance
from radarslam.simulation.scenario import generate_scenario
from radarslam.slam import EkfSlam

# --------------------------------------------------------------------------- independent reference
#: Central-difference step. Truncation error ~ h^2 |f'''| / 6 ~ 1e-10 relative, rounding ~ eps |f| / h
#: ~ 2e-11 relative for the O(1-10) entries here: the reference Jacobians carry ~1e-10 relative error.
FD_STEP = 1e-5
#: The entries (i, j) of the pseudo-measurement Y = [e1^2, e2^2, e1 e2] (0-based).
PAIRS = ((0, 0), (1, 1), (0, 1))


def S_of(p: np.ndarray) -> np.ndarray:
    """S(p) = R(theta) diag(l1, l2), typed in as matrices."""
    th, l1, l2 = p
    R = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]])
    return R @ np.diag([l1, l2])


def dS_dp(p: np.ndarray) -> np.ndarray:
    """(3, 2, 2): dS/dp_k by central differences (numerical linearisation of S)."""
    return np.array([(S_of(p + e) - S_of(p - e)) / (2 * FD_STEP) for e in np.eye(3) * FD_STEP])


def pseudo_mean(p: np.ndarray, c_h: float) -> np.ndarray:
    """E[Y] as a function of p alone (the spread c_h S S^T; the other terms do not depend on p)."""
    SS = c_h * S_of(p) @ S_of(p).T
    return np.array([SS[i, j] for i, j in PAIRS])


def reference_moments(p, Cp, Cm, Cv, c_h):
    """Moments of the pseudo-measurement for the model linearised in p, from numpy matrices:
    C_y = C_m + c_h S S^T + E[dS C_h dS^T] + C_v with dS = sum_k dS/dp_k dp_k, E[Y] its entries,
    C^Y by Isserlis' theorem on index pairs, H = dE[Y]/dp by central differences."""
    S, dS = S_of(p), dS_dp(p)
    shape_unc = c_h * np.einsum("kl,kab,lcb->ac", Cp, dS, dS)
    Cy = Cm + c_h * S @ S.T + shape_unc + Cv
    EY = np.array([Cy[i, j] for i, j in PAIRS])
    CY = np.array([[Cy[i, k] * Cy[j, l] + Cy[i, l] * Cy[j, k] for k, l in PAIRS] for i, j in PAIRS])
    H = np.column_stack([(pseudo_mean(p + e, c_h) - pseudo_mean(p - e, c_h)) / (2 * FD_STEP)
                         for e in np.eye(3) * FD_STEP])
    return Cy, EY, CY, H


def reference_update(p, Cp, m, Cm, y, Cv, c_h):
    """The Kalman update with the pseudo-measurement, from the reference moments."""
    _, EY, CY, H = reference_moments(p, Cp, Cm, Cv, c_h)
    e = y - m
    Y = np.array([e[i] * e[j] for i, j in PAIRS])
    CpY = Cp @ H.T
    K = np.linalg.solve(CY, CpY.T).T
    return p + K @ (Y - EY), Cp - K @ CY @ K.T


def random_spd(rng, n: int, stds) -> np.ndarray:
    """A random covariance with the given standard deviations and random correlations."""
    L = rng.normal(size=(n, n))
    C = L @ L.T + 0.5 * np.eye(n)
    d = np.sqrt(np.diag(C))
    return (C / np.outer(d, d)) * np.outer(stds, stds)


def random_case(rng):
    p = np.array([rng.uniform(0, math.pi), *rng.uniform(0.4, 3.0, 2)])
    Cp = random_spd(rng, 3, [rng.uniform(0.02, 0.3), *rng.uniform(0.05, 0.5, 2)])
    m = rng.normal(scale=20.0, size=2)
    Cm = random_spd(rng, 2, rng.uniform(0.02, 0.4, 2))
    Cv = random_spd(rng, 2, rng.uniform(0.05, 0.5, 2))
    c_h = float(rng.choice([0.25, 0.5]))
    y = m + S_of(p) @ rng.normal(scale=math.sqrt(c_h), size=2) + rng.multivariate_normal(np.zeros(2), Cv)
    return p, Cp, m, Cm, Cv, c_h, y


def angle_diff_mod_pi(a: float, b: float) -> float:
    return (a - b + math.pi / 2) % math.pi - math.pi / 2


# --------------------------------------------------------------------------- the kernel
def test_update_matches_independent_evaluation_on_random_cases():
    """80 random one-detection updates against the reference; at least 50 must be comparable (no
    floor, no skipped indefinite update; in fact all 80 are). Tolerance: the reference's Jacobians
    are ~1e-10 relative (FD_STEP) and the gain solves with C^Y (condition numbers up to 126 here), so
    the corrections can differ by ~1e-9 of their size (measured: 2e-10); 1e-8 relative to the
    correction (plus 1e-12 absolute) leaves a 50x margin, while a slip in any expanded entry of the
    kernel is an O(1) relative error."""
    rng = np.random.default_rng(2019)
    compared = 0
    for _ in range(80):
        p, Cp, m, Cm, Cv, c_h, y = random_case(rng)
        p_ref, Cp_ref = reference_update(p, Cp, m, Cm, y, Cv, c_h)
        p_new, Cp_new = mem_ekf_update(p, Cp, m, Cm, y, Cv, c_h)
        if min(p_ref[1:]) < AXIS_FLOOR or np.linalg.eigvalsh(Cp_ref)[0] <= 0:
            continue
        compared += 1
        dp = p_ref - p
        tol = 1e-8 * np.abs(dp).max() + 1e-12
        assert abs(angle_diff_mod_pi(p_new[0], p_ref[0])) < tol
        assert 0.0 <= p_new[0] < math.pi
        np.testing.assert_allclose(p_new[1:], p_ref[1:], rtol=0, atol=tol)
        np.testing.assert_allclose(Cp_new, Cp_ref, rtol=0, atol=1e-8 * np.abs(Cp - Cp_ref).max() + 1e-14)
        assert np.array_equal(Cp_new, Cp_new.T)
        # an update never adds uncertainty
        assert np.linalg.eigvalsh(Cp - Cp_new)[0] > -1e-12
    assert compared >= 50


def test_scan_update_is_the_sequence_of_single_updates():
    rng = np.random.default_rng(7)
    p, Cp, m, Cm, Cv, c_h, _ = random_case(rng)
    pts = m + rng.normal(size=(6, 2)) @ S_of(p).T * math.sqrt(c_h)
    Cvs = np.array([random_spd(rng, 2, rng.uniform(0.05, 0.3, 2)) for _ in range(6)])
    ps, Cps = mem_ekf_update_scan(p, Cp, m, Cm, pts, Cvs, c_h)
    q, Cq = p, Cp
    for y, C in zip(pts, Cvs):
        q, Cq = mem_ekf_update(q, Cq, m, Cm, y, C, c_h)
    np.testing.assert_array_equal(ps, q)
    np.testing.assert_array_equal(Cps, Cq)
    # no detections: nothing changes
    p0, C0 = mem_ekf_update_scan(p, Cp, m, Cm, np.empty((0, 2)), Cv, c_h)
    np.testing.assert_array_equal(p0, p)
    np.testing.assert_array_equal(C0, Cp)


def test_reference_moments_agree_with_monte_carlo_of_the_linearised_model():
    """The reference itself, checked by sampling y - m = dm + (S + sum_k dS_k dp_k) h + v: the mean
    of Y and its cross-covariance with dp (C^pY = C_p H^T) are exact for this model (the third
    moments vanish), so each entry must lie within 5 standard errors (the seed is fixed)."""
    rng = np.random.default_rng(11)
    n = 200_000
    for _ in range(3):
        p, Cp, _, Cm, Cv, c_h, _ = random_case(rng)
        _, EY, _, H = reference_moments(p, Cp, Cm, Cv, c_h)
        dp = rng.multivariate_normal(np.zeros(3), Cp, n)
        h = rng.normal(scale=math.sqrt(c_h), size=(n, 2))
        S_lin = S_of(p) + np.einsum("nk,kab->nab", dp, dS_dp(p))
        e = (rng.multivariate_normal(np.zeros(2), Cm, n) + np.einsum("nab,nb->na", S_lin, h)
             + rng.multivariate_normal(np.zeros(2), Cv, n))
        Y = np.column_stack([e[:, i] * e[:, j] for i, j in PAIRS])
        se = Y.std(axis=0) / math.sqrt(n)
        assert np.all(np.abs(Y.mean(axis=0) - EY) < 5 * se)
        prod = (dp - dp.mean(axis=0))[:, :, None] * (Y - Y.mean(axis=0))[:, None, :]
        se_cross = prod.std(axis=0) / math.sqrt(n)
        assert np.all(np.abs(prod.mean(axis=0) - Cp @ H.T) < 5 * se_cross)


@pytest.mark.parametrize("theta", [0.0, 1e-9, 0.7, math.pi / 2, math.pi - 1e-9, 2.5, -0.4, 4.0])
def test_jacobians_against_central_differences(theta):
    """J_1, J_2 (rows of S) and H = dE[Y]/dp against central differences, at orientations across
    and beyond [0, pi), for elongated, circular and 'l1 minor' shapes. FD error ~1e-10 (FD_STEP)."""
    for l1, l2 in [(2.3, 1.15), (1.0, 1.0), (0.3, 2.0)]:
        p = np.array([theta, l1, l2])
        J1, J2 = shape_jacobians(p)
        dS = dS_dp(p)                       # dS[k][i, :] = d S_i / d p_k
        np.testing.assert_allclose(J1, dS[:, 0, :].T, atol=1e-9)
        np.testing.assert_allclose(J2, dS[:, 1, :].T, atol=1e-9)
        for c_h in (0.25, 0.5):
            H = pseudo_measurement_jacobian(p, c_h)
            fd = np.column_stack([(pseudo_mean(p + e, c_h) - pseudo_mean(p - e, c_h)) / (2 * FD_STEP)
                                  for e in np.eye(3) * FD_STEP])
            np.testing.assert_allclose(H, fd, atol=1e-9)
            # the paper's form of the same matrix: rows 2 S_1 C_h J_1, 2 S_2 C_h J_2, S_1 C_h J_2 + S_2 C_h J_1
            S = S_of(p)
            paper = c_h * np.vstack([2 * S[0] @ J1, 2 * S[1] @ J2, S[0] @ J2 + S[1] @ J1])
            np.testing.assert_allclose(H, paper, atol=1e-12)


def test_predict_grows_the_covariance_only():
    p, Cp = np.array([0.4, 2.0, 1.0]), np.diag([0.01, 0.04, 0.09])
    q, Cq = mem_ekf_predict(p, Cp, 0.16, 0.02, 0.05)
    np.testing.assert_array_equal(q, p)
    np.testing.assert_allclose(Cq - Cp, np.diag([0.16 * 0.02**2, 0.16 * 0.05**2, 0.16 * 0.05**2]), rtol=1e-14)


def test_floors_and_wrapping():
    """A detection right at the centroid pulls the axes down: they stop at AXIS_FLOOR; the orientation
    stays in [0, pi) from either side of 0."""
    p, Cp = np.array([1e-4, 0.06, 0.06]), np.diag([0.5, 0.04, 0.04])
    m, Cm, Cv = np.zeros(2), np.zeros((2, 2)), 1e-4 * np.eye(2)
    q, _ = mem_ekf_update_scan(p, Cp, m, Cm, np.zeros((5, 2)), Cv)
    assert np.all(q[1:] >= AXIS_FLOOR) and 0.0 <= q[0] < math.pi
    rng = np.random.default_rng(3)
    for th in (1e-6, math.pi - 1e-6):
        ys = rng.normal(size=(20, 2)) @ S_of(np.array([th + 0.3, 2.0, 0.5])).T * 0.5
        q, _ = mem_ekf_update_scan(np.array([th, 1.0, 1.0]), np.diag([0.3, 0.2, 0.2]), m, Cm, ys, Cv)
        assert 0.0 <= q[0] < math.pi


def test_public_functions_name_bad_arguments():
    p, Cp, m, Cm, Cv = np.array([0.1, 1.0, 0.5]), np.eye(3) * 0.01, np.zeros(2), np.eye(2) * 0.01, np.eye(2) * 0.01
    with pytest.raises(InputError, match=r"^y: expected shape \(2,\)"):
        mem_ekf_update(p, Cp, m, Cm, np.zeros(3), Cv)
    with pytest.raises(InputError, match=r"^Cp: expected a positive definite matrix"):
        mem_ekf_update(p, np.diag([0.01, 0.01, 0.0]), m, Cm, np.zeros(2), Cv)
    with pytest.raises(InputError, match=r"^p: expected semi-axes >= 0"):
        mem_ekf_update(np.array([0.1, -1.0, 0.5]), Cp, m, Cm, np.zeros(2), Cv)
    with pytest.raises(InputError, match=r"^c_h: expected a value > 0"):
        mem_ekf_update(p, Cp, m, Cm, np.zeros(2), Cv, c_h=0.0)
    with pytest.raises(InputError, match=r"^Cv: expected shape \(3, 2, 2\)"):
        mem_ekf_update_scan(p, Cp, m, Cm, np.zeros((3, 2)), np.zeros((2, 2, 2)))
    with pytest.raises(InputError, match=r"^X: expected a symmetric matrix"):
        shape_from_matrix(np.array([[1.0, 0.5], [0.0, 1.0]]))


# --------------------------------------------------------------------------- shape <-> matrix
@given(theta=st.floats(0.0, math.pi, exclude_max=True), l1=st.floats(0.05, 20.0), ratio=st.floats(0.0, 0.99))
def test_shape_matrix_round_trip(theta, l1, ratio):
    """p -> X -> p with l1 >= l2; the orientation is recovered modulo pi (eigen-gap >= 2% of l1^2,
    so its rounding error is below 1e-13 rad). The squared axes (eigenvalues) carry ~eps l1^2 of
    rounding, which the square root turns into ~sqrt(eps) l1 = 1.5e-8 l1 for an axis near 0."""
    p = np.array([theta, l1, l1 * ratio])
    X = shape_matrix(p)
    q = shape_from_matrix(X)
    assert 0.0 <= q[0] < math.pi
    np.testing.assert_allclose(q[1:] ** 2, p[1:] ** 2, rtol=0, atol=1e-14 * l1 * l1)
    np.testing.assert_allclose(q[1:], p[1:], rtol=1e-12, atol=1e-7 * l1)
    assert abs(angle_diff_mod_pi(q[0], theta)) < 1e-9
    np.testing.assert_allclose(shape_matrix(q), X, rtol=0, atol=1e-12 * l1 * l1)


@given(theta=st.floats(-10.0, 10.0), a=st.floats(0.05, 10.0), b=st.floats(0.05, 10.0))
def test_orientation_ambiguity(theta, a, b):
    """[theta, a, b], [theta + pi, a, b] and [theta + pi/2, b, a] are one ellipse; shape_from_matrix
    returns its canonical form (major axis first, orientation in [0, pi))."""
    X = shape_matrix(np.array([theta, a, b]))
    for other in ([theta + math.pi, a, b], [theta + math.pi / 2, b, a], [theta - 3 * math.pi, a, b]):
        np.testing.assert_allclose(shape_matrix(np.array(other)), X, rtol=0, atol=1e-12 * max(a, b) ** 2)
    q = shape_from_matrix(X)
    assert q[1] >= q[2] and 0.0 <= q[0] < math.pi
    if abs(a - b) > 1e-3 * max(a, b):
        major_dir = theta if a > b else theta + math.pi / 2
        assert abs(angle_diff_mod_pi(q[0], major_dir)) < 1e-9


def test_matrix_round_trip_on_random_spd():
    rng = np.random.default_rng(5)
    for _ in range(200):
        X = random_spd(rng, 2, rng.uniform(0.05, 5.0, 2))
        np.testing.assert_allclose(shape_matrix(shape_from_matrix(X)), X, rtol=0, atol=1e-12 * np.abs(X).max())
    np.testing.assert_array_equal(shape_from_matrix(4.0 * np.eye(2)), [0.0, 2.0, 2.0])   # circle: theta = 0


# --------------------------------------------------------------------------- convergence on a static ellipse
TRUE_P = np.array([0.6, 2.3, 1.15])       # a 4 x 2 m car's moment ellipse (L / sqrt 3, W / sqrt 3)
CENTRE = np.array([12.0, -4.0])
SIGMA = 0.1                               # sensor noise std (m), isotropic, known to the filter


def ellipse_detections(rng, n: int, spread: str) -> np.ndarray:
    """``n`` detections uniform over the surface of the TRUE_P ellipse, or on its contour, plus noise."""
    rho = np.sqrt(rng.uniform(size=n)) if spread == "surface" else np.ones(n)
    u = rng.uniform(0.0, 2 * math.pi, n)
    local = np.column_stack([rho * np.cos(u), rho * np.sin(u)])
    return CENTRE + local @ S_of(TRUE_P).T + rng.normal(scale=SIGMA, size=(n, 2))


def track(seed: int, n_scans: int, c_h: float, spread: str = "surface", m: int = 8) -> list[np.ndarray]:
    """The shape after each of ``n_scans`` scans of ``m`` detections, from a deliberately poor start
    (a 1.6 m circle turned 25 degrees off), known centroid, q = 0."""
    rng = np.random.default_rng(seed)
    p, Cp = np.array([TRUE_P[0] + math.radians(25), 1.6, 1.6]), np.diag([0.5 ** 2, 0.5 ** 2, 0.5 ** 2])
    out = []
    for _ in range(n_scans):
        p, Cp = mem_ekf_update_scan(p, Cp, CENTRE, np.zeros((2, 2)), ellipse_detections(rng, m, spread),
                                    SIGMA ** 2 * np.eye(2), c_h)
        out.append(p)
    return out


def shape_gwd(p: np.ndarray) -> float:
    """GWD between the estimate and the truth on the same centre: the extent error alone (m)."""
    return gaussian_wasserstein_distance(CENTRE, shape_matrix(p), CENTRE, shape_matrix(TRUE_P))


#: Measured over the 8 seeds below (development run): GWD median 0.225 m after 5 scans, 0.033 m
#: (max 0.063 m) after 150 scans (1200 detections); axis errors at most 4.3 cm, orientation errors
#: at most 1.8 degrees. The asserted bounds (median 0.06 m, max 0.12 m, 8 cm, 3 degrees) leave a
#: margin of about 2x; a start 25 degrees and up to 0.7 m off, so "shrinks" is a factor >= 2.
GWD_BOUND_END = 0.06


def test_converges_on_a_static_ellipse():
    early, late = [], []
    for seed in range(8):
        ps = track(seed, 150, 0.25)
        early.append(shape_gwd(ps[4]))
        late.append(shape_gwd(ps[-1]))
        p = ps[-1]
        assert np.max(np.abs(np.sort(p[1:]) - np.sort(TRUE_P[1:]))) < 0.08
        assert abs(math.degrees(angle_diff_mod_pi(p[0], TRUE_P[0]))) < 3.0
    assert np.median(late) < GWD_BOUND_END and max(late) < 2 * GWD_BOUND_END
    assert np.median(early) > 2 * np.median(late)


def test_negative_control_wrong_spread_factor_biases_the_axes_predictably():
    """c_h = 1 on surface detections (true 1/4): the filter matches c_h l^2 to l^2 / 4, so the axes
    come out halved (sqrt(1/4)); the GWD bound of the correct model fails. On contour detections the
    right factor is 1/2 (h = [cos u, sin u]); the surface factor 1/4 inflates the axes by sqrt 2."""
    wrong = [track(seed, 150, 1.0)[-1] for seed in range(4)]
    for p in wrong:
        ratio = np.sort(p[1:]) / np.sort(TRUE_P[1:])
        assert np.all(np.abs(ratio - 0.5) < 0.05)      # noise sigma^2 adds ~0.3% to l^2 here
        assert shape_gwd(p) > 5 * GWD_BOUND_END
    for seed in range(4):
        right = track(seed, 150, 0.5, "contour")[-1]
        assert np.all(np.abs(np.sort(right[1:]) / np.sort(TRUE_P[1:]) - 1.0) < 0.04)
        inflated = track(seed, 150, 0.25, "contour")[-1]
        assert np.all(np.abs(np.sort(inflated[1:]) / np.sort(TRUE_P[1:]) - math.sqrt(2)) < 0.06)


# --------------------------------------------------------------------------- the component
def mem_ekf_config(**extent):
    return from_dict({"trajectory": {"n_steps": 70}, "extent": {"estimator": "mem-ekf", **extent}})


def test_estimator_initialises_from_efa_and_tracks():
    # the extent step's R matched to the test data: 0.1 m along the range and across it at 12 m
    cfg = mem_ekf_config(use_in_slam=True, range_std_m=SIGMA, azimuth_std_deg=math.degrees(SIGMA / 12.0))
    est = EXTENT_ESTIMATORS.create("mem-ekf", cfg)
    assert isinstance(est, MemEkfEstimator)
    st_ = est.new()
    rng = np.random.default_rng(1)
    pose, pose_cov = np.zeros(3), np.eye(3) * 1e-6
    polar = np.column_stack([np.full(8, 12.0), np.zeros(8)])     # W only; the points are set directly
    k = 0
    while not st_.initialized:
        est.step(st_, polar, ellipse_detections(rng, 8, "surface"), CENTRE, np.zeros((2, 2)), pose, pose_cov,
                 0.16, k)
        k += 1
    assert k == 3                                   # 24 > n_init = 20 buffered detections
    assert isinstance(st_, MemEkfState) and st_.X_efa is not None
    np.testing.assert_allclose(st_.X, st_.X_efa, rtol=1e-12)    # the EFA fit, through p
    np.testing.assert_array_equal(st_.X, shape_matrix(st_.p))
    np.testing.assert_array_equal(st_.Cp, est.Cp0)
    for _ in range(100):
        est.step(st_, polar, ellipse_detections(rng, 8, "surface"), CENTRE, np.zeros((2, 2)), pose, pose_cov,
                 0.16, k)
        k += 1
    np.testing.assert_array_equal(est.matrix(st_), shape_matrix(st_.p))
    assert shape_gwd(st_.p) < 2 * GWD_BOUND_END    # process noise on: a little above the q = 0 bound
    gX, has = est.spreads([st_, est.new()])
    assert has.tolist() == [True, False]
    np.testing.assert_array_equal(gX[0], cfg.extent.spread_factor * st_.X)
    fresh = est.new()
    kept = est.merge(fresh, st_)                 # an uninitialised survivor takes the other's shape
    assert kept.initialized and kept.n_buffered == 0
    for a, b in ((kept.p, st_.p), (kept.Cp, st_.Cp), (kept.X, st_.X), (kept.X_efa, st_.X_efa)):
        np.testing.assert_array_equal(a, b)


def test_noise_modes_count_the_shared_errors_or_not():
    """extent.mem_ekf_noise (a.10): with a large centroid and pose covariance, "full" counts them per
    detection and shrinks the axes; "sensor" (the default) ignores them and converges to the truth;
    "no-centroid" lies between."""
    rng = np.random.default_rng(5)
    pose, pose_cov = np.zeros(3), np.diag([0.3, 0.3, 1e-3])
    polar = np.column_stack([np.full(8, 12.0), np.zeros(8)])
    C_m = np.eye(2) * 0.5
    err = {}
    for mode in ("full", "no-centroid", "sensor"):
        cfg = mem_ekf_config(use_in_slam=True, range_std_m=SIGMA, azimuth_std_deg=math.degrees(SIGMA / 12.0),
                             mem_ekf_noise=mode)
        est = EXTENT_ESTIMATORS.create("mem-ekf", cfg)
        st_ = est.new()
        r = np.random.default_rng(rng.integers(1 << 30))
        for k in range(150):
            est.step(st_, polar, ellipse_detections(r, 8, "surface"), CENTRE, C_m, pose, pose_cov, 0.16, k)
        err[mode] = shape_gwd(st_.p)
        if mode == "full":
            assert min(st_.p[1:]) < 0.8 * TRUE_P[2]     # the minor axis shrunk by the double counting
    assert err["sensor"] < 2 * GWD_BOUND_END < err["full"]
    assert err["sensor"] < err["no-centroid"] < err["full"]
    assert mem_ekf_config().extent.mem_ekf_noise == "sensor"


def test_estimator_inside_slam_on_a_short_car_park_run():
    """'With extent' on 70 car-park steps: the run finishes, every landmark with an extent has a
    finite SPD matrix equal to shape_matrix(p), a valid shape and a positive definite C_p."""
    cfg = mem_ekf_config(use_in_slam=True)
    scenario = generate_scenario(cfg, np.random.default_rng(3))
    slam = EkfSlam(cfg)
    rec = run_filter(cfg, scenario.events, slam)
    assert len(rec.maps) == cfg.trajectory.n_steps
    states = [r.extent for r in slam.state.landmarks]
    shaped = [s for s in states if s.initialized]
    assert len(shaped) >= 3
    for s in shaped:
        assert isinstance(s, MemEkfState)
        np.testing.assert_array_equal(s.X, shape_matrix(s.p))
        assert np.all(np.isfinite(s.X)) and np.linalg.eigvalsh(s.X)[0] >= AXIS_FLOOR ** 2 * (1 - 1e-9)
        assert 0.0 <= s.p[0] < math.pi and s.p[1:].min() >= AXIS_FLOOR
        assert np.array_equal(s.Cp, s.Cp.T) and np.linalg.eigvalsh(s.Cp)[0] > 0
    final = rec.maps[-1]
    has = ~np.isnan(final.rma[:, 0, 0])
    assert has.sum() == len(shaped)
    assert np.all(np.isfinite(final.rma[has])) and np.all(np.linalg.eigvalsh(final.rma[has])[:, 0] > 0)


@pytest.mark.parametrize("key, value, message", [
    ("mem_ekf_init_std", [0.0, 0.5], r"^extent\.mem_ekf_init_std: expected positive values, got \[0\.0, 0\.5\]$"),
    ("mem_ekf_init_std", [10.0], r"^extent\.mem_ekf_init_std: expected a list of 2 values, got 1$"),
    ("mem_ekf_process_std", [-1.0, 0.0], r"^extent\.mem_ekf_process_std: expected values >= 0"),
    ("mem_ekf_process_std", [1.0, "a"], r"^extent\.mem_ekf_process_std\[1\]: expected a number, got 'a'$"),
    ("estimator", "mem_ekf", r"^extent\.estimator: expected one of \[.*'mem-ekf'.*\], got 'mem_ekf'$"),
])
def test_bad_config_values_are_one_line_errors_naming_the_key(key, value, message):
    with pytest.raises(ConfigError, match=message) as err:
        from_dict({"extent": {key: value}})
    assert "\n" not in str(err.value)
