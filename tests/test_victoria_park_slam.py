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
from consistency_bounds import nees_band, nees_upper_bound, share_band, share_lower_bound, share_upper_bound

from radarslam.config import profile_config
from radarslam.runs.dataset import (NIS_BAND_PROBABILITY, TWO_SIGMA_PROBABILITY, compare_tree_diameters, dead_reckoning,
                                    evaluate_against_gps, run_dataset)

N_SCANS = 500
RMSE_BOUND_500 = 1.3


def nis_upper_bounds(n: int) -> tuple[float, float]:
    """One-sided bounds of a run's NIS (:func:`~radarslam.runs.dataset.nis_fraction`: one 2-dof NIS
    per update, ``n`` of them) that a filter that is not overconfident meets: the share of updates
    above the per-update band's top (probability 0.025 each) at most the upper 1% quantile of
    Binomial(n, 0.025) / n, and the mean at most the upper 1% quantile of chi2(2 n) / n. A consistent
    filter's innovations are white, so its n NIS values are independent."""
    return share_upper_bound(n, (1.0 - NIS_BAND_PROBABILITY) / 2.0), nees_upper_bound(2, n, 0.99)


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
    # the NIS not overconfident (measured at 150 scans: n = 1259, 0.1% above the band, mean 0.17);
    # its two-sided band is missed on this data (test_first_500_scans_nis_lies_in_its_chi_square_band)
    above_max, mean_max = nis_upper_bounds(m["nis"]["n"])
    assert m["nis"]["above"] <= above_max and m["nis"]["mean"] <= mean_max, m["nis"]
    assert m["nis"]["band"] == pytest.approx([0.0506, 7.3778], abs=1e-3)
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
    above_max, mean_max = nis_upper_bounds(nis["n"])                # not overconfident (the sanity bound)
    assert nis["n"] > 1000 and nis["above"] <= above_max and nis["mean"] <= mean_max, (mode, nis)
    if mode == "trees":   # one detection per trunk and scan: fewer landmarks, no extents
        assert run.final_map.ids.size < 70 and np.all(np.isnan(run.final_map.rma))


@pytest.mark.xfail(strict=True, reason="measured over 500 scans: mean NIS 0.19 (trees, n = 2971) and 0.48 (laser, "
                                       "n = 3915) against the band of chi2(2 n) / n [1.91, 2.10] and [1.92, 2.08]; "
                                       "share inside the per-update 95% band 0.62 and 0.64 against [0.94, 0.96]: "
                                       "the profiles associate and update with n_c R (measurement_corr_scans 5.9 "
                                       "and 11, docs/method.md c.11.9), so most NIS fall below the band")
def test_first_500_scans_nis_lies_in_its_chi_square_band(published500):
    """A consistent filter's NIS (2 dof per update, n independent updates): the mean within the
    two-sided 99% band of chi2(2 n) / n and the share inside the per-update 95% band within the
    two-sided 99% band of Binomial(n, 0.95) / n."""
    from radarslam.runs.dataset import nis_fraction

    mode, run = published500
    nis = nis_fraction(run)
    lo, hi = nees_band(2, nis["n"], 0.99)
    a, b = share_band(nis["n"], NIS_BAND_PROBABILITY, 0.99)
    assert lo <= nis["mean"] <= hi and a <= nis["inside"] <= b, (mode, nis["mean"], (lo, hi), nis["inside"], (a, b))


@pytest.mark.parametrize("mode", ["trees", "laser"])
def test_an_overconfident_radar_model_fails_the_nis_bound(victoria_park_dir, mode):
    """Negative control of the NIS bound above: the profile told the sensor 10 times more precise
    than it is (range and azimuth stds / 10), on the same 500 scans, has far more updates above the
    band's top and a mean NIS above the bound (measured: 21% and 4.5 trees, 33% and 9.9 laser)."""
    import dataclasses

    from radarslam.io.datasets.victoria_park import INPUT_PROFILES, PUBLISHED_START
    from radarslam.runs.dataset import nis_fraction

    cfg = profile_config(INPUT_PROFILES[mode])
    f = cfg.filter
    cfg = dataclasses.replace(cfg, filter=dataclasses.replace(f, initial_pose=list(PUBLISHED_START),
                                                              range_std_m=f.range_std_m / 10,
                                                              azimuth_std_deg=f.azimuth_std_deg / 10))
    run = run_dataset("victoria-park", victoria_park_dir, cfg, n_scans=N_SCANS, progress=False,
                      loader_options={"input": mode})
    nis = nis_fraction(run)
    above_max, mean_max = nis_upper_bounds(nis["n"])
    assert nis["above"] > above_max and nis["mean"] > mean_max, (mode, nis["above"], nis["mean"])


#: The position consistency of the published protocol at the 71 scans at a GPS fix. The errors of
#: consecutive fixes are correlated (the GPS's slowly varying error and the map's drift: the east
#: error's correlation is about 0.8 between fixes within 5 s and the north error keeps its sign over
#: the 77 s), and no correlation time shorter than the 77 s can be read from these 71 fixes, so no
#: smaller effective n is justified: the bounds below assume the 71 independent (a correlated
#: sample spreads more, so they are narrower than the truth's).
N_FIXES_500 = 71


