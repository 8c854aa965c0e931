"""The Monte Carlo report: Table 1 with bootstrap intervals, Fig. 3 curves, Table II, NEES, files, CLI,
for any number of variants."""

from __future__ import annotations

import argparse
import csv
import json
import math
import re
import shutil
from dataclasses import replace

import numpy as np
import pytest
from conftest import require
from scipy.stats import chi2

from radarslam.config import profile_config
from radarslam.core.errors import InputError
from radarslam.montecarlo.trials import load_results, run_montecarlo
from radarslam.montecarlo.report import (GWD_KEY_STEPS, REPORT_CONVENTIONS, gwd_curves, landmark_table, nees_summary, table1, write_report)
from radarslam.config.variants import PAPER_VARIANTS, Variant
from radarslam.metrics.pose import avg_rmse, chi2_band
from radarslam.metrics.statistics import rmse_over_defined
from radarslam.viz import have_matplotlib

N_TRIALS, N_STEPS, SEED = 4, 40, 7
#: A third variant for the "any number of variants" tests.
NOSIFT = Variant("nosift", "With extent, no contour sifting", {"extent": {"use_in_slam": True, "contour_sifting": False}})


@pytest.fixture(scope="module")
def mc_dir(tmp_path_factory):
    """A real (short) Monte Carlo directory, built once for the module."""
    cfg = profile_config()
    cfg = replace(cfg, trajectory=replace(cfg.trajectory, n_steps=N_STEPS))
    out = tmp_path_factory.mktemp("mc")
    run_montecarlo(cfg, SEED, N_TRIALS, out, jobs=1, progress=False, log=lambda s: None, variants=PAPER_VARIANTS)
    return out


@pytest.fixture(scope="module")
def res(mc_dir):
    return load_results(mc_dir)


@pytest.fixture(scope="module")
def mc3_dir(tmp_path_factory):
    """A 3-variant Monte Carlo of 3 short trials with its report."""
    cfg = profile_config()
    cfg = replace(cfg, trajectory=replace(cfg.trajectory, n_steps=30))
    out = tmp_path_factory.mktemp("mc3")
    run_montecarlo(cfg, 3, 3, out, jobs=1, progress=False, log=lambda s: None, variants=PAPER_VARIANTS + (NOSIFT,))
    return out


@pytest.fixture(scope="module")
def report(mc_dir):
    return write_report(mc_dir, n_boot=300)


def synthetic_errors(rng, n_runs, sigma, rho=0.8, factor=0.9):
    """Paired per-run errors: "No extent" e = sigma_k z1, "With extent" factor sigma_k (rho z1 + ...).

    Both are N(0, sigma_k^2) up to ``factor``, so the true avg. RMSE is mean(sigma) and the true
    relative change is 100 (factor - 1) %.
    """
    z1 = rng.standard_normal((n_runs, len(sigma)))
    z2 = rng.standard_normal((n_runs, len(sigma)))
    a = z1 * sigma
    b = factor * (rho * z1 + math.sqrt(1.0 - rho * rho) * z2) * sigma
    return {"noext": {"position_error_m": np.abs(a), "heading_error_rad": a},
            "ext": {"position_error_m": np.abs(b), "heading_error_rad": b}}


def width(ci):
    return ci[1] - ci[0]


def check_markdown_table(text: str) -> list[list[str]]:
    """Assert ``text`` holds one valid GitHub table (header, delimiter row, equal cell counts)."""
    lines = [ln for ln in text.strip().splitlines() if ln.startswith("|")]
    assert len(lines) >= 3
    cells = [[c.strip() for c in re.split(r"(?<!\\)\|", ln)[1:-1]] for ln in lines]
    assert re.fullmatch(r"\|(\s*:?-{3,}:?\s*\|)+", lines[1])
    assert all(len(c) == len(cells[0]) for c in cells)
    return [cells[0]] + cells[2:]


# --------------------------------------------------------------------------------------------- Table 1


def test_table1_point_estimates_are_avg_rmse_of_the_stacked_errors(res):
    t1 = table1(res, n_boot=300)
    assert t1["n_runs"] == N_TRIALS
    for c in ("noext", "ext"):
        assert t1["position_avg_rmse_m"][c]["estimate"] == avg_rmse(res[c]["position_error_m"])
        assert t1["heading_avg_rmse_deg"][c]["estimate"] == avg_rmse(np.degrees(res[c]["heading_error_rad"]))
    for m in ("position_avg_rmse_m", "heading_avg_rmse_deg"):
        r = t1[m]
        ch = r["change_pct"]
        assert list(ch) == ["ext"]  # the baseline has no change against itself
        assert ch["ext"]["estimate"] == pytest.approx(100 * (r["ext"]["estimate"] / r["noext"]["estimate"] - 1),
                                                      rel=1e-12)
        for d in (r["noext"], r["ext"], ch["ext"]):
            lo, hi = d["ci"]
            assert lo <= d["estimate"] <= hi
    assert t1["variants"] == ["noext", "ext"] and t1["baseline"] == "noext"


