"""EKF-SLAM with extents on the real Victoria Park data: the first 500 scans against GPS, the trunk
diameters against ACFR's detector, and the CLI end to end.

Needs ``../shared/data/victoria_park``: skips locally without it, FAILS under CI (``CI`` set).

The bound on the 500-scan GPS-aligned RMSE (``RMSE_BOUND_500``) was measured, not guessed:

- the victoria-park profile gives 1.046 m over the first 500 scans (1.040 m since its associator is
  the per-landmark batch update) (302 GPS fixes, 100 s of
  driving; the same under the python and numba backends);
- odometry alone through the same Ackermann model gives 1.507 m over the same fixes;
- the GPS's own white jitter is only about 0.1 m per axis (robust std of second differences of
  consecutive 5 Hz fixes), so most of the 1 m is slowly varying GPS error and map-relative drift.

The bound, 1.3 m, lies between the two: it fails if SLAM loses a quarter of its accuracy or no
longer beats odometry, and the odometry-only track is asserted to exceed it (negative control).
"""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.runs.dataset import compare_tree_diameters, dead_reckoning, evaluate_against_gps, run_dataset

N_SCANS = 500
RMSE_BOUND_500 = 1.3


@pytest.fixture(scope="module")
def run500(victoria_park_dir):
    return run_dataset("victoria-park", victoria_park_dir, profile_config("victoria-park"), n_scans=N_SCANS,
                       progress=False)


def test_first_500_scans_beat_odometry_and_stay_below_the_bound(run500):
    ev = evaluate_against_gps(run500)
    dr = evaluate_against_gps(run500, dead_reckoning(run500.data, run500.config)[1])
    assert ev["n_fixes"] >= 290
    assert ev["rmse_m"] < RMSE_BOUND_500, ev["rmse_m"]
    assert ev["max_m"] < 2.5
    # negative control: odometry alone does not meet the bound
    assert dr["rmse_m"] > RMSE_BOUND_500, dr["rmse_m"]
    # a healthy map: the trunks along 100 s of driving, not a landmark per detection
    assert 60 <= run500.final_map.ids.size <= 130
    assert np.all(np.isfinite(run500.poses)) and np.all(np.isfinite(run500.final_map.positions))
    assert np.all(np.linalg.eigvalsh(run500.pose_covs) > 0)
    assert np.median(run500.n_associated) >= 5


def test_trunk_diameters_agree_with_acfr_detector(run500):
    # measured, visible-arc (the profile's estimator, docs/method.md a.9): 47 matched, median |diff|
    # 0.015 m, median ratio 1.01, Spearman 0.99 (ACFR median 0.48 m); its RMA baseline 0.124 m and
    # 0.68. The full-run targets (0.08 m, 0.7) are asserted here on the first 500 scans, and
    # the RMA baseline is asserted NOT to meet them (what the visible-arc model fixes).
    c = compare_tree_diameters(run500)
    assert c["estimator"] == "visible-arc" and c["n_matched"] >= 40
    assert c["median_abs_diff_m"] < 0.08
    assert 0.9 < c["median_ratio"] < 1.1
    assert c["spearman"] > 0.7
    assert c["baseline_median_abs_diff_m"] > 0.08
    # negative control: shuffling the pairing destroys the agreement
    rng = np.random.default_rng(0)
    shuffled = rng.permutation(c["reference_m"])
    from scipy.stats import spearmanr

    assert abs(spearmanr(c["estimate_m"], shuffled).statistic) < 0.3


