"""A trajectory against its truth, as evo's APE states it (docs/recordings.md
"What metrics.json holds").

- :func:`align`: none, the first pose, or the SE(2) least-squares fit without scale (Umeyama,
  IEEE T-PAMI 13(4), 1991, eqs. 38-42 in two dimensions);
- :func:`trajectory_errors`: the position RMSE ``sqrt(mean_k |p_k - p_k^true|^2)`` (evo's APE of the
  translation part, its ``rmse``), the heading RMSE, and beside them the paper's avg. RMSE
  (docs/method.md f.1), which for one run is the MEAN position error (evo's APE ``mean``);
- :func:`trajectory_nees`: the pose NEES at every scan against the same truth after the same
  alignment, the covariance turned with the pose (:func:`~radarslam.metrics.pose.pose_nees_summary`).
"""

from __future__ import annotations

import math

import numpy as np

from radarslam.core.angles import wrap_pi
from radarslam.metrics.pose import avg_rmse, pose_errors, pose_nees_summary

#: The alignments :func:`align` knows.
ALIGNMENTS = ("none", "first-pose", "se2")
#: One line per figure of :func:`trajectory_errors` (metrics.json's ``definitions``).
DEFINITIONS = {
    "position_rmse_m": "sqrt(mean over scans of |p - p_true|^2): evo's APE (translation part) rmse",
    "heading_rmse_deg": "sqrt(mean over scans of wrap(theta - theta_true)^2)",
    "position_avg_rmse_m": "the paper's avg. RMSE (docs/method.md f.1): mean over scans of sqrt(mean over runs "
                           "of |p - p_true|^2); of one run, the mean position error (evo's APE mean)",
    "heading_avg_rmse_deg": "the paper's avg. RMSE of the heading: of one run, the mean |heading error|",
    "alignment": "none: the estimate as is; first-pose: moved so that its first pose is the truth's; "
                 "se2: the rotation and translation (no scale) of least squares (Umeyama)",
}