def test_table1_is_reproducible_and_seeded():
    data = synthetic_errors(np.random.default_rng(0), 25, np.array([1.0, 2.0]))
    a, b, c = table1(data, 200, rng_seed=3), table1(data, 200, rng_seed=3), table1(data, 200, rng_seed=4)
    assert a == b
    assert a["position_avg_rmse_m"]["noext"]["ci"] != c["position_avg_rmse_m"]["noext"]["ci"]


def test_ci_is_narrower_with_more_trials():
    sigma = np.array([0.5, 1.0, 1.5])
    rng = np.random.default_rng(1)
    few = table1(synthetic_errors(rng, 10, sigma), 500)
    many = table1(synthetic_errors(rng, 250, sigma), 500)
    # Width ~ 1/sqrt(N): expect a factor ~5; ask for 2.
    for m in ("position_avg_rmse_m", "heading_avg_rmse_deg"):
        for path in (("noext",), ("ext",), ("change_pct", "ext")):
            a, b = many[m], few[m]
            for key in path:
                a, b = a[key], b[key]
            assert width(a["ci"]) < 0.5 * width(b["ci"])


def test_paired_change_interval_follows_the_pairing():
    """With "With extent" errors exactly 0.9 x "No extent" on every trial, every paired resample
    gives -10 %: the interval collapses, which an unpaired bootstrap would not do."""
    rng = np.random.default_rng(2)
    a = rng.standard_normal((30, 5))
    data = {"noext": {"position_error_m": np.abs(a), "heading_error_rad": a},
            "ext": {"position_error_m": 0.9 * np.abs(a), "heading_error_rad": 0.9 * a}}
    r = table1(data, 300)["position_avg_rmse_m"]["change_pct"]["ext"]
    assert r["estimate"] == pytest.approx(-10.0, abs=1e-9)
    np.testing.assert_allclose(r["ci"], [-10.0, -10.0], atol=1e-9)


def test_every_variant_gets_its_paired_change_against_the_first():
    """Three variants, the third exactly 0.8 x the first on every trial, the second independent noise:
    the third's paired change is -20 % with a collapsed interval; the second's interval covers its
    estimate; the baseline is whichever variant comes first."""
    rng = np.random.default_rng(8)
    a = rng.standard_normal((40, 5))
    b = rng.standard_normal((40, 5))
    data = {"variants": [{"name": "base", "label": "Base"}, {"name": "other", "label": "Other"},
                         Variant("scaled", "Scaled", {})],
            "base": {"position_error_m": np.abs(a), "heading_error_rad": a},
            "other": {"position_error_m": np.abs(b), "heading_error_rad": b},
            "scaled": {"position_error_m": 0.8 * np.abs(a), "heading_error_rad": 0.8 * a}}
    t1 = table1(data, 300)
    assert t1["variants"] == ["base", "other", "scaled"] and t1["baseline"] == "base"
    assert t1["labels"] == {"base": "Base", "other": "Other", "scaled": "Scaled"}
    for m in ("position_avg_rmse_m", "heading_avg_rmse_deg"):
        ch = t1[m]["change_pct"]
        assert list(ch) == ["other", "scaled"]
        assert ch["scaled"]["estimate"] == pytest.approx(-20.0, abs=1e-9)
        np.testing.assert_allclose(ch["scaled"]["ci"], [-20.0, -20.0], atol=1e-9)
        assert ch["other"]["ci"][0] <= ch["other"]["estimate"] <= ch["other"]["ci"][1]
        assert width(ch["other"]["ci"]) > 5.0
    # the same data with "scaled" first: the baseline moves and the change inverts (1 / 0.8 - 1 = +25 %)
    data["variants"] = data["variants"][::-1]
    t1r = table1(data, 300)
    assert t1r["baseline"] == "scaled"
    assert t1r["position_avg_rmse_m"]["change_pct"]["base"]["estimate"] == pytest.approx(25.0, abs=1e-9)


def test_bootstrap_ci_covers_the_true_value_95_percent_of_the_time():
    """Coverage over REPS independent synthetic Monte Carlos of N_RUNS runs.

    Each repetition is an independent Bernoulli(p) with p the true coverage, so the observed
    coverage has standard deviation sqrt(p (1 - p) / REPS) = 0.011 at p = 0.95, REPS = 400; the bound
    is 0.95 +- 3 sigma. The percentile bootstrap undercovers by O(1/N) (a variance-type statistic);
    at N_RUNS = 300 that bias is ~0.005 (0.943 measured offline over 2000 repetitions), well inside the
    bound. At N = 20-30 it would be ~0.9, which is why N_RUNS is not smaller.
    """
    n_runs, reps, n_boot = 300, 400, 400
    sigma = np.array([0.5, 1.0, 1.5, 2.0])
    true_rmse, true_change = float(sigma.mean()), -10.0
    rng = np.random.default_rng(2024)
    hit = hit_change = 0
    for i in range(reps):
        r = table1(synthetic_errors(rng, n_runs, sigma), n_boot, rng_seed=i)["position_avg_rmse_m"]
        hit += r["noext"]["ci"][0] <= true_rmse <= r["noext"]["ci"][1]
        hit_change += r["change_pct"]["ext"]["ci"][0] <= true_change <= r["change_pct"]["ext"]["ci"][1]
    tol = 3 * math.sqrt(0.95 * 0.05 / reps)
    assert abs(hit / reps - 0.95) < tol, hit / reps
    assert abs(hit_change / reps - 0.95) < tol, hit_change / reps


