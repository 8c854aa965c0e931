"""The pose covariance and the pose NEES as outputs of a recording run (docs/recordings.md "What
metrics.json holds", "Commands"): ``trajectory.csv``'s covariance columns, ``metrics.json["pose_nees"]``
against hand-computed values and scipy's chi-square bands, ``nees.png`` only with a truth, and the
refusal of a covariance that is not symmetric positive definite."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.stats import chi2

from radarslam.cli.main import main
from radarslam.config import profile_config
from radarslam.core.errors import InputError
from radarslam.io.recording.plain import read_plain, write_plain
from radarslam.io.recording.synthetic import synthetic_recording
from radarslam.io.results import POSE_COV_COLUMNS
from radarslam.metrics.pose import pose_nees_summary
from radarslam.metrics.trajectory import transform, trajectory_nees
from radarslam.runs.start import filter_cov_to_platform, filter_to_platform

PNG = b"\x89PNG\r\n\x1a\n"
LO3, HI3 = chi2.ppf(0.025, 3), chi2.ppf(0.975, 3)


def _table(path: Path) -> dict[str, np.ndarray]:
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    return {h: np.array([float(r[j]) for r in rows[1:]]) for j, h in enumerate(rows[0])}


def _hand_nees(e: np.ndarray, P: np.ndarray) -> np.ndarray:
    """``e_k^T P_k^-1 e_k`` by the explicit inverse, one scan at a time."""
    return np.array([float(ek @ np.linalg.inv(Pk) @ ek) for ek, Pk in zip(e, P)])


# ------------------------------------------------------------------------------------------------
# The arithmetic (metrics/pose.py, metrics/trajectory.py)
# ------------------------------------------------------------------------------------------------
def test_nees_by_hand_with_and_without_the_truths_std():
    est = np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, math.pi - 0.05], [5.0, 5.0, 0.0]])
    true = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, -math.pi + 0.05], [np.nan] * 3])
    covs = np.array([np.diag([4.0, 1.0, 1.0]), [[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 1.0]],
                     np.diag([1.0, 1.0, 0.01]), np.eye(3)])
    s = pose_nees_summary(est, covs, true)
    # 1 / 4; (1, 1) through [[2, 1], [1, 2]]^-1 = [[2, -1], [-1, 2]] / 3: 2/3; the heading error wrapped: -0.1
    np.testing.assert_allclose(s["per_scan"][:3], [0.25, 2.0 / 3.0, 0.01 / 0.01], rtol=1e-12)
    assert np.isnan(s["per_scan"][3]) and s["scans"] == 3 and s["exact_pose_scans"] == 0
    assert s["time_average"] == pytest.approx((0.25 + 2.0 / 3.0 + 1.0) / 3.0, rel=1e-12)
    # the truth's std (1 m, 0, 0.1 rad) added: 1 / (4 + 1); (1, 1) through [[3, 1], [1, 2]]^-1 = [[2, -1], [-1, 3]] / 5:
    # 3/5; 0.1^2 / (0.01 + 0.01)
    t = pose_nees_summary(est, covs, true, truth_std=(1.0, 0.0, 0.1))
    np.testing.assert_allclose(t["per_scan"][:3], [0.2, 0.6, 0.5], rtol=1e-12)


def test_bands_are_scipys_chi_square_and_the_shares_count_scans():
    est = np.zeros((5, 3))
    est[:, 0] = np.sqrt([0.1, 1.0, 3.0, 9.0, 20.0])      # NEES 0.1, 1, 3, 9, 20 with a unit covariance
    s = pose_nees_summary(est, np.tile(np.eye(3), (5, 1, 1)), np.zeros((5, 3)))
    np.testing.assert_allclose(s["per_scan"], [0.1, 1.0, 3.0, 9.0, 20.0], rtol=1e-12)
    assert s["band_per_scan"] == [pytest.approx(LO3, rel=1e-12), pytest.approx(HI3, rel=1e-12)]
    assert (LO3, HI3) == pytest.approx((0.2158, 9.3484), abs=1e-4)
    assert s["band_time_average"] == [pytest.approx(chi2.ppf(0.025, 15) / 5, rel=1e-12),
                                      pytest.approx(chi2.ppf(0.975, 15) / 5, rel=1e-12)]
    assert (s["share_inside_band"], s["share_below_band"], s["share_above_band"]) == (0.6, 0.2, 0.2)
    assert s["time_average"] == pytest.approx(33.1 / 5) and s["time_average_inside_band"] is False
    assert s["dof"] == 3 and s["probability"] == 0.95


def test_negative_control_a_covariance_100x_too_small():
    rng = np.random.default_rng(7)
    P = np.array([[0.5, 0.1, 0.01], [0.1, 2.0, -0.02], [0.01, -0.02, 0.01]])
    covs = np.tile(P, (2000, 1, 1))
    true = np.zeros((2000, 3))
    est = rng.multivariate_normal(np.zeros(3), P, size=2000)
    good, bad = pose_nees_summary(est, covs, true), pose_nees_summary(est, covs / 100.0, true)
    np.testing.assert_allclose(bad["per_scan"], 100.0 * good["per_scan"], rtol=1e-9)
    assert abs(good["share_inside_band"] - 0.95) < 0.02 and good["time_average_inside_band"]
    assert bad["share_inside_band"] < 0.2 and bad["share_above_band"] > 0.8 and not bad["time_average_inside_band"]


def test_components_by_hand_along_across_and_heading():
    """A car heading 90 deg (north) 2 m ahead of its truth and 1 m to its left, with a covariance of
    4 m^2 east, 1 m^2 north: along the heading (north) 2^2 / 1, across (west) 1^2 / 4; the heading
    0.1 rad off with 0.04 rad^2: 0.25. A 100x too small covariance (negative control) gives 100x each."""
    est = np.array([[-1.0, 2.0, math.pi / 2 + 0.1]])
    true = np.array([[0.0, 0.0, math.pi / 2]])
    covs = np.array([np.diag([4.0, 1.0, 0.04])])
    c = pose_nees_summary(est, covs, true)["components"]
    assert c["along_track"]["time_average"] == pytest.approx(4.0, rel=1e-12)
    assert c["cross_track"]["time_average"] == pytest.approx(0.25, rel=1e-12)
    assert c["heading"]["time_average"] == pytest.approx(0.25, rel=1e-12)
    assert c["along_track"]["rms_error"] == pytest.approx(2.0) and c["cross_track"]["rms_std"] == pytest.approx(2.0)
    assert c["heading"]["rms_error"] == pytest.approx(math.degrees(0.1))
    assert c["along_track"]["band_time_average"] == [pytest.approx(chi2.ppf(0.025, 1)), pytest.approx(chi2.ppf(0.975, 1))]
    bad = pose_nees_summary(est, covs / 100.0, true)["components"]
    for k in ("along_track", "cross_track", "heading"):
        assert bad[k]["time_average"] == pytest.approx(100.0 * c[k]["time_average"], rel=1e-12)


def test_components_of_a_consistent_filter_are_near_one():
    """Errors drawn from the covariance (correlated, headings all round): each 1-dof time average
    within its 95% band over 2000 scans, i.e. [0.94, 1.06] (chi2(2000)/2000)."""
    rng = np.random.default_rng(11)
    P = np.array([[0.5, 0.2, 0.01], [0.2, 2.0, -0.02], [0.01, -0.02, 0.01]])
    true = np.column_stack([np.zeros(2000), np.zeros(2000), rng.uniform(-math.pi, math.pi, 2000)])
    est = true + rng.multivariate_normal(np.zeros(3), P, size=2000)
    c = pose_nees_summary(est, np.tile(P, (2000, 1, 1)), true)["components"]
    for k, v in c.items():
        lo, hi = v["band_time_average"]
        assert lo <= v["time_average"] <= hi, (k, v)


def test_a_zero_covariance_is_an_exact_pose_left_out():
    """The anchored frame's first pose (docs/method.md b.5.1): P = 0 with a truth of std 0 has no NEES."""
    covs = np.stack([np.zeros((3, 3)), np.eye(3)])
    s = pose_nees_summary(np.ones((2, 3)) * [[0.0], [1.0]], covs, np.zeros((2, 3)))
    assert np.isnan(s["per_scan"][0]) and s["per_scan"][1] == pytest.approx(3.0)
    assert s["scans"] == 1 and s["exact_pose_scans"] == 1


