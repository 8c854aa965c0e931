"""The car's states considered, not estimated (docs/method.md c.13.4): the Schmidt-Kalman update as
the code runs it (the scan's update, then the held states put back in the platform's coordinates)
against the textbook gain with zeroed rows; both engines alike; the held states never move."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))

from radarslam.config import merge_tables, profile_config  # noqa: E402
from radarslam.config.variants import CONSISTENT  # noqa: E402
from radarslam.core.angles import wrap_pi_scalar  # noqa: E402
from radarslam.slam import _fused, consider, ekf  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402
from radarslam.slam.scan_frame import enter_frame, leave_frame, rehold  # noqa: E402
from test_fused import _assert_same_run, _overlay, _scenario  # noqa: E402

N, LO, HI = 10, 3, 5            # pose, two held states (a bias and the radar's yaw offset), two landmarks
YAW = 4                         # the yaw offset's index
MYAW = 0.3                      # the radar's stated yaw (no lever arm: the frame change is then affine)


def _problem(seed):
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((N, N))
    P = 0.1 * A @ A.T + 0.05 * np.eye(N)
    x = 0.3 * rng.standard_normal(N)
    Hs = rng.standard_normal((4, N))
    Hs[:, LO:HI] = 0.0          # measured from the sensor's pose: no column on the held states
    R = 0.2 * np.eye(4)
    e = rng.standard_normal(4)
    return x, P, Hs, R, e


def _frame_jacobian():
    """``G``: the state in the radar's frame as a linear map of the platform's (enter_frame, c.13.1)."""
    G = np.eye(N)
    G[2, YAW] = 1.0
    return G


def _schmidt(x, P, H, R, e):
    """The textbook Schmidt-Kalman update: the optimal gain with the held rows zeroed, Joseph form."""
    K = P @ H.T @ np.linalg.inv(H @ P @ H.T + R)
    K[LO:HI] = 0.0
    A = np.eye(N) - K @ H
    return x + K @ e, A @ P @ A.T + K @ R @ K.T


def _as_the_code_does(x, P, Hs, R, e, back_in_platform=True):
    x, P = x.copy(), P.copy()
    xc, Pcc = consider.held(x, P, LO, HI)
    enter_frame(x, P, 0.0, 0.0, MYAW, YAW, -1, np.zeros(3))
    ekf.joint_update_inplace(x, P, e, Hs, R)
    if back_in_platform:
        rehold(x, P, xc, Pcc, LO, True, 0.0, 0.0, MYAW, YAW, -1, np.zeros(3))
    else:                       # negative control: the held states put back in the radar's frame
        consider.restore(x, P, xc, Pcc, LO)
    leave_frame(x, P, 0.0, 0.0, MYAW, YAW, -1, np.zeros(3))
    return x, P


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_scans_update_then_the_hold_is_the_schmidt_kalman_update(seed):
    """A joint update in the radar's frame (whose heading holds the yaw offset) followed by
    ``rehold`` equals the textbook Schmidt update in the platform's coordinates, where the yaw
    offset does have a column in ``H = H_s G``; the held mean and block are untouched."""
    x, P, Hs, R, e = _problem(seed)
    want_x, want_P = _schmidt(x, P, Hs @ _frame_jacobian(), R, e)
    got_x, got_P = _as_the_code_does(x, P, Hs, R, e)
    got_x[2] = want_x[2] + wrap_pi_scalar(got_x[2] - want_x[2])           # the update wraps the heading
    np.testing.assert_allclose(got_x, want_x, atol=1e-12)
    np.testing.assert_allclose(got_P, want_P, atol=1e-12)
    assert np.array_equal(got_x[LO:HI], x[LO:HI]) and np.array_equal(got_P[LO:HI, LO:HI], P[LO:HI, LO:HI])
    assert np.abs(got_P[:LO, LO:HI] - P[:LO, LO:HI]).max() > 1e-3          # the cross terms did change
    assert np.linalg.eigvalsh(got_P).min() > 0.0


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_negative_control_the_hold_in_the_radars_frame_is_not_schmidt(seed):
    """Putting the held states back while the pose is still the radar's gives the whole heading
    correction to the car's heading (what the yaw offset would have explained): not the Schmidt
    update, by far more than rounding."""
    x, P, Hs, R, e = _problem(seed)
    want_x, _ = _schmidt(x, P, Hs @ _frame_jacobian(), R, e)
    got_x, _ = _as_the_code_does(x, P, Hs, R, e, back_in_platform=False)
    assert abs(wrap_pi_scalar(got_x[2] - want_x[2])) > 1e-3


BIASED = {"odometer": {"speed_scale": 1.04, "turn_rate_bias_deg_s": 0.5}}
CONSIDER = merge_tables(CONSISTENT.overlay, {"filter": {"odometry_bias": "states", "car_states": "consider"}})


def test_both_engines_hold_the_car_states_alike():
    """The biased car park (c.11.4) with the odometry-bias states considered: the fused engine is the
    steps form's run to 1e-9; the states stay at their prior 0 after every scan and their variance
    only grows (by the random walk's drift), while the pose's covariance carries them; estimated
    instead (negative control), they move, their variance shrinks and the run differs."""
    cfg = _overlay(profile_config("apsipa"), BIASED)
    events = _scenario(cfg, 3).events
    run = _overlay(cfg, CONSIDER)
    assert _assert_same_run(run, events) > 1000
    r, _ = _fused.run(EkfSlam(run), events)
    prior = EkfSlam(run).state.P[LO:HI, LO:HI]
    assert np.array_equal(r["bias"], np.zeros_like(r["bias"]))
    var = np.diagonal(r["bias_covs"], axis1=1, axis2=2)
    assert np.all(np.diff(var, axis=0) >= 0.0) and np.all(var[0] >= np.diag(prior))   # only the drift adds
    est, _ = _fused.run(EkfSlam(_overlay(run, {"filter": {"car_states": "estimate"}})), events)
    assert np.abs(est["bias"][-1]).max() > 1e-3
    assert np.any(np.diagonal(est["bias_covs"][-1]) < 0.5 * np.diag(prior))             # the scans taught them
    assert np.abs(est["poses"] - r["poses"]).max() > 1e-3
