"""scripts/threshold_study.py (the seed paper's claim on thresholds): the settings it
runs, and the whole script at a tiny size."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"
sys.path.insert(0, str(SCRIPTS))

import threshold_study  # noqa: E402


def test_settings_scale_each_threshold_alone():
    """Integers round half up and stay >= 1; a value equal to the profile's is the base run;
    every overlay changes one threshold over its base variant's."""
    assert threshold_study.scaled(2, 0.5) == 1 and threshold_study.scaled(3, 1.5) == 5
    assert threshold_study.scaled(1, 0.5) == 1 and threshold_study.scaled(2.5, 0.75) == pytest.approx(1.875)
    s = threshold_study.settings()
    assert len(s) == 3 * len(threshold_study.THRESHOLDS) * len(threshold_study.FACTORS)
    assert ("noext", "cluster_min_samples", 0.75, 2, "noext") in s
    bases = {b.name: b for b in threshold_study.BASES}
    for v in threshold_study.study_variants()[3:]:
        base = bases[v.name.split("-")[0]]
        changed = {k for k in v.overlay["landmarks"] if v.overlay["landmarks"][k] != base.overlay.get(
            "landmarks", {}).get(k)}
        assert len(changed) == 1 and changed <= set(threshold_study.THRESHOLDS)


def test_seed_one_is_refused(tmp_path):
    assert threshold_study.main(["--seed", "1", "--trials", "1", "--out", str(tmp_path / "r")]) == 2


@pytest.mark.slow
def test_threshold_study_runs_and_writes_finite_outputs(tmp_path):
    """Two trials of every setting: the table, its JSON and the figure exist; every error and
    spread is finite and >= 0."""
    out = tmp_path / "ts"
    r = subprocess.run([sys.executable, str(SCRIPTS / "threshold_study.py"), "--trials", "2", "--jobs", "1",
                        "--out", str(out)], capture_output=True, text=True, timeout=1800)
    assert r.returncode == 0, r.stderr[-2000:]
    for name in ("threshold_study.md", "threshold_study.json", "threshold_study.png"):
        assert (out / name).stat().st_size > 0
    rows = json.loads((out / "threshold_study.json").read_text())["rows"]
    assert len(rows) == len(threshold_study.settings())
    assert all(math.isfinite(x[k]) and x[k] > 0 for x in rows for k in ("position_m", "heading_deg"))
    spreads = threshold_study.spreads(rows)
    assert len(spreads) == 3 * len(threshold_study.THRESHOLDS)
    assert all(math.isfinite(s["position_spread_m"]) and s["position_spread_m"] >= 0 for s in spreads)
    assert "Spread over x0.5..x2" in (out / "threshold_study.md").read_text()