def test_first_500_scans_position_bound_contains_the_gps_error(published500):
    """docs/method.md v.7: over the first 500 scans the filter's 2-sigma bound with the GPS's own 1 m
    (this fix and the first) contains the error: the share inside the 95.45% ellipse is at least the
    lower 1% quantile of Binomial(n, 0.9545) / n (0.887 at n = 71), the share inside both axes'
    2-sigma intervals at least that of Binomial(n, 0.9545^2) / n (0.831; two correlated Gaussian
    axes are both inside with a probability at least the product, Sidak), and the mean squared
    Mahalanobis distance (2 dof) at most the upper 1% quantile of chi2(2 n) / n (2.59). Measured: all
    71 inside in both modes, mean 1.00 trees, 1.16 laser. Negative controls: the filter's covariance
    alone contains the error at almost none (the first fix's error is a translation it omits); the
    GPS's std stated 10 times too small (0.1 m) leaves both shares and the mean outside their bounds
    (measured 0.10, 0.08 and 65 trees, 81 laser)."""
    from radarslam.runs.dataset import evaluate_published, position_consistency

    mode, run = published500
    pub = evaluate_published(run)
    c = position_consistency(run, pub)
    n = c["n"]
    assert n == N_FIXES_500 and c["gps_std_m"] == 1.0
    ellipse_min, both_min = share_lower_bound(n, TWO_SIGMA_PROBABILITY), share_lower_bound(n, TWO_SIGMA_PROBABILITY ** 2)
    mean_max = nees_upper_bound(2, n, 0.99)
    assert c["inside_ellipse"] >= ellipse_min and c["inside_both"] >= both_min, (mode, c["inside_ellipse"], c["inside_both"])
    assert 0.5 < c["mean_mahalanobis2"] <= mean_max, (mode, c["mean_mahalanobis2"])
    assert c["inside_both_filter_only"] <= 0.2, (mode, c["inside_both_filter_only"])
    bad = position_consistency(run, pub, gps_std_m=0.1)
    assert bad["inside_ellipse"] < ellipse_min and bad["inside_both"] < both_min, (mode, bad["inside_ellipse"])
    assert bad["mean_mahalanobis2"] > mean_max, (mode, bad["mean_mahalanobis2"])


@pytest.mark.xfail(strict=True, reason="measured over 500 scans: mean squared Mahalanobis distance 1.00 (trees) and "
                                       "1.16 (laser) against the band of chi2(142) / 71 [1.44, 2.66]: the GPS's "
                                       "stated 1 m (not a fitted value, docs/method.md v.7) is larger than its "
                                       "error on these fixes, and the 71 fixes are correlated (N_FIXES_500)")
def test_first_500_scans_position_mahalanobis_lies_in_its_chi_square_band(published500):
    """The mean squared Mahalanobis distance of the GPS error (2 dof, n fixes taken as independent)
    within the two-sided 99% band of chi2(2 n) / n."""
    from radarslam.runs.dataset import evaluate_published, position_consistency

    mode, run = published500
    c = position_consistency(run, evaluate_published(run))
    lo, hi = nees_band(2, c["n"], 0.99)
    assert lo <= c["mean_mahalanobis2"] <= hi, (mode, c["mean_mahalanobis2"], lo, hi)


@pytest.mark.slow
def test_sensitivity_script_at_reduced_size(victoria_park_dir, monkeypatch):
    """scripts/victoria_park_sensitivity.py at --scans 500 (its main, every row, trees): the profile
    row is the 500-scan figure above (1.426 m), each row's figures are finite and the rows differ
    (R and U change the run), and each row's NIS (its nis_fraction, recorded as the script calls it)
    is not overconfident (:func:`nis_upper_bounds`; measured at most 0.3% of the updates above the
    band's top and a mean at most 0.53, R x0.5, against about 3% and 2.1). Measured: profile 1.43,
    R x0.5 1.51, R x2 1.26, U x0.5 1.34, U x2 1.51, laser time -50 ms 1.39 m."""
    import importlib.util
    from pathlib import Path

    from radarslam.runs import dataset

    nis_of = []
    nis_fraction = dataset.nis_fraction

    def recorded(run, **kw):
        nis_of.append(nis_fraction(run, **kw))
        return nis_of[-1]

    monkeypatch.setattr(dataset, "nis_fraction", recorded)
    spec = importlib.util.spec_from_file_location(
        "vp_sens", Path(__file__).resolve().parents[1] / "scripts" / "victoria_park_sensitivity.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    rows, nis = {}, {}
    for n in mod.VARIANTS:
        rows[n] = mod.run_variant(n, "trees", victoria_park_dir, N_SCANS, "numba")
        nis[n] = nis_of[-1]
    base = rows["profile"]
    assert base["published_rmse_m"] == pytest.approx(1.426, abs=0.01)
    assert base["first_half_rmse_m"] == pytest.approx(base["published_rmse_m"])
    for name, r in rows.items():
        assert np.isfinite(r["published_rmse_m"]) and np.isnan(r["second_half_rmse_m"]), r
        assert 0.0 <= r["inside_2sigma"] <= 1.0 and r["nis_inside"] == nis[name]["inside"]
        above_max, mean_max = nis_upper_bounds(nis[name]["n"])
        assert nis[name]["above"] <= above_max and nis[name]["mean"] <= mean_max, (name, nis[name])
    assert len({round(r["published_rmse_m"], 9) for r in rows.values()}) >= 4


def test_sensitivity_script_lays_a_candidate_under_the_variants(victoria_park_dir):
    """scripts/victoria_park_sensitivity.py's overlay (``--config``, c.11.7): a candidate's keys are
    laid over the profile before the variant's change. Under FEJ the JCBB row runs with the standard
    Jacobians (its event-by-event form has no first estimates), so it equals the JCBB row without the
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