def umeyama_se2(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation ``R`` (2, 2) and translation ``t`` (2,) minimising ``sum |R src_k + t - dst_k|^2``.

    Parameters
    ----------
    src, dst : ndarray, shape (K, 2)
        Matched points (K >= 2, not all at one place).
    """
    mu_s, mu_d = src.mean(axis=0), dst.mean(axis=0)
    sigma = (dst - mu_d).T @ (src - mu_s) / src.shape[0]          # Umeyama eq. 38
    U, _, Vt = np.linalg.svd(sigma)
    D = np.diag([1.0, math.copysign(1.0, np.linalg.det(U) * np.linalg.det(Vt))])   # eq. 39: a rotation
    R = U @ D @ Vt
    return R, mu_d - R @ mu_s


def transform(poses: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Poses ``(K, 3)`` moved by the rigid motion ``(R, t)`` (headings turned by R's angle)."""
    out = np.empty_like(poses)
    out[:, :2] = poses[:, :2] @ R.T + t
    out[:, 2] = wrap_pi(poses[:, 2] + math.atan2(R[1, 0], R[0, 0]))
    return out


def alignment(est: np.ndarray, true: np.ndarray, how: str = "none") -> tuple[np.ndarray, np.ndarray]:
    """The rigid motion ``(R, t)`` that :func:`align` applies to ``est`` (K, 3) for ``true`` (K, 3) by
    ``how`` (one of :data:`ALIGNMENTS`; ``none``: the identity)."""
    if how == "none":
        return np.eye(2), np.zeros(2)
    if how == "first-pose":
        a = true[0, 2] - est[0, 2]
        R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
        return R, true[0, :2] - R @ est[0, :2]
    if how == "se2":
        if est.shape[0] < 2:
            return alignment(est, true, "first-pose")
        return umeyama_se2(est[:, :2], true[:, :2])
    raise ValueError(f"align: expected one of {', '.join(ALIGNMENTS)}, got {how!r}")


def align(est: np.ndarray, true: np.ndarray, how: str = "none") -> np.ndarray:
    """``est`` (K, 3) aligned to ``true`` (K, 3) by ``how`` (one of :data:`ALIGNMENTS`)."""
    if how == "none":
        return est
    return transform(est, *alignment(est, true, how))


def trajectory_errors(est: np.ndarray, true: np.ndarray, how: str = "none") -> dict:
    """The figures of :data:`DEFINITIONS` of ``est`` against ``true`` (both (K, 3), matched rows;
    rows where the truth is NaN are left out), after :func:`align` by ``how``."""
    ok = np.all(np.isfinite(true), axis=1)
    if not ok.any():
        return {"truth_scans": 0}
    est, true = align(est[ok], true[ok], how), true[ok]
    pos, head = pose_errors(est, true)
    return {"truth_scans": int(ok.sum()), "position_rmse_m": float(np.sqrt(np.mean(pos ** 2))),
            "heading_rmse_deg": math.degrees(float(np.sqrt(np.mean(head ** 2)))),
            "position_avg_rmse_m": avg_rmse(pos), "heading_avg_rmse_deg": math.degrees(avg_rmse(head)),
            "final_position_error_m": float(pos[-1]), "final_heading_error_deg": math.degrees(abs(float(head[-1]))),
            "position_max_error_m": float(pos.max())}


#: One line per figure of :func:`trajectory_nees` (metrics.json's ``pose_nees["definitions"]``).
NEES_DEFINITIONS = {
    "per_scan": "e^T (P + diag(truth_std^2))^-1 e at every scan (null without a truth), e = (x - x_true, "
                "y - y_true, wrap(theta - theta_true)) after the alignment, P the filter's pose covariance "
                "turned with the pose; chi-square with 3 dof for a consistent filter and a truth of that std",
    "band_per_scan": "the two-sided chi-square band of one scan: chi2.ppf((1 - p)/2, 3), chi2.ppf((1 + p)/2, 3)",
    "share_inside_band": "the share of the scans with a NEES inside band_per_scan (p for a consistent filter)",
    "time_average": "the mean of per_scan over the scans with one (3 for a consistent filter)",
    "band_time_average": "chi2.ppf((1 -+ p)/2, 3 K) / K over K scans: the band of the mean of K INDEPENDENT "
                         "scans; a filter's errors are correlated in time, so it is narrower than the mean's spread",
    "alignment": "an alignment fitted to this estimate (first-pose, se2) lowers its errors: its NEES is optimistic",
    "components": "along_track, cross_track (the position error and covariance in the true heading's frame) and "
                  "heading: the time average of each 1-dof NEES (1 for a consistent filter), its band, the RMS error "
                  "and the RMS std (m; heading deg): which direction the filter misjudges",
}


def trajectory_nees(est: np.ndarray, covs: np.ndarray, true: np.ndarray, how: str = "none",
                    truth_std=(0.0, 0.0, 0.0), prob: float = 0.95) -> dict:
    """:func:`~radarslam.metrics.pose.pose_nees_summary` of ``est`` (K, 3) with its covariances ``covs``
    (K, 3, 3) against ``true`` (K, 3) after the alignment of :func:`trajectory_errors` (fitted on the
    rows with a truth): the poses moved by ``(R, t)``, each covariance turned by ``diag(R, 1)``."""
    est, covs, true = (np.asarray(a, dtype=float) for a in (est, covs, true))
    ok = np.all(np.isfinite(true), axis=1)
    moved = est.copy()
    if ok.any() and how != "none" and covs.shape[1:] == (3, 3):      # else refused below
        R, t = alignment(est[ok], true[ok], how)
        moved[ok] = transform(est[ok], R, t)
        J = np.eye(3)
        J[:2, :2] = R
        covs = J @ covs @ J.T
    return pose_nees_summary(moved, covs, true, truth_std, prob)