@pytest.mark.parametrize("row, says", [
    ([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r"^pose_covs\[2\]: expected a symmetric covariance, got "),
    (np.diag([1.0, -1.0, 1.0]), r"^pose_covs\[2\]: expected a positive definite covariance, got eigenvalues -1, 1, 1$"),
    ([[1.0, 1.0, 0.0], [1.0, 1.0, 0.0], [0.0, 0.0, 1.0]], r"^pose_covs\[2\]: expected a positive definite covariance"),
    (np.diag([1.0, np.nan, 1.0]), r"^pose_covs\[2\]: expected a finite covariance, got NaN or inf$"),
])
def test_a_covariance_not_symmetric_positive_definite_is_refused_in_one_line(row, says):
    covs = np.tile(np.eye(3), (4, 1, 1))
    covs[2] = row
    with pytest.raises(InputError, match=says) as info:
        pose_nees_summary(np.zeros((4, 3)), covs, np.zeros((4, 3)))
    assert "\n" not in str(info.value)


def test_the_covariance_refused_is_the_sum_with_the_truths_std():
    covs = np.stack([np.eye(3), np.eye(3), -np.eye(3), np.eye(3)])
    with pytest.raises(InputError, match=r"^pose_covs \+ diag\(truth_std\^2\)\[2\]: expected a positive definite"):
        pose_nees_summary(np.zeros((4, 3)), covs, np.zeros((4, 3)), truth_std=(0.1, 0.1, 0.1))
    covs[2] = np.diag([0.0, 0.0, 1.0])              # singular alone, definite with the truth's std
    s = pose_nees_summary(np.zeros((4, 3)), covs, np.zeros((4, 3)), truth_std=(0.1, 0.1, 0.0))
    assert s["scans"] == 4
    true = np.zeros((4, 3))
    true[2] = np.nan                                # a scan without a truth is not checked
    covs[2] = -np.eye(3)
    assert pose_nees_summary(np.zeros((4, 3)), covs, true)["scans"] == 3


@pytest.mark.parametrize("kw, says", [
    ({"truth_std": (0.1, -0.1, 0.0)},
     r"^truth_std: expected 3 values >= 0 \[x_m, y_m, theta_rad\], got \[0\.1, -0\.1, 0\.0\]$"),
    ({"covs": np.tile(np.eye(2), (4, 1, 1))},
     r"^estimated, true, pose_covs: expected shapes \(K, 3\), \(K, 3\), \(K, 3, 3\)"),
    ({"prob": 1.0}, r"^prob: expected a probability in \(0, 1\), got 1\.0$"),
])
def test_bad_arguments_refused_in_one_line(kw, says):
    args = {"estimated": np.zeros((4, 3)), "covs": np.tile(np.eye(3), (4, 1, 1)), "true": np.zeros((4, 3)), **kw}
    with pytest.raises(InputError, match=says):
        pose_nees_summary(**args)


def test_the_alignment_turns_the_covariance_with_the_pose():
    """The NEES after ``se2`` does not depend on the frame the estimate came in: poses moved by a rigid
    motion and covariances turned with them give the same NEES as the unmoved ones."""
    rng = np.random.default_rng(3)
    K = 40
    true = np.column_stack([np.linspace(0, 30, K), 5 * np.sin(np.linspace(0, 3, K)), np.linspace(0, 2, K)])
    covs = np.array([np.diag([0.2, 0.05, 0.001]) + 0.01 * k * np.diag([1.0, 1.0, 0.0]) for k in range(K)])
    est = true + np.array([rng.multivariate_normal(np.zeros(3), c) for c in covs])
    a = 0.7
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    J = np.eye(3)
    J[:2, :2] = R
    moved, turned = transform(est, R, np.array([100.0, -40.0])), J @ covs @ J.T
    ref = trajectory_nees(est, covs, true, "se2")["per_scan"]
    np.testing.assert_allclose(trajectory_nees(moved, turned, true, "se2")["per_scan"], ref, rtol=1e-7)
    wrong = trajectory_nees(moved, covs, true, "se2")["per_scan"]        # the covariance left unturned
    assert np.max(np.abs(wrong / ref - 1.0)) > 0.1
    np.testing.assert_allclose(trajectory_nees(est, covs, true)["per_scan"],
                               pose_nees_summary(est, covs, true)["per_scan"], rtol=0)


def test_the_ackermann_lever_moves_the_covariance_by_its_jacobian():
    cfg = profile_config("apsipa")
    cfg = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, motion_model="ackermann"))
    poses = np.array([[1.0, 2.0, 0.3], [-4.0, 0.5, 2.5]])
    h = 1e-6
    for k, p in enumerate(poses):
        J = np.column_stack([(filter_to_platform((p + h * np.eye(3)[i])[None], cfg)[0]
                              - filter_to_platform((p - h * np.eye(3)[i])[None], cfg)[0]) / (2 * h) for i in range(3)])
        P = np.diag([0.1, 0.2, 0.01]) + 0.01
        np.testing.assert_allclose(filter_cov_to_platform(p[None], P[None], cfg)[0], J @ P @ J.T, rtol=1e-6)
    assert not np.allclose(J, np.eye(3))
    plain = profile_config("apsipa")
    np.testing.assert_array_equal(filter_cov_to_platform(poses, np.tile(np.eye(3), (2, 1, 1)), plain),
                                  np.tile(np.eye(3), (2, 1, 1)))