def test_table1_rejects_bad_input(res):
    with pytest.raises(InputError, match="n_boot"):
        table1(res, n_boot=0)
    with pytest.raises(InputError, match="res: expected a load_results dict with a 'ext' variant"):
        table1({"noext": res["noext"]})
    with pytest.raises(InputError, match="'noext' twice"):
        table1({"variants": ["noext", "noext"], "noext": res["noext"]})
    with pytest.raises(InputError, match="at least one"):
        table1({"variants": []})


# --------------------------------------------------------------------------------------------- Fig. 3


def _gwd_res():
    nan = np.nan
    K = 12
    ext_rma = np.array([[nan, 1, 2] + [2] * 9,
                        [nan, nan, 4] + [2] * 9,
                        [nan, 3, nan] + [2] * 9], dtype=float)
    ext_efa = np.full((3, K), nan)
    ext_efa[:, 3:9] = 2.5
    ext_efa[:, 9] = 3.0           # k = 10: EFA 3 > RMA 2
    ext_efa[:, 10] = 1.0          # k = 11: EFA 1 < RMA 2
    ext_efa[2, 11] = 5.0          # k = 12: one run only
    return {"noext": {"gwd_rma_moment": 2 * ext_rma, "gwd_efa_moment": np.full((3, K), nan)},
            "ext": {"gwd_rma_moment": ext_rma, "gwd_efa_moment": ext_efa}}


def test_gwd_curves_by_hand():
    cur = gwd_curves(_gwd_res(), "moment")
    assert cur["convention"] == "moment"
    np.testing.assert_array_equal(cur["k"], np.arange(1, 13))
    rma = cur["configs"]["ext"]["rma"]
    expect = np.array([np.nan, math.sqrt((1 + 9) / 2), math.sqrt((4 + 16) / 2)] + [2.0] * 9)
    np.testing.assert_allclose(rma["rmse"], expect, rtol=1e-15)
    np.testing.assert_array_equal(rma["n_runs"], [0, 2, 2] + [3] * 9)
    assert rma["first_k"] == 2
    assert rma["at"] == {5: 2.0, 10: 2.0}   # only the key scans <= K = 12
    assert rma["final"] == 2.0
    assert rma["mean_k10"] == 2.0 and rma["std_k10"] == 0.0 and rma["range_k10"] == 0.0

    efa = cur["configs"]["ext"]["efa"]
    np.testing.assert_allclose(efa["rmse"], [np.nan] * 3 + [2.5] * 6 + [3.0, 1.0, 5.0], rtol=1e-15)
    np.testing.assert_array_equal(efa["n_runs"], [0] * 3 + [3] * 8 + [1])
    assert efa["first_k"] == 4
    assert efa["mean_k10"] == pytest.approx(3.0)
    assert efa["std_k10"] == pytest.approx(math.sqrt(8 / 3))       # population std of (3, 1, 5)
    assert efa["range_k10"] == pytest.approx(4.0)
    # k = 10, 11, 12: RMA (2, 2, 2) vs EFA (3, 1, 5): below at 2 of 3
    assert cur["configs"]["ext"]["frac_rma_below_efa_k10"] == pytest.approx(2 / 3)

    no = cur["configs"]["noext"]
    np.testing.assert_allclose(no["rma"]["rmse"], 2 * expect, rtol=1e-15)
    assert no["efa"]["first_k"] is None and np.all(np.isnan(no["efa"]["rmse"]))
    assert np.all(no["efa"]["n_runs"] == 0) and math.isnan(no["efa"]["at"][5])
    assert math.isnan(no["efa"]["std_k10"]) and math.isnan(no["frac_rma_below_efa_k10"])
    assert no["label"] == "No extent" and cur["configs"]["ext"]["label"] == "With extent"


def test_gwd_curves_on_real_runs(res):
    for conv in ("moment", "full"):
        cur = gwd_curves(res, conv)
        for c in ("noext", "ext"):
            for est in ("rma", "efa"):
                g = res[c][f"gwd_{est}_{conv}"]
                k = np.flatnonzero(np.all(np.isfinite(g), axis=0))[-1]
                assert cur["configs"][c][est]["rmse"][k] == pytest.approx(np.sqrt(np.mean(g[:, k] ** 2)), rel=1e-14)
                assert set(cur["configs"][c][est]["at"]) == {s for s in GWD_KEY_STEPS if s <= N_STEPS}


def test_gwd_curves_rejects_bad_input():
    with pytest.raises(InputError, match="convention"):
        gwd_curves(_gwd_res(), "huge")
    with pytest.raises(InputError, match="gwd_rma_full"):
        gwd_curves(_gwd_res(), "full")


