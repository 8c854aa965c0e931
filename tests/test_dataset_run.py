"""The dataset runner's evaluation pieces: trunk diameters from RMA extents, the reference-detection
attribution and the diameter comparison (synthetic oracles; the real-data runs are in
``test_victoria_park_slam.py``)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from radarslam.config import profile_config
from radarslam.core.errors import InputError
from radarslam.runs.dataset import (REFERENCE_GATE_M, _attribute_reference, compare_tree_diameters, trunk_diameter)
from radarslam.runs.recording import RecordingRun
from radarslam.slam.driver import FilterRecord
from radarslam.slam.filter import MapSnapshot


def _laser_on_trunk(d: float, r: float, step_deg: float = 0.5) -> np.ndarray:
    """Points where beams ``step_deg`` apart, from the origin, hit a trunk of diameter ``d`` centred at
    ``(r, 0)`` (the first intersection of each ray with the circle)."""
    rho = d / 2
    half = math.asin(rho / r)
    th = np.arange(-half, half, math.radians(step_deg)) + (half % math.radians(step_deg)) / 2
    # ray t (cos th, sin th) meets |p - (r, 0)| = rho at the smaller root
    b = r * np.cos(th)
    t = b - np.sqrt(np.maximum(b * b - (r * r - rho * rho), 0.0))
    return np.column_stack([t * np.cos(th), t * np.sin(th)])


@pytest.mark.parametrize("d,r", [(0.3, 10.0), (0.6, 15.0), (1.0, 25.0), (0.4, 25.0)])
def test_trunk_diameter_inverts_the_laser_arc(d, r):
    pts = _laser_on_trunk(d, r, step_deg=0.01)  # dense beams: the continuous limit of the model
    C = np.cov(pts.T, bias=True)
    X = C / 0.25  # what the RMA converges to when the scatter is gamma_z X (seed eq. 4)
    assert trunk_diameter(X, 0.25) == pytest.approx(d, rel=0.03)
    # negative control: the filled-disc reading 2 sqrt(lambda) is 15% too large
    assert 2 * math.sqrt(np.linalg.eigvalsh(X)[-1]) == pytest.approx(d * 2 / math.sqrt(3), rel=0.03)


def test_trunk_diameter_near_field_bias_is_small_and_negative():
    # documented: about 0.6 rho / r too small; 8% at r = 7.5 rho
    for ratio, lo, hi in [(7.5, 0.90, 0.94), (40.0, 0.975, 0.995)]:
        pts = _laser_on_trunk(1.0, ratio * 0.5, step_deg=0.01)
        assert lo < trunk_diameter(np.cov(pts.T, bias=True) / 0.25) < hi


def test_trunk_diameter_scales_with_gamma_and_batches():
    X = np.array([[[3.0, 0.0], [0.0, 0.1]], [[0.1, 0.0], [0.0, 0.12]]])
    got = trunk_diameter(X, 0.25)
    np.testing.assert_allclose(got, [math.sqrt(9.0), math.sqrt(0.36)])
    np.testing.assert_allclose(trunk_diameter(X, 1.0), 2 * got)
    with pytest.raises(InputError, match="X: expected shape"):
        trunk_diameter(np.eye(3))
    with pytest.raises(InputError, match="gamma_z"):
        trunk_diameter(np.eye(2), 0.0)


def _run_with(ids, rma, hits, estimator="rma-efa") -> RecordingRun:
    n = len(ids)
    snap = MapSnapshot(ids=np.array(ids), positions=np.zeros((n, 2)), covs=np.zeros((n, 2, 2)),
                       rma=np.asarray(rma, dtype=float), efa=np.full((n, 2, 2), np.nan), created=np.zeros(n, int))
    e = np.empty(0)
    cfg = profile_config("victoria-park")
    cfg = dataclasses.replace(cfg, extent=dataclasses.replace(cfg.extent, estimator=estimator))
    record = FilterRecord(e.reshape(0, 3), e.reshape(0, 3, 3), [snap], e, e, e)
    return RecordingRun(cfg, None, None, [], e, record, None, {}, name="x",
                        reference_hits=None if hits is None else np.asarray(hits, dtype=float))


def test_compare_tree_diameters_matches_by_id_and_counts():
    X = lambda d: np.diag([d * d / 3, 1e-3])  # noqa: E731 - extent of diameter d
    nan = np.full((2, 2), np.nan)
    hits = [[1, 0.5, 0.1]] * 3 + [[1, 0.9, 0.1]] + [[2, 0.3, 0.2]] * 2 + [[3, 0.4, 0.1]] * 5 + [[9, 1.0, 0.1]] * 4
    run = _run_with([1, 2, 3, 4], [X(0.4), X(0.3), nan, X(0.7)], hits)
    c = compare_tree_diameters(run, min_detections=3)
    # id 1: 4 detections, median 0.5 vs 0.4; id 2: too few; id 3: no extent; id 9: not in the map
    assert c["n_matched"] == 1 and c["ids"].tolist() == [1]
    assert c["median_abs_diff_m"] == pytest.approx(0.1)
    assert c["reference_m"][0] == pytest.approx(0.5) and c["estimate_m"][0] == pytest.approx(0.4)
    c2 = compare_tree_diameters(run, min_detections=2)
    assert c2["n_matched"] == 2 and c2["median_abs_diff_m"] == pytest.approx(0.05)
    assert c2["median_ratio"] == pytest.approx(0.9)
    with pytest.raises(InputError, match="min_detections"):
        compare_tree_diameters(run, min_detections=0)
    with pytest.raises(InputError, match="reference tree detections"):
        compare_tree_diameters(_run_with([1], [X(0.4)], None))


def test_compare_tree_diameters_of_the_visible_arc_estimator_reads_its_circles():
    circle = lambda d: (d / 2) ** 2 * np.eye(2)  # noqa: E731 - the visible-arc extent of diameter d
    hits = [[1, 0.5, 0.1]] * 3 + [[2, 0.3, 0.2]] * 3
    c = compare_tree_diameters(_run_with([1, 2], [circle(0.45), circle(0.3)], hits, "visible-arc"))
    assert c["estimator"] == "visible-arc" and c["baseline"] == "rma"
    np.testing.assert_allclose(c["estimate_m"], [0.45, 0.3])
    assert c["median_abs_diff_m"] == pytest.approx(0.025)


def test_attribute_reference_gate_and_nearest():
    # sensor at the origin facing +y; landmarks 7 and 8 at (0, 10) and (2, 10)
    pose, positions, ids = np.array([0.0, 0.0, math.pi / 2]), np.array([[0.0, 10.0], [2.0, 10.0]]), np.array([7, 8])
    det = np.array([[10.3, 0.0, 0.5],                    # 0.3 m beyond landmark 7
                    [math.hypot(1.8, 10), -math.atan2(1.8, 10), 0.6],   # 0.2 m from landmark 8
                    [10.0, -math.atan2(1.0, 10), 0.7],   # between: 1 m from both -> outside the gate
                    [40.0, 0.0, 0.8]])                   # beyond max range
    h = _attribute_reference(pose, positions, ids, det, max_range=30.0)
    np.testing.assert_allclose(h[:, :2], [[7, 0.5], [8, 0.6]])
    np.testing.assert_allclose(h[:, 2], [0.3, 0.2], atol=1e-9)
    assert REFERENCE_GATE_M < 1.0


def test_duplicate_landmarks_counts_pairs_by_radius():
    from radarslam.runs.dataset import duplicate_landmarks

    run = _run_with([1, 2, 3, 4], np.zeros((4, 2, 2)), None)
    pos = np.array([[0.0, 0.0], [0.3, 0.0], [1.7, 0.0], [10.0, 0.0]])
    run.record.maps[-1] = MapSnapshot(ids=np.array([1, 2, 3, 4]), positions=pos, covs=np.zeros((4, 2, 2)),
                                rma=np.zeros((4, 2, 2)), efa=np.zeros((4, 2, 2)), created=np.zeros(4, int))
    d = duplicate_landmarks(run, 0.42)
    assert d["n_pairs"] == 1 and d["pairs"] == [(1, 2)]
    assert d["pairs_within"] == {1.0: 1, 1.5: 2, 2.0: 3, 3.0: 3}
    with pytest.raises(InputError, match="diameter_m"):
        duplicate_landmarks(run, 0.0)


def test_position_consistency_counts_the_bound_per_axis_with_the_gps_std():
    """Analytic oracle: errors of 1, 3 and 5 m east against a filter std of 1 m and a GPS std of
    1 m (bound 2 sqrt(1 + 2) = 3.46 m) are inside, inside, outside; with the filter alone (2 m) only
    the first is."""
    from types import SimpleNamespace

    from radarslam.runs.dataset import position_consistency

    poses = np.array([[1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [5.0, 0.0, 0.0]])
    covs = np.tile(np.diag([1.0, 1.0, 0.01]), (3, 1, 1))
    run = SimpleNamespace(poses=poses, pose_covs=covs, times=np.arange(3.0), gps=SimpleNamespace(xy=np.zeros((3, 2))))
    c = position_consistency(run, {"index": np.arange(3), "fix": np.arange(3)}, gps_std_m=1.0)
    assert c["inside_east"] == pytest.approx(2 / 3) and c["inside_north"] == 1.0
    assert c["inside_both"] == pytest.approx(2 / 3) and c["inside_both_filter_only"] == pytest.approx(1 / 3)
    np.testing.assert_allclose(c["error_m"][:, 0], [1.0, 3.0, 5.0])
    assert c["mean_mahalanobis2"] == pytest.approx((1 + 9 + 25) / 3 / 3)
    with pytest.raises(InputError, match="gps_std_m"):
        position_consistency(run, {"index": np.arange(3), "fix": np.arange(3)}, gps_std_m=-1.0)


def test_a_recording_run_with_gps_is_evaluated_as_victoria_park_is():
    """The one run type: a RecordingRun with ``gps`` set (a recording of your own) takes the GPS
    evaluations. Analytic oracle: every pose 0.3 m east and 0.4 m north of its fix gives a published
    error of 0.5 m at every fix, and an aligned error of 0 (the offset is a translation); without
    fixes the evaluations are refused in one line."""
    from types import SimpleNamespace

    from radarslam.runs.dataset import evaluate_against_gps, evaluate_published, position_consistency

    t = np.arange(40) * 0.5
    xy = np.column_stack([t, np.sin(t)])                      # a curved track at ~1-1.4 m/s
    poses = np.column_stack([xy + [0.3, 0.4], np.zeros(t.size)])
    record = FilterRecord(poses, np.tile(np.eye(3), (t.size, 1, 1)), [], *(np.zeros(t.size, int),) * 3, times=t)
    run = RecordingRun(profile_config("victoria-park"), None, None, [], t, record, None, {}, name="mine",
                       gps=SimpleNamespace(t=t, xy=xy))
    pub = evaluate_published(run)
    assert pub["n_matched"] == t.size and pub["rmse_m"] == pytest.approx(0.5)
    ev = evaluate_against_gps(run)
    assert ev["n_fixes"] == t.size and ev["rmse_m"] == pytest.approx(0.0, abs=1e-9)
    assert position_consistency(run, pub)["n"] == t.size
    no_gps = dataclasses.replace(run, gps=None)
    for evaluate in (evaluate_published, evaluate_against_gps):
        with pytest.raises(InputError, match="expected a run with GPS fixes") as err:
            evaluate(no_gps)
        assert "\n" not in str(err.value) and "'mine'" in str(err.value)


def test_datasetrun_is_a_deprecated_name_of_the_one_run_type():
    from radarslam.runs import dataset

    with pytest.warns(DeprecationWarning, match="RecordingRun"):
        assert dataset.DatasetRun is RecordingRun
    with pytest.raises(AttributeError):
        dataset.NoSuchRun  # noqa: B018


def test_run_dataset_runs_victoria_park_as_a_recording(victoria_park_dir, monkeypatch):
    """``run_dataset`` goes through the recordings' filter run (``run_stream``, once) and gives the
    one run type, the loaded data as its input, with its GPS and the reference hits (laser mode)."""
    from radarslam.runs import dataset, stream_run

    calls = []
    real = stream_run.run_stream
    monkeypatch.setattr(dataset, "run_stream", lambda *a, **k: calls.append(k) or real(*a, **k))
    cfg = profile_config("victoria-park")
    run = dataset.run_dataset("victoria-park", victoria_park_dir, cfg, n_scans=40, progress=False,
                              loader_options=dataset.victoria_park_options(cfg))
    assert len(calls) == 1 and calls[0]["maps"] == "last"
    assert type(run) is RecordingRun and run.name == "victoria-park"
    assert run.events is run.recording.events and run.gps is run.recording.gps
    assert run.reference_hits is not None and run.reference_hits.shape[1] == 3
    assert run.times.size == run.poses.shape[0] == 40 and run.truth is None
    assert run.metrics["load_seconds"] > 0 and run.engine in ("fused", "fused-steps", "python")