# ------------------------------------------------------------------------------------------------
# A recording run (runs/recording.py, runs/recording_outputs.py)
# ------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def recordings(tmp_path_factory) -> dict[str, Path]:
    """A 2 s drive past point reflectors with radar noise (0.5 m, 0.02 rad: the filter's NEES mostly inside
    its band), with and without its truth."""
    root = tmp_path_factory.mktemp("nees")
    rec = synthetic_recording(duration_s=2.0, turn_rate_rad_s=0.1, range_std_m=0.5, azimuth_std_rad=0.02,
                              rng=np.random.default_rng(1))
    out = {}
    for name, r in (("truth", rec), ("no_truth", dataclasses.replace(rec, truth_t=None, truth=None))):
        out[name] = root / name
        out[name].mkdir()
        write_plain(r, out[name])
    return out


@pytest.fixture(scope="module")
def truth_run(recordings, tmp_path_factory):
    from radarslam.runs.recording import run_recording, write_recording_outputs

    run = run_recording(read_plain(recordings["truth"]), profile_config("apsipa"))
    out = tmp_path_factory.mktemp("out")
    names = write_recording_outputs(out, run, {})
    return run, out, names


def test_trajectory_csv_carries_the_records_covariances(truth_run):
    run, out, _ = truth_run
    t = _table(out / "trajectory.csv")
    assert list(t) == ["k", "t", "x", "y", "theta", "x_true", "y_true", "theta_true", *POSE_COV_COLUMNS]
    P = run.record.pose_covs
    assert P.shape == (run.times.size, 3, 3) and np.all(P[:, 0, 0] > 0)
    for col, (i, j) in zip(POSE_COV_COLUMNS, [(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)]):
        np.testing.assert_array_equal(t[col], P[:, i, j], err_msg=col)     # repr: the floats to the bit
    np.testing.assert_array_equal(t["x"], run.record.poses[:, 0])
    tum = (out / "trajectory_tum.txt").read_text().splitlines()
    assert len(tum) == run.times.size and all(len(line.split()) == 8 for line in tum)   # as before: t x y z q