# --------------------------------------------------------------------------------------------- Table II


def test_landmark_table_by_hand():
    K = 5
    pos = np.array([[1.0] * K, [3.0] * K])
    head = np.radians(np.array([[2.0] * K, [2.0] * K]))
    sc = {"landmark_mae_m": np.array([1.0, np.nan]), "mean_inclusion_delay": np.array([2.0, 4.0]),
          "mean_removal_delay": np.array([np.nan, 11.0])}
    d = {"position_error_m": pos, "heading_error_rad": head,
         "false_per_scan": np.array([[0, 1, 0, 0, 0], [0, 0, 4, 0, 0]]),
         "missed_per_scan": np.array([[0, 0, 0, 0, 0], [0, 0, 0, 0, 2]]),
         "n_landmarks": np.array([[1, 2, 3, 4, 5], [1, 2, 3, 4, 7]]), "scalars": sc}
    t2 = landmark_table({"noext": d, "ext": d})
    row = t2["configs"]["ext"]
    assert row["position_avg_rmse_m"] == pytest.approx(math.sqrt(5.0))
    assert row["heading_avg_rmse_deg"] == pytest.approx(2.0)
    assert row["landmark_mae_m"] == 1.0 and row["n_trials_landmark_mae_m"] == 1
    assert row["mean_inclusion_delay"] == 3.0 and row["n_trials_mean_inclusion_delay"] == 2
    assert row["mean_removal_delay"] == 11.0 and row["n_trials_mean_removal_delay"] == 1
    assert row["mean_false"] == pytest.approx(0.5) and row["max_false"] == 4
    assert row["mean_missed"] == pytest.approx(0.2) and row["max_missed"] == 2
    assert row["mean_landmarks_final"] == 6.0 and row["n_trials"] == 2


def test_landmark_table_on_real_runs(res):
    t2 = landmark_table(res)
    for c in ("noext", "ext"):
        row, d = t2["configs"][c], res[c]
        assert row["mean_false"] == pytest.approx(d["false_per_scan"].mean())
        assert row["max_missed"] == d["missed_per_scan"].max()
        assert row["mean_landmarks_final"] == pytest.approx(d["scalars"]["n_landmarks_final"].mean())
        assert row["landmark_mae_m"] == pytest.approx(np.nanmean(d["scalars"]["landmark_mae_m"]))
        # K = 40 < 60: the car has not left yet, so no removal delay is defined anywhere.
        assert row["n_trials_mean_removal_delay"] == 0 and math.isnan(row["mean_removal_delay"])


# --------------------------------------------------------------------------------------------- NEES


def test_nees_band_holds_for_chi2_and_fails_for_inflated_nees():
    """Each scan's average of N chi2(3) draws is inside the two-sided 95% band with probability 0.95,
    independently over scans: the fraction has sd sqrt(0.95 0.05 / K) = 0.0034 at K = 4000; bound 4 sd.
    Negative control: NEES x 3 (covariance 3x too small) puts the average (mean 9, sd 1.6) above the upper
    bound (4.2 for N = 20) at all but ~0.2% of scans; bound 1%."""
    n, K = 20, 4000
    rng = np.random.default_rng(77)
    nees = rng.chisquare(3, size=(n, K))
    s = nees_summary({"noext": {"nees": nees}, "ext": {"nees": nees}})
    assert s["band"] == list(chi2_band(3, n, 0.95)) and s["n_runs"] == n and s["dof"] == 3
    c = s["configs"]["ext"]
    np.testing.assert_allclose(c["avg_nees"], nees.mean(axis=0))
    assert abs(c["frac_inside"] - 0.95) < 4 * math.sqrt(0.95 * 0.05 / K)
    assert c["frac_inside"] + c["frac_below"] + c["frac_above"] == pytest.approx(1.0)
    assert abs(c["time_avg"] - 3.0) < 4 * math.sqrt(6.0 / (n * K))  # var chi2(3) = 6

    bad = nees_summary({"noext": {"nees": 3 * nees}, "ext": {"nees": 3 * nees}})["configs"]["noext"]
    assert bad["frac_inside"] < 0.01 and bad["frac_above"] > 0.99
    # The band itself: n * avg ~ chi2(3 n).
    lo, hi = s["band"]
    assert chi2.cdf(n * hi, 3 * n) - chi2.cdf(n * lo, 3 * n) == pytest.approx(0.95)


# --------------------------------------------------------------------------------------------- files


EXPECTED_FILES = {"table1.md", "table1.csv", "table2_landmarks.md", "table2_landmarks.csv", "fig3_gwd_moment.csv",
                  "fig3_gwd_full.csv", "nees.csv", "nis.csv", "report.json", "report.md"}
FIGURES = {"fig3_gwd_moment.png", "fig3_gwd_full.png", "fig2_trial1.png", "nees.png", "nis.png"}