def test_cli_run_dataset_writes_every_output(victoria_park_dir, tmp_path):
    out = tmp_path / "vp"
    r = subprocess.run([sys.executable, "-m", "radarslam", "run", "--dataset", "victoria-park", str(victoria_park_dir),
                        "--scans", "150", "--out", str(out)], capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert "GPS-aligned RMSE" in r.stdout
    for f in ["trajectory.csv", "trajectory_tum.txt", "map.json", "metrics.json", "config.toml", "run.json", "map.png"]:
        assert (out / f).stat().st_size > 0, f
    tum = np.loadtxt(out / "trajectory_tum.txt")
    assert tum.shape == (150, 8)
    np.testing.assert_allclose(np.linalg.norm(tum[:, 4:], axis=1), 1.0, atol=1e-9)  # unit quaternions
    m = json.loads((out / "metrics.json").read_text())
    assert m["scans"] == 150 and m["gps_aligned_rmse_m"] < m["odometry_only_rmse_m"] + 0.5
    assert m["landmarks_final"] == len(json.loads((out / "map.json").read_text())["landmarks"])
    assert 'profile = "victoria-park"' in (out / "config.toml").read_text()
    assert (out / "errors.png").stat().st_size > 0 and m["input"] == "laser"
    assert 0.0 < m["nis"]["inside"] <= 1.0 and m["nis"]["band"] == pytest.approx([0.0506, 7.3778], abs=1e-3)
    assert m["duplicated_trunks"]["n_pairs"] >= 0 and m["trunk_diameters"]["estimator"] == "visible-arc"
    assert m["odometry_bias"] is None and not (out / "bias.csv").exists()       # filter.odometry_bias "none"


def test_cli_run_dataset_tree_input_published(victoria_park_dir, tmp_path):
    out = tmp_path / "vpt"
    r = subprocess.run([sys.executable, "-m", "radarslam", "run", "--dataset", "victoria-park", str(victoria_park_dir),
                        "--input", "trees", "--protocol", "published", "--scans", "300", "--out", str(out)],
                       capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    m = json.loads((out / "metrics.json").read_text())
    assert m["input"] == "trees" and m["scans"] == 300 and m["trunk_diameters"] is None
    assert m["published_rmse_m"] < 2.0 and m["published_scans_matched"] > 30      # measured 1.4-1.6 m
    assert 'profile = "victoria-park-trees"' in (out / "config.toml").read_text()
    assert (out / "errors.png").stat().st_size > 0 and "NIS of" in r.stdout
    c = m["consistency"]                          # docs/method.md v.7: the published protocol's bound
    assert c["n"] == m["published_scans_matched"] and c["gps_std_m"] == 1.0
    assert c["inside_both"] >= 0.95 and c["inside_both_filter_only"] <= 0.2
    assert (out / "consistency.png").stat().st_size > 0 and "2-sigma bound" in r.stdout


def test_cli_run_dataset_bad_inputs(victoria_park_dir, tmp_path):
    def run(*a):
        return subprocess.run([sys.executable, "-m", "radarslam", "run", *a, "--out", str(tmp_path / "o")],
                              capture_output=True, text=True, timeout=120)

    r = run("--dataset", "no-such-set", str(victoria_park_dir))
    assert r.returncode != 0 and "--dataset" in r.stderr and "victoria-park" in r.stderr
    r = run("--dataset", "victoria-park", str(tmp_path / "missing"))
    assert r.returncode != 0 and "directory not found" in r.stderr
    assert "Traceback" not in r.stderr


def test_published_protocol_run_can_be_recomputed_from_its_tum_file(victoria_park_dir, tmp_path):
    """--protocol published: the estimate starts at the first GPS fix in the GPS frame; the TUM file
    (GPS frame, MAT time base in seconds) and the raw fixes give the reported RMSE with a few lines
    of numpy, as anyone could recompute it; --first-scan is refused."""
    import math

    import scipy.io

    from radarslam.cli.main import main
    from radarslam.io.datasets import victoria_park as vp

    out = tmp_path / "pub"
    assert main(["run", "--dataset", "victoria-park", str(victoria_park_dir), "--scans", "300", "--protocol",
                 "published", "--backend", "numba", "--no-plot", "--out", str(out)]) == 0
    m = json.loads((out / "metrics.json").read_text())
    tum = np.loadtxt(out / "trajectory_tum.txt")
    assert tum[0, 1:3] == pytest.approx(vp.PUBLISHED_START[:2], abs=1e-6)
    assert 2 * math.atan2(tum[0, 6], tum[0, 7]) == pytest.approx(vp.PUBLISHED_START[2], abs=1e-6)
    g = scipy.io.loadmat(victoria_park_dir / vp.FILE_GPS)
    gt = g["timeGps"].ravel() / 1000.0                           # the MAT time base, seconds
    gxy = np.column_stack([g["Lo_m"].ravel(), g["La_m"].ravel()])
    j = np.abs(tum[:, :1] - gt[None, :]).argmin(axis=1)
    ok = np.abs(tum[:, 0] - gt[j]) <= 0.025 + 1e-6               # stamps on a ms grid: ties are within
    rmse = math.sqrt(np.mean(np.sum((tum[ok, 1:3] - gxy[j[ok]]) ** 2, axis=1)))
    assert ok.sum() == m["published_scans_matched"] > 30
    assert rmse == pytest.approx(m["published_rmse_m"], rel=1e-6)
    assert m["published_rmse_m"] < 3.0                           # 300 scans: measured 1.3-1.7 m
    assert main(["run", "--dataset", "victoria-park", str(victoria_park_dir), "--first-scan", "5", "--protocol",
                 "published", "--out", str(tmp_path / "no")]) == 1


# ------------------------------------------------------------------ tree-detection input, published protocol
#: Measured on the first 500 scans from the published start (71 scans within 25 ms of a GPS fix):
#: the victoria-park-trees profile gives 1.426 m (its white-noise predecessor 1.495 m), the raw-laser profile
#: 1.634 m, and odometry alone through the same Ackermann model 2.662 m. The bound, 2.0 m, fails if
#: either mode loses a third of its accuracy or stops beating odometry, which is asserted to exceed it.
PUBLISHED_BOUND_500 = 2.0


@pytest.fixture(scope="module", params=["trees", "laser"])
def published500(request, victoria_park_dir):
    import dataclasses

    from radarslam.io.datasets.victoria_park import PUBLISHED_START

    mode = request.param
    from radarslam.io.datasets.victoria_park import INPUT_PROFILES

    cfg = profile_config(INPUT_PROFILES[mode])
    cfg = dataclasses.replace(cfg, filter=dataclasses.replace(cfg.filter, initial_pose=list(PUBLISHED_START)))
    return mode, run_dataset("victoria-park", victoria_park_dir, cfg, n_scans=N_SCANS, progress=False,
                             loader_options={"input": mode})


def test_first_500_scans_published_protocol_each_input_mode(published500):
    from radarslam.runs.dataset import evaluate_published, nis_fraction

    mode, run = published500
    pub = evaluate_published(run)
    odo = evaluate_published(run, dead_reckoning(run.data, run.config)[1])
    assert pub["n_matched"] == odo["n_matched"] == 71
    assert pub["rmse_m"] < PUBLISHED_BOUND_500, (mode, pub["rmse_m"])
    assert odo["rmse_m"] > PUBLISHED_BOUND_500, odo["rmse_m"]          # negative control
    nis = nis_fraction(run)
    assert nis["n"] > 1000 and 0.0 <= nis["inside"] <= 1.0
    if mode == "trees":   # one detection per trunk and scan: fewer landmarks, no extents
        assert run.final_map.ids.size < 70 and np.all(np.isnan(run.final_map.rma))


def test_first_500_scans_position_bound_contains_the_gps_error(published500):
    """docs/method.md v.7, measured: over the first 500 scans the filter's 2-sigma bound with the
    GPS's own 1 m (this fix and the first) contains the error at all 71 scans in both modes (mean
    squared Mahalanobis distance 1.00 trees, 1.33 laser; 2 expected); the filter's covariance alone
    contains it at none (negative control: the first fix's error is a translation it omits)."""
    from radarslam.runs.dataset import evaluate_published, position_consistency

    mode, run = published500
    c = position_consistency(run, evaluate_published(run))
    assert c["n"] == 71 and c["gps_std_m"] == 1.0
    assert c["inside_both"] >= 0.95 and c["inside_ellipse"] >= 0.95, (mode, c["inside_both"])
    assert c["inside_both_filter_only"] <= 0.2, (mode, c["inside_both_filter_only"])
    assert 0.5 < c["mean_mahalanobis2"] < 2.0


@pytest.mark.slow
def test_sensitivity_script_at_reduced_size(victoria_park_dir):
    """scripts/victoria_park_sensitivity.py at --scans 500 (its main, every row, trees): the profile
    row is the 500-scan figure above (1.426 m), each row's figures are finite and the rows differ
    (R and U change the run). Measured: profile 1.43, R x0.5 1.51, R x2 1.26, U x0.5 1.34, U x2 1.51,
    laser time -50 ms 1.39 m."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "vp_sens", Path(__file__).resolve().parents[1] / "scripts" / "victoria_park_sensitivity.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rows = {n: mod.run_variant(n, "trees", victoria_park_dir, N_SCANS, "numba") for n in mod.VARIANTS}
    base = rows["profile"]
    assert base["published_rmse_m"] == pytest.approx(1.426, abs=0.01)
    assert base["first_half_rmse_m"] == pytest.approx(base["published_rmse_m"])
    for r in rows.values():
        assert np.isfinite(r["published_rmse_m"]) and np.isnan(r["second_half_rmse_m"]), r
        assert 0.0 <= r["inside_2sigma"] <= 1.0 and 0.0 <= r["nis_inside"] <= 1.0
    assert len({round(r["published_rmse_m"], 9) for r in rows.values()}) >= 4


def test_sensitivity_script_lays_a_candidate_under_the_variants(victoria_park_dir):
    """scripts/victoria_park_sensitivity.py's overlay (``--config``, c.11.7): a candidate's keys are
    laid over the profile before the variant's change. Under FEJ the JCBB row runs with the standard
    Jacobians (its orchestrated form has no first estimates), so it equals the JCBB row without the
    candidate to the last digit, while the FEJ candidate's own row differs from the profile's (the
    overlay is applied: the negative control). 300 scans of the tree input."""
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "vp_sens", Path(__file__).resolve().parents[1] / "scripts" / "victoria_park_sensitivity.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    fej = {"filter": {"jacobians": "fej"}}
    plain = mod.run_variant("profile", "trees", victoria_park_dir, 300, "numba")
    cand = mod.run_variant("profile", "trees", victoria_park_dir, 300, "numba", fej)
    assert abs(cand["published_rmse_m"] - plain["published_rmse_m"]) > 1e-6
    j0 = mod.run_variant("associator jcbb", "trees", victoria_park_dir, 300, "numba")
    j1 = mod.run_variant("associator jcbb", "trees", victoria_park_dir, 300, "numba", fej)
    assert j1["published_rmse_m"] == j0["published_rmse_m"] and np.isfinite(j0["published_rmse_m"])