def test_metrics_json_nees_equals_the_hand_computed_one(truth_run):
    run, out, names = truth_run
    m = json.loads((out / "metrics.json").read_text())
    n = m["pose_nees"]
    std = np.array(run.config.filter.truth_pose_std)
    assert n["truth_std_added"]["from"] == "filter.truth_pose_std" and n["truth_std_added"]["std"] == list(std)
    e = run.record.poses - run.truth                     # the truth interpolated at the scan times; align none
    e[:, 2] = (e[:, 2] + math.pi) % (2 * math.pi) - math.pi
    hand = _hand_nees(e, run.record.pose_covs + np.diag(std ** 2))
    np.testing.assert_allclose(n["per_scan"], hand, rtol=1e-9)
    # the same errors as the RMSE's
    assert math.sqrt(np.mean(e[:, 0] ** 2 + e[:, 1] ** 2)) == pytest.approx(m["position_rmse_m"], rel=1e-12)
    K = run.times.size
    assert n["scans"] == K and n["time_average"] == pytest.approx(hand.mean(), rel=1e-9)
    assert n["band_per_scan"] == pytest.approx([LO3, HI3], rel=1e-12)
    assert n["band_time_average"] == pytest.approx([chi2.ppf(0.025, 3 * K) / K, chi2.ppf(0.975, 3 * K) / K], rel=1e-12)
    assert n["share_inside_band"] == pytest.approx(np.mean((hand >= LO3) & (hand <= HI3)))
    assert n["alignment"] == "none" and "per_scan" in n["definitions"]
    if "map.png" in names:                               # with matplotlib: the figure beside the map
        assert "nees.png" in names and (out / "nees.png").read_bytes()[:8] == PNG