def md_sections(text: str) -> dict[str, str]:
    """``{"## heading": body}`` of a Markdown document."""
    out, head = {}, None
    for ln in text.splitlines():
        if ln.startswith("## "):
            head = ln
            out[head] = ""
        elif head is not None:
            out[head] += ln + "\n"
    return out


def read_csv(path) -> list[dict]:
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


def test_write_report_writes_every_file(mc_dir, report, res):
    rdir = mc_dir / "report"
    expected = EXPECTED_FILES | (FIGURES if have_matplotlib() else set())
    assert set(report["files"]) == expected
    for name in expected:
        assert (rdir / name).is_file() and (rdir / name).stat().st_size > 0, name

    rows = check_markdown_table((rdir / "table1.md").read_text())
    assert rows[0] == ["metric", "No extent", "No extent 95% CI", "With extent", "With extent 95% CI",
                       "change With extent vs No extent (%)", "change With extent 95% CI (paired)",
                       "paper No / With extent"]
    assert [r[0] for r in rows[1:]] == ["position avg. RMSE (m)", "heading avg. RMSE (deg)"]
    assert float(rows[1][1]) == pytest.approx(avg_rmse(res["noext"]["position_error_m"]), abs=5e-4)
    assert float(rows[2][5]) == pytest.approx(report["table1"]["heading_avg_rmse_deg"]["change_pct"]["ext"]["estimate"],
                                              abs=0.05)
    rows2 = check_markdown_table((rdir / "table2_landmarks.md").read_text())
    assert rows2[0] == ["metric", "No extent", "With extent", "APSIPA low / high clutter"] and len(rows2) == 9

    text = (rdir / "report.json").read_text()
    assert "NaN" not in text and "Infinity" not in text
    rj = json.loads(text)
    assert rj["meta"]["n_trials"] == N_TRIALS and rj["meta"]["seed"] == SEED and rj["meta"]["trials"] == [1, 2, 3, 4]
    assert [v["name"] for v in rj["meta"]["variants"]] == ["noext", "ext"] and rj["meta"]["baseline"] == "noext"
    pos = report["table1"]["position_avg_rmse_m"]["ext"]["estimate"]
    assert rj["table1"]["position_avg_rmse_m"]["ext"]["estimate"] == pos
    assert rj["landmarks"]["configs"]["ext"]["mean_removal_delay"] is None      # NaN -> null
    assert len(rj["gwd"]["full"]["configs"]["ext"]["rma"]["rmse"]) == N_STEPS
    assert rj["files"] == report["files"]

    for conv in ("moment", "full"):
        g = np.genfromtxt(rdir / f"fig3_gwd_{conv}.csv", delimiter=",", names=True)
        assert g.shape == (N_STEPS,)
        np.testing.assert_array_equal(g["k"], np.arange(1, N_STEPS + 1))
        np.testing.assert_allclose(g["ext_efa_rmse_m"], report["gwd"][conv]["configs"]["ext"]["efa"]["rmse"],
                                   rtol=1e-15, equal_nan=True)
        np.testing.assert_array_equal(g["noext_rma_n_runs"], report["gwd"][conv]["configs"]["noext"]["rma"]["n_runs"])
    nees = np.genfromtxt(rdir / "nees.csv", delimiter=",", names=True)
    np.testing.assert_allclose(nees["ext_avg_nees"], res["ext"]["nees"].mean(axis=0), rtol=1e-15)
    t1 = {r["metric"]: r for r in read_csv(rdir / "table1.csv")}
    assert float(t1["heading_avg_rmse_deg"]["ext"]) == report["table1"]["heading_avg_rmse_deg"]["ext"]["estimate"]
    assert float(t1["position_avg_rmse_m"]["change_pct_ext_ci_low"]) == \
        report["table1"]["position_avg_rmse_m"]["change_pct"]["ext"]["ci"][0]
    t2 = np.genfromtxt(rdir / "table2_landmarks.csv", delimiter=",", names=True, dtype=None, encoding=None)
    assert t2.dtype.names == ("metric", "noext", "ext")
    assert float(t2["noext"][list(t2["metric"]).index("mean_false")]) == report["landmarks"]["configs"]["noext"]["mean_false"]

    md = (rdir / "report.md").read_text()
    sec = md_sections(md)
    assert list(sec) == ["## What this run reproduces", "## Variants", "## Table 1: platform pose error (seed Table 1)",
                         "## Fig. 3: RMSE of the average GWD (m), convention `moment`",
                         "## Fig. 3: RMSE of the average GWD (m), convention `full`",
                         "## Table II: landmark management (APSIPA Table II)", "## Pose NEES (3 dof)",
                         "## NIS of the EKF updates (2 dof)"] + (["## Fig. 2"] if have_matplotlib() else [])
    claim_rows = check_markdown_table(sec["## What this run reproduces"])
    assert len(claim_rows) - 1 == len(report["claims"]) and all(r[2] in ("**reproduced**", "**not reproduced**",
                                                                          "undefined") for r in claim_rows[1:])
    assert (rdir / "table1.md").read_text().strip() in sec["## Table 1: platform pose error (seed Table 1)"]
    assert (rdir / "table2_landmarks.md").read_text().strip() in sec["## Table II: landmark management (APSIPA Table II)"]
    head = re.search(r"- trials: (\d+) \(numbers ([\d, -]+)\), seed (\d+), profile `(\w+)`, K = (\d+) scans", md)
    assert head and (int(head[1]), head[2], int(head[3]), head[4], int(head[5])) == (N_TRIALS, "1-4", SEED, "apsipa",
                                                                                     N_STEPS)
    nees_rows = check_markdown_table(sec["## Pose NEES (3 dof)"])
    assert [r[0] for r in nees_rows[1:]] == ["No extent", "With extent"]
    assert [float(r[4]) for r in nees_rows[1:]] == [pytest.approx(report["nees"]["configs"][c]["time_avg"], abs=5e-3)
                                                    for c in ("noext", "ext")]
    assert [r[5] for r in nees_rows[1:]] == ["fixed", "fixed"]      # docs/method.md b.5: the paper's offset


def test_a_third_variant_appears_in_every_output(mc3_dir):
    """No code knows "nosift": every table, CSV and figure of the report covers it from the data."""
    rep = write_report(mc3_dir, n_boot=200)
    res = load_results(mc3_dir)
    rdir = mc3_dir / "report"
    names, labels = ["noext", "ext", "nosift"], ["No extent", "With extent", NOSIFT.label]
    assert [v.name for v in res["variants"]] == names

    # report.json
    rj = json.loads((rdir / "report.json").read_text())
    assert [(v["name"], v["label"]) for v in rj["meta"]["variants"]] == list(zip(names, labels))
    assert rj["meta"]["variants"][2]["overlay"] == NOSIFT.overlay
    for m, key, f in (("position_avg_rmse_m", "position_error_m", lambda e: e),
                      ("heading_avg_rmse_deg", "heading_error_rad", np.degrees)):
        est = {n: avg_rmse(f(res[n][key])) for n in names}
        assert [rj["table1"][m][n]["estimate"] for n in names] == [est[n] for n in names]
        assert list(rj["table1"][m]["change_pct"]) == ["ext", "nosift"]
        assert rj["table1"][m]["change_pct"]["nosift"]["estimate"] == pytest.approx(
            100 * (est["nosift"] / est["noext"] - 1), rel=1e-12)
    assert list(rj["landmarks"]["configs"]) == names and list(rj["nees"]["configs"]) == names
    assert all(list(rj["gwd"][c]["configs"]) == names for c in REPORT_CONVENTIONS)

    # table1.md / table1.csv
    rows = check_markdown_table((rdir / "table1.md").read_text())
    assert rows[0][1::2][:3] == labels and f"change {NOSIFT.label} vs No extent (%)" in rows[0]
    col = rows[0].index(NOSIFT.label)
    assert float(rows[1][col]) == pytest.approx(rep["table1"]["position_avg_rmse_m"]["nosift"]["estimate"], abs=5e-4)
    t1 = {r["metric"]: r for r in read_csv(rdir / "table1.csv")}
    for m in ("position_avg_rmse_m", "heading_avg_rmse_deg"):
        r = rep["table1"][m]
        assert float(t1[m]["nosift"]) == r["nosift"]["estimate"]
        assert [float(t1[m]["nosift_ci_low"]), float(t1[m]["nosift_ci_high"])] == r["nosift"]["ci"]
        assert [float(t1[m][f"change_pct_nosift{s}"]) for s in ("", "_ci_low", "_ci_high")] == \
            [r["change_pct"]["nosift"]["estimate"], *r["change_pct"]["nosift"]["ci"]]

    # table2_landmarks.md / .csv
    rows2 = check_markdown_table((rdir / "table2_landmarks.md").read_text())
    assert rows2[0][1:4] == labels
    t2 = {r["metric"]: r for r in read_csv(rdir / "table2_landmarks.csv")}
    assert float(t2["mean_false"]["nosift"]) == pytest.approx(res["nosift"]["false_per_scan"].mean(), rel=1e-15)
    assert float(t2["mean_landmarks_final"]["nosift"]) == pytest.approx(
        res["nosift"]["scalars"]["n_landmarks_final"].mean(), rel=1e-15)

    # fig3 CSVs and the NEES CSV
    for conv in REPORT_CONVENTIONS:
        g = np.genfromtxt(rdir / f"fig3_gwd_{conv}.csv", delimiter=",", names=True)
        for est in ("rma", "efa"):
            expect, n = rmse_over_defined(res["nosift"][f"gwd_{est}_{conv}"])
            np.testing.assert_allclose(g[f"nosift_{est}_rmse_m"], expect, rtol=1e-15, equal_nan=True)
            np.testing.assert_array_equal(g[f"nosift_{est}_n_runs"], n)
    nees = np.genfromtxt(rdir / "nees.csv", delimiter=",", names=True)
    for n in names:
        np.testing.assert_allclose(nees[f"{n}_avg_nees"], res[n]["nees"].mean(axis=0), rtol=1e-15)

    # report.md: the variants table and a column or row of the variant in every table
    sec = md_sections((rdir / "report.md").read_text())
    vrows = check_markdown_table(sec["## Variants"])
    assert [(r[0], r[1]) for r in vrows[1:]] == [(f"`{n}`", lab) for n, lab in zip(names, labels)]
    assert json.loads(vrows[3][2].strip("`")) == NOSIFT.overlay
    for conv in REPORT_CONVENTIONS:
        body = sec[f"## Fig. 3: RMSE of the average GWD (m), convention `{conv}`"]
        header = check_markdown_table(body.split("\n\n| curve")[0])[0]
        assert f"{NOSIFT.label} RMA" in header and f"runs ({NOSIFT.label})" in header
    nees_rows = check_markdown_table(sec["## Pose NEES (3 dof)"])
    assert [r[0] for r in nees_rows[1:]] == labels