def test_negative_control_on_the_run_a_covariance_100x_too_small(truth_run):
    from radarslam.runs.recording_outputs import pose_nees_metrics

    run, _, _ = truth_run
    cfg = dataclasses.replace(run.config, filter=dataclasses.replace(run.config.filter, truth_pose_std=[0.0] * 3))
    good = pose_nees_metrics(run.record.poses, run.record.pose_covs, run.truth, cfg, "none")
    bad = pose_nees_metrics(run.record.poses, run.record.pose_covs / 100.0, run.truth, cfg, "none")
    np.testing.assert_allclose(bad["per_scan"], 100.0 * good["per_scan"], rtol=1e-9)
    assert good["share_inside_band"] >= 0.5 and bad["share_inside_band"] < good["share_inside_band"] - 0.4
    assert bad["share_above_band"] > good["share_above_band"] + 0.4
    assert bad["time_average"] == pytest.approx(100.0 * good["time_average"], rel=1e-9)
    refused = pose_nees_metrics(run.record.poses, -run.record.pose_covs, run.truth, cfg, "none")
    assert refused == {"error": refused["error"]} and "expected a positive definite covariance" in refused["error"]


def test_no_truth_no_nees_and_no_plot_no_figures(recordings, tmp_path, capsys):
    out = tmp_path / "no_truth"
    assert main(["run", "--recording", str(recordings["no_truth"]), "--out", str(out)]) == 0
    m = json.loads((out / "metrics.json").read_text())
    assert "pose_nees" not in m and not (out / "nees.png").exists()
    assert list(_table(out / "trajectory.csv"))[5:] == list(POSE_COV_COLUMNS)     # the covariance still
    quiet = tmp_path / "no_plot"
    assert main(["run", "--recording", str(recordings["truth"]), "--no-plot", "--out", str(quiet)]) == 0
    assert "pose_nees" in json.loads((quiet / "metrics.json").read_text())
    assert not list(quiet.glob("*.png"))
    capsys.readouterr()