def test_figures_draw_every_variant_distinctly(mc3_dir, tmp_path):
    require("matplotlib")
    from radarslam.viz.report import plot_gwd_curves, plot_nees

    res = load_results(mc3_dir)
    labels = [v.label for v in res["variants"]]
    curves = gwd_curves(res, "full")
    entries = plot_gwd_curves(tmp_path / "g.png", curves, "full", reference={"rma": {5: 2.3}, "efa": {5: 2.3}})
    assert [e[0] for e in entries[:6]] == [f"{est}, {lab}" for lab in labels for est in ("RMA", "EFA")]
    assert len({(e[1], e[2]) for e in entries[:6]}) == 6            # no two curves look alike
    assert len({e[1] for e in entries[:6:2]}) == 3                   # one line style per variant
    ns = nees_summary(res)
    entries = plot_nees(tmp_path / "n.png", ns)
    assert [e[0].split(" (")[0] for e in entries[:3]] == labels
    assert len({(e[1], e[2]) for e in entries[:3]}) == 3
    assert (tmp_path / "g.png").stat().st_size > 0 and (tmp_path / "n.png").stat().st_size > 0


def test_fig2_regenerates_trial_1_exactly(mc_dir, report, res, tmp_path):
    require("matplotlib")
    from radarslam.montecarlo.trials import trial_seed
    from radarslam.simulation.trial import run_trial
    from radarslam.viz.report import plot_fig2

    assert report["fig2"] == {"trial": 1, "variant": "ext", "label": "With extent", "matches_stored": True}
    tr = run_trial(res["config"], trial_seed(res["seed"], 1), use_extent=True)
    plot_fig2(tmp_path / "f.png", tr)
    assert np.array_equal(tr.record.poses, res["ext"]["poses"][0])
    assert (tmp_path / "f.png").stat().st_size > 0


def test_report_skips_corrupt_trials_and_fig2_without_trial_1(mc_dir, tmp_path):
    d = tmp_path / "mc"
    shutil.copytree(mc_dir, d, ignore=shutil.ignore_patterns("report"))
    (d / "trials" / "trial_000001.npz").unlink()
    p = d / "trials" / "trial_000003.npz"
    p.write_bytes(p.read_bytes()[:1000])
    rep = write_report(d, n_boot=50, figures=have_matplotlib())
    assert rep["meta"]["trials"] == [2, 4] and list(rep["meta"]["corrupt"]) == [3]
    assert rep["meta"]["trial_range"] == "2, 4"
    assert rep["fig2"] is None and "fig2_trial1.png" not in rep["files"]
    assert not (d / "report" / "fig2_trial1.png").exists()
    md = (d / "report" / "report.md").read_text()
    assert re.search(r"^- corrupt trial files skipped: 1$", md, re.M) and re.search(r"^  - trial 3: unreadable", md, re.M)
    assert rep["table1"]["n_runs"] == 2
    res = load_results(d)
    assert rep["table1"]["position_avg_rmse_m"]["ext"]["estimate"] == avg_rmse(res["ext"]["position_error_m"])


# --------------------------------------------------------------------------------------------- CLI


def _parser():
    from radarslam.cli.report import add_parser

    p = argparse.ArgumentParser(prog="radarslam")
    add_parser(p.add_subparsers(dest="command", required=True))
    return p


def test_cli_report_prints_the_summary(mc_dir, capsys):
    args = _parser().parse_args(["report", str(mc_dir), "--bootstrap", "100", "--overwrite"])
    assert args.bootstrap == 100 and _parser().parse_args(["report", "x"]).bootstrap == 2000
    assert args.func(args) == 0
    out = capsys.readouterr().out
    assert out == (mc_dir / "report" / "report.md").read_text()
    assert json.loads((mc_dir / "report" / "report.json").read_text())["table1"]["n_boot"] == 100


def test_cli_report_bad_dir_is_an_input_error(tmp_path):
    p = _parser()
    empty = tmp_path / "empty"
    empty.mkdir()
    no_trials = tmp_path / "no_trials"
    no_trials.mkdir()
    (no_trials / "manifest.json").write_text(json.dumps({"seed": 1, "config_toml": ""}))
    bad_manifest = tmp_path / "bad_manifest"
    bad_manifest.mkdir()
    (bad_manifest / "manifest.json").write_text("{not json")
    for d, msg in ((tmp_path / "missing", "not a directory"), (empty, "manifest"),
                   (no_trials, "no valid trial"), (bad_manifest, "cannot read")):
        args = p.parse_args(["report", str(d)])
        with pytest.raises(InputError, match=msg) as ei:
            args.func(args)
        assert str(ei.value).startswith("DIR")
    args = p.parse_args(["report", str(empty), "--bootstrap", "0"])
    with pytest.raises(InputError, match="--bootstrap"):
        args.func(args)


def test_cli_main_report(mc_dir, tmp_path, capsys):
    from radarslam.cli.main import main

    before = (mc_dir / "report" / "report.json").read_text() if (mc_dir / "report" / "report.json").exists() else None
    if before is not None:  # a finished report is never replaced without --overwrite
        assert main(["report", str(mc_dir), "--bootstrap", "50"]) == 1
        assert "already holds a finished result (report.md); pass --overwrite" in capsys.readouterr().err
        assert (mc_dir / "report" / "report.json").read_text() == before
    assert main(["report", str(mc_dir), "--bootstrap", "50", "--overwrite"]) == 0
    assert capsys.readouterr().out == (mc_dir / "report" / "report.md").read_text()
    assert json.loads((mc_dir / "report" / "report.json").read_text())["table1"]["n_boot"] == 50
    assert main(["report", str(tmp_path / "missing")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("radarslam report: error: DIR")


def test_nis_summary_pools_updates_and_tests_them_against_the_chi2_band():
    """Synthetic NIS: consistent draws land inside the band at ~95% of scans with mean ~2;
    draws scaled by 2 (an overconfident filter) are above it everywhere (negative control)."""
    from scipy import stats

    from radarslam.montecarlo.report import nis_summary

    rng = np.random.default_rng(4)
    N, K = 50, 120
    count = rng.integers(0, 30, (N, K)).astype(float)
    sums = np.array([[rng.chisquare(2, int(c)).sum() for c in row] for row in count])
    res = {"variants": [Variant("good", "consistent", {}), Variant("bad", "overconfident", {})],
           "good": {"nis_sum": sums, "nis_count": count}, "bad": {"nis_sum": 2.0 * sums, "nis_count": count}}
    ns = nis_summary(res)
    good, bad = ns["configs"]["good"], ns["configs"]["bad"]
    n = count.sum(axis=0)
    np.testing.assert_allclose(good["mean_nis"], sums.sum(0) / n)
    np.testing.assert_allclose(good["band_low"], stats.chi2.ppf(0.025, 2 * n) / n)
    assert abs(good["overall"] - 2.0) < 0.05
    assert good["frac_inside"] > 0.88
    assert bad["frac_inside"] < 0.05 and abs(bad["overall"] - 4.0) < 0.1


def test_claims_say_plainly_what_reproduces():
    """Table 1 direction holds only when the paired CI lies below zero; size against the paper's
    With-extent values; Fig. 3 'below at every k >= 10' needs 100%, 'flatter' needs a lower std."""
    from radarslam.montecarlo.report.tables import claims

    def metric(ext, change_ci):
        return {"noext": {"estimate": 1.2, "ci": [1.1, 1.3]}, "ext": {"estimate": ext, "ci": [ext - 0.1, ext + 0.1]},
                "change_pct": {"ext": {"estimate": 100 * (ext / 1.2 - 1), "ci": change_ci}}}

    t1 = {"baseline": "noext", "variants": ["noext", "ext"], "labels": {"noext": "No extent", "ext": "With extent"},
          "position_avg_rmse_m": metric(1.05, [-20.0, -5.0]), "heading_avg_rmse_deg": metric(3.3, [-8.0, 1.0])}
    curve = {"configs": {"ext": {"rma": {"std_k10": 0.05}, "efa": {"std_k10": 0.10}, "frac_rma_below_efa_k10": 1.0},
                         "noext": {"rma": {"std_k10": 0.20}, "efa": {"std_k10": 0.10},
                                   "frac_rma_below_efa_k10": 0.9}}}
    got = {(c["claim"], c["variant"]): c["holds"] for c in claims(t1, {"moment": curve})}
    assert got[("Table 1 direction (position)", "ext")] is True
    assert got[("Table 1 direction (heading)", "ext")] is False          # CI reaches above zero
    assert got[("Table 1 size (position <= paper)", "ext")] is True       # 1.05 <= 1.09
    assert got[("Table 1 size (heading <= paper)", "ext")] is False       # 3.3 > 3.24
    assert got[("Fig. 3 RMA below EFA at every k >= 10 (moment)", "ext")] is True
    assert got[("Fig. 3 RMA below EFA at every k >= 10 (moment)", "noext")] is False
    assert got[("Fig. 3 RMA flatter than EFA (moment)", "ext")] is True
    assert got[("Fig. 3 RMA flatter than EFA (moment)", "noext")] is False
