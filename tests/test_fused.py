"""The fused engine (radarslam.slam._fused) against its steps form run event by event (the filter object, EkfSlam with filter.fused false).

It must make the very same decisions (every association, every landmark id after every scan) and
the same estimates to rounding, for every configuration it claims to cover, and refuse the ones it
does not. The oracle is ``EkfSlam`` run scan by scan (numba backend), and the golden recording.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from conftest import require
from golden import CARPARK_RUNS, GOLDEN, carpark_run

require("numba")

from radarslam.config import from_dict, profile_config, to_dict  # noqa: E402
from radarslam.config import merge_tables  # noqa: E402
from radarslam.core.errors import InputError  # noqa: E402
from radarslam.core.types import Odometry, Scan  # noqa: E402
from radarslam.montecarlo.trials import trial_seed  # noqa: E402
from radarslam.slam.driver import run_filter  # noqa: E402
from radarslam.config.variants import CONSISTENT, DEFAULT_VARIANTS, PAPER_VARIANTS, apply_variant  # noqa: E402
from radarslam.simulation.scenario import generate_scenario  # noqa: E402
from radarslam.slam import _fused  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402


def _overlay(cfg, overlay: dict):
    return from_dict(merge_tables(to_dict(cfg), overlay))


def _scenario(cfg, trial: int):
    return generate_scenario(cfg, np.random.default_rng(trial_seed(1, trial)))


def _event_by_event(cfg, events):
    """Scan by scan: associations ``(scan position, detection, id)``, and per scan the pose, its
    covariance, the NIS sum and every snapshot; and the bias states and their covariances per scan."""
    slam = EkfSlam(replace(cfg, filter=replace(cfg.filter, fused=False)))
    rows, poses, covs, nis, snaps, bias, bias_covs = [], [], [], [], [], [], []
    for ev in events:
        rep = slam.process(ev)
        if rep is None:
            continue
        s = len(poses)
        for lid, dets in rep.associations.items():
            rows += [(s, int(d), int(lid)) for d in dets]
        poses.append(slam.pose)
        covs.append(slam.pose_cov)
        nis.append(rep.nis.sum())
        snaps.append(slam.snapshot())
        bias.append(slam.bias)                              # the odometry-bias states (c.11), if any
        bias_covs.append(slam.state.bias_cov)
    bias = (np.array(bias), np.array(bias_covs))
    return sorted(rows), np.array(poses), np.array(covs), np.array(nis), snaps, bias


def _assert_same_run(cfg, events, tol=1e-9):
    rows, poses, covs, nis, snaps, bias = _event_by_event(cfg, events)
    r, arows = _fused.run(EkfSlam(cfg), events)
    assert sorted(map(tuple, arows.tolist())) == rows                      # every association
    off = r["map_offsets"]
    assert off.shape[0] == len(snaps) + 1
    assert np.array_equal(r["n_landmarks"], [s.ids.size for s in snaps])
    for s, a, b in zip(snaps, off[:-1], off[1:]):
        assert np.array_equal(r["ids"][a:b], s.ids)                        # the same landmarks, in state order
        assert np.array_equal(r["created"][a:b], s.created)
        for key in ("positions", "covs", "rma", "efa"):
            np.testing.assert_allclose(r[key][a:b], getattr(s, key), rtol=tol, atol=tol, err_msg=key)
    np.testing.assert_allclose(r["poses"], poses, rtol=tol, atol=tol)
    np.testing.assert_allclose(r["pose_covs"], covs, rtol=tol, atol=tol)
    np.testing.assert_allclose(r["nis_sum"], nis, rtol=tol, atol=tol)
    for key, want in zip(("bias", "bias_covs"), bias):                    # the bias states (c.11), if any
        assert r[key].shape == want.shape
        np.testing.assert_allclose(r[key], want, rtol=tol, atol=tol, err_msg=key)
    return len(rows)


@pytest.mark.parametrize("variant", DEFAULT_VARIANTS, ids=[v.name for v in DEFAULT_VARIANTS])
@pytest.mark.parametrize("trial", [1, 2])
def test_default_variants_same_as_the_steps_form(variant, trial):
    cfg = profile_config("apsipa")
    n = _assert_same_run(apply_variant(cfg, variant), _scenario(cfg, trial).events)
    assert n > 1500                                     # a real run: thousands of associations compared


OVERLAYS = {
    "narrow-fov": {"filter": {"field_of_view_deg": 120.0}},
    "merge-axis-and-cap": {"landmarks": {"merge_axis_tol_m": 0.5, "merge_max_per_scan": 1, "merge_distance_m": 3.0}},
    "posterior-centroid": {"extent": {"use_in_slam": True, "use_posterior_landmark": True}},
    "noise-corrected-efa": {"extent": {"efa_noise_correct": True}},
    "cluster-init-no-spread": {"landmarks": {"init": "cluster"}, "extent": {"use_in_slam": True}},
    "radius-sifting": {"extent": {"use_in_slam": True, "contour_sifting": False}},
    "no-inflation": {"extent": {"use_in_slam": True, "inflate_noise": False, "pre_init_spread": "prior"}},
    "literal-sifting": {"extent": {"use_in_slam": True, "sifting_mode": "literal"}},
    "batch-noext": {"landmarks": {"associator": "batch"}},
    "batch-joint": {"landmarks": {"associator": "batch-joint", "init": "cluster"},
                    "extent": {"use_in_slam": True, "pre_init_spread": "prior"}},
    "early-extents": {"extent": {"use_in_slam": True, "n_init": 3}, "landmarks": {"merge_distance_m": 4.0}},
    "no-tracking": {"extent": {"track": False}},
    # the scan's W other than the largest trace's (h.3), with the RMA and MEM-EKF*
    "w-mean": {"extent": {"w_mode": "mean"}},
    "w-max-det-in-slam": {"extent": {"w_mode": "max_det", "use_in_slam": True}},
    "w-mean-mem-ekf": {"extent": {"estimator": "mem-ekf", "w_mode": "mean", "efa_noise_correct": True}},
    # the buffered detections' scatter as the spread before the extent (a.7.2), with three associators
    "scatter-spread": {"extent": {"use_in_slam": True, "pre_init_spread": "scatter"}},
    "scatter-spread-joint": {"landmarks": {"associator": "batch-joint", "init": "cluster"},
                             "extent": {"use_in_slam": True, "pre_init_spread": "scatter"}},
    "scatter-spread-jcbb": {"landmarks": {"associator": "jcbb"},
                            "extent": {"use_in_slam": True, "pre_init_spread": "scatter", "n_init": 6}},
    "rule1-only": {"landmarks": {"confirm_points": 2, "alpha": 50.0}},
    # the EFA baseline of the last efa_window detections (Decision 5), upper bound and noise-corrected, RMA and MEM-EKF*
    "sliding-efa": {"extent": {"efa_mode": "sliding", "efa_window": 12}},
    "sliding-efa-corrected-merge": {"extent": {"efa_mode": "sliding", "efa_noise_correct": True, "w_mode": "mean",
                                               "n_init": 3}, "landmarks": {"merge_distance_m": 4.0}},
    "sliding-efa-mem-ekf": {"extent": {"estimator": "mem-ekf", "efa_mode": "sliding", "efa_noise_correct": True}},
    # first-estimates Jacobians (c.2.1) with each associator that evaluates them
    "fej-nearest": {"filter": {"jacobians": "fej"}},
    "fej-batch": {"filter": {"jacobians": "fej"}, "landmarks": {"associator": "batch"},
                  "extent": {"use_in_slam": True}},
    "fej-consistent": {"filter": {"jacobians": "fej"}, "landmarks": {"associator": "batch-joint", "init": "cluster"},
                       "extent": {"use_in_slam": True, "pre_init_spread": "prior", "prior_extent_radius_m": 2.0}},
    # JCBB (c.4.1): the paper's filter, the consistent variant, and a node budget that cuts searches short
    "jcbb-noext": {"landmarks": {"associator": "jcbb"}},
    "jcbb-consistent": {"landmarks": {"associator": "jcbb", "init": "cluster"},
                        "extent": {"use_in_slam": True, "pre_init_spread": "prior", "prior_extent_radius_m": 2.0}},
    "jcbb-budget": {"landmarks": {"associator": "jcbb", "jcbb_max_nodes": 4}, "extent": {"use_in_slam": True}},
    # MEM-EKF* (a.10): the map only, in SLAM (sifting, R_eff), and with the centroid's and the pose's
    # covariance in each detection's noise and the noise-corrected EFA baseline
    "mem-ekf": {"extent": {"estimator": "mem-ekf"}},
    "mem-ekf-in-slam": {"extent": {"estimator": "mem-ekf", "use_in_slam": True}},
    "mem-ekf-consistent": {"landmarks": {"associator": "batch-joint", "init": "cluster"},
                           "extent": {"estimator": "mem-ekf", "use_in_slam": True, "pre_init_spread": "prior",
                                      "prior_extent_radius_m": 2.0}},
    "mem-ekf-full-noise": {"extent": {"estimator": "mem-ekf", "use_in_slam": True, "mem_ekf_noise": "full",
                                      "efa_noise_correct": True, "n_init": 3}},
    "mem-ekf-no-centroid": {"extent": {"estimator": "mem-ekf", "mem_ekf_noise": "no-centroid",
                                       "use_posterior_landmark": True}},
    # turn-dependent control noise (c.11.8) and the correlated-R equivalent (c.11.9)
    "turn-noise-corr-r": {"filter": {"turn_noise_gain": 0.5, "measurement_corr_scans": 3.0}},
    "turn-noise-consistent": {"filter": {"turn_noise_gain": 0.5},
                              "landmarks": {"associator": "batch-joint", "init": "cluster"},
                              "extent": {"use_in_slam": True, "pre_init_spread": "prior"}},
    # the part in view centred anywhere on its object (c.17), with both batch associators
    "view-offset-joint": {"landmarks": {"associator": "batch-joint", "init": "cluster"},
                          "extent": {"use_in_slam": True, "pre_init_spread": "prior", "view_offset": "uniform"}},
    "view-offset-batch": {"landmarks": {"associator": "batch"},
                          "extent": {"use_in_slam": True, "view_offset": "uniform"}},
}


@pytest.mark.parametrize("name", sorted(OVERLAYS))
def test_covered_options_same_as_the_steps_form(name):
    """Each option the engine claims to cover, on a whole run (trial 3)."""
    cfg = _overlay(profile_config("apsipa"), OVERLAYS[name])
    _assert_same_run(cfg, _scenario(profile_config("apsipa"), 3).events)


@pytest.mark.parametrize("option,base,other", [
    ({"use_in_slam": True}, {"pre_init_spread": "prior"}, {"pre_init_spread": "scatter"}),
    ({}, {"w_mode": "max_trace"}, {"w_mode": "mean"}),
    ({"use_in_slam": True}, {"w_mode": "max_trace"}, {"w_mode": "max_det"}),
    ({}, {"efa_mode": "per_scan"}, {"efa_mode": "sliding"}),
])
def test_the_compiled_options_change_the_run(option, base, other):
    """The scatter spread before the extent (a.7.2), the scan's W by its mean or largest determinant
    (h.3) and the sliding EFA (Decision 5) change the run they are compared on above (trial 3): the
    poses, the extents or the EFA baselines move, so the parity cases compare branches that run."""
    events = _scenario(profile_config("apsipa"), 3).events
    runs = [_fused.run(EkfSlam(_overlay(profile_config("apsipa"), {"extent": {**option, **o}})), events)[0]
            for o in (base, other)]
    same_map = runs[0]["rma"].shape == runs[1]["rma"].shape
    moved = max(np.abs(runs[0]["poses"] - runs[1]["poses"]).max(),
                np.abs(runs[0]["rma"][-5:] - runs[1]["rma"][-5:]).max() if same_map else 1.0,
                np.nanmax(np.abs(runs[0]["efa"][-5:] - runs[1]["efa"][-5:])) if same_map else 1.0)
    assert moved > 1e-3, moved


@pytest.mark.parametrize("base", ["noext", "consistent"])
@pytest.mark.parametrize("mode", ["doppler", "both", "radar-alone"])
def test_doppler_odometry_same_as_the_steps_form(base, mode):
    """Doppler and gyro odometry (c.10.5; scripts/doppler_odometry_study.py's configurations): the
    body-velocity inputs formed before the engine, the predictions in it, on a whole run (trial 3)
    simulated with the Doppler channel; the radar alone (``yaw_rate`` doppler) ahead of the rear axle."""
    overlay = PAPER_VARIANTS[0].overlay if base == "noext" else CONSISTENT.overlay
    odometry = {"odometry": "doppler", "yaw_rate": "doppler"} if mode == "radar-alone" else {"odometry": mode}
    mount = 3.7 if mode == "radar-alone" else 0.0
    cfg = profile_config("apsipa")
    cfg = replace(cfg, radar=replace(cfg.radar, doppler=True), sensor=replace(cfg.sensor, mount_x_m=mount))
    events = _scenario(cfg, 3).events
    run = _overlay(cfg, merge_tables(merge_tables({}, overlay), {"filter": odometry}))
    assert _assert_same_run(run, events) > 1500
    r, _ = _fused.run(EkfSlam(run), events)
    r0, _ = _fused.run(EkfSlam(_overlay(cfg, overlay)), events)
    assert not np.allclose(r["poses"], r0["poses"])          # the Doppler inputs drove it, not the odometer


GATED = {
    "consistent": CONSISTENT.overlay,
    "noext-object-tests-only": merge_tables(PAPER_VARIANTS[0].overlay, {"filter": {"doppler_memory_scans": 0}}),
    "no-objects-short-memory": merge_tables(CONSISTENT.overlay, {"filter": {"doppler_object_radius_m": 0.0,
                                                                            "doppler_memory_scans": 2}}),
    "doppler-odometry": merge_tables(CONSISTENT.overlay, {"filter": {"odometry": "doppler"}}),
}


@pytest.mark.parametrize("name", sorted(GATED))
def test_doppler_gate_same_as_the_steps_form(name):
    """The Doppler gate (c.10.4) in a car park with three moving cars (trial 3): the scan's static
    detections chosen before the engine, the memory, the veto and the young landmarks' removal in
    it; associations by the scan's own detection rows."""
    cfg = profile_config("apsipa")
    cfg = replace(cfg, radar=replace(cfg.radar, doppler=True), world=replace(cfg.world, moving_vehicles=3))
    events = _scenario(cfg, 3).events
    run = _overlay(cfg, merge_tables(GATED[name], {"filter": {"doppler_gate": True}}))
    assert _assert_same_run(run, events) > 1000
    stream = _fused._stream_arrays(events, slam=EkfSlam(run))
    assert stream.moving.sum() > 100                          # the gate dropped detections
    assert (stream.seen.shape[0] > 100) == (name != "no-objects-short-memory")     # moving objects remembered
    r, _ = _fused.run(EkfSlam(run), events)
    r0, _ = _fused.run(EkfSlam(_overlay(cfg, GATED[name])), events)
    assert np.array_equal(r["n_detections"], r0["n_detections"])                  # counted before the gate
    assert not np.array_equal(r["n_landmarks"], r0["n_landmarks"])


def test_large_map_same_as_the_steps_form():
    """The records and buffers outgrow their first capacity (16 landmarks): a two-row large car
    park, 400 scans."""
    cfg = _overlay(profile_config("large-carpark"), {"world": {"rows": 2, "cars_per_row": 20},
                                                     "trajectory": {"n_steps": 400}})
    events = generate_scenario(cfg, np.random.default_rng(5)).events
    _assert_same_run(cfg, events)
    r, _ = _fused.run(EkfSlam(cfg), events)
    assert r["n_landmarks"].max() > 16


def test_golden_runs_reproduced():
    """The golden recording's car-park runs (tests/golden.py), by the fused engine: the same
    associations and landmark ids, values to 1e-12."""
    with np.load(GOLDEN) as z:
        golden = {k: z[k] for k in z.files}
    for name, profile, seed, extent in CARPARK_RUNS:
        cfg = profile_config(profile)
        cfg = replace(cfg, extent=replace(cfg.extent, use_in_slam=extent, sifting_mode="literal"))
        scenario = generate_scenario(cfg, np.random.default_rng(np.random.SeedSequence(seed)))
        r, arows = _fused.run(EkfSlam(cfg), scenario.events)
        k = [e.index for e in scenario.events if isinstance(e, Scan)]
        a = np.array([(k[s], d, lid) for s, d, lid in arows.tolist()], dtype=np.int64)
        a = a[np.lexsort((a[:, 1], a[:, 2], a[:, 0]))]
        want = {key.split("/")[-1]: v for key, v in golden.items() if key.startswith(f"numba/{name}/")}
        assert np.array_equal(a, want["associations"]), name
        assert np.array_equal(r["n_landmarks"], want["n_landmarks"]), name
        last = slice(r["map_offsets"][-2], r["map_offsets"][-1])
        assert np.array_equal(r["ids"][last], want["ids"]), name
        for key, got in (("poses", r["poses"]), ("positions", r["positions"][last]), ("rma", r["rma"][last]),
                         ("efa", r["efa"][last])):
            np.testing.assert_allclose(got, want[key], rtol=1e-12, atol=1e-12, err_msg=f"{name}/{key}")
        # and the reference run of the same module agrees on the decisions
        assert np.array_equal(want["associations"], carpark_run(profile, seed, extent, "numba")["associations"])


def test_run_filter_takes_the_steps_form_when_fused_is_false():
    """``filter.fused`` false runs the engine's steps form (its steps in Python over the compiled
    kernels): the compiled run's decisions and estimates."""
    cfg = profile_config("apsipa")
    events = _scenario(cfg, 4).events
    fused = run_filter(cfg, events)
    slow = run_filter(replace(cfg, filter=replace(cfg.filter, fused=False)), events)
    assert (fused.engine, slow.engine) == ("fused", "fused-steps")
    np.testing.assert_allclose(fused.poses, slow.poses, rtol=1e-9, atol=1e-9)
    assert np.array_equal(fused.n_associated, slow.n_associated)
    assert np.array_equal(fused.nis_count, slow.nis_count)
    assert [m.ids.tolist() for m in fused.maps] == [m.ids.tolist() for m in slow.maps]


def _message(cfg, events) -> str:
    with pytest.raises(InputError) as exc:
        run_filter(cfg, events)
    return str(exc.value)


@pytest.mark.parametrize("bad", ["negative-range", "time-backwards", "nan-control", "zero-dt", "overflow", "not-an-event"])
def test_bad_input_same_error_in_each_form(bad):
    cfg = profile_config("apsipa")
    events = list(_scenario(cfg, 1).events[:41])
    i = next(n for n in range(20, 41) if isinstance(events[n], Scan))
    j = next(n for n in range(20, 41) if isinstance(events[n], Odometry))
    if bad == "negative-range":
        polar = events[i].polar.copy()
        polar[0, 0] = -1.0
        events[i] = replace(events[i], polar=polar)
    elif bad == "time-backwards":
        events[i] = replace(events[i], t=-5.0)
    elif bad == "nan-control":
        events[j] = replace(events[j], control=np.array([np.nan, 0.0]))
    elif bad == "zero-dt":
        events[j] = replace(events[j], dt=0.0)
    elif bad == "overflow":
        events[j] = replace(events[j], control=np.array([1e308, 0.0]), dt=1e10)
    else:
        events[j] = "odometry"
    fused = _message(cfg, events)
    assert fused == _message(replace(cfg, filter=replace(cfg.filter, fused=False)), events)
    assert "\n" not in fused and ("expected" in fused)


def test_comparison_detects_a_different_run():
    """Negative control: the comparison above fails for a run with another association threshold."""
    cfg = profile_config("apsipa")
    events = _scenario(cfg, 3).events
    rows = _event_by_event(cfg, events)[0]
    other = replace(cfg, landmarks=replace(cfg.landmarks, beta=cfg.landmarks.beta * 0.8))
    _, arows = _fused.run(EkfSlam(other), events)
    assert sorted(map(tuple, arows.tolist())) != rows


def test_timing_reports_each_scan_and_changes_nothing():
    """``timing=True`` (benchmarks/bench_scaling.py) adds each scan's wall time and leaves every
    result as it was, to the bit."""
    import time

    cfg = profile_config("apsipa")
    events = _scenario(cfg, 2).events
    plain, rows = _fused.run(EkfSlam(cfg), events)
    t0 = time.perf_counter()
    timed, rows_t = _fused.run(EkfSlam(cfg), events, timing=True)
    wall = time.perf_counter() - t0
    assert "seconds" not in plain and timed["seconds"].shape == plain["poses"][:, 0].shape
    assert np.all(timed["seconds"] > 0) and timed["seconds"].sum() < wall
    assert np.array_equal(rows, rows_t)
    for key, value in plain.items():
        assert np.array_equal(value, timed[key], equal_nan=True), key


def test_a_scan_of_thousands_of_detections_runs_compiled():
    """A scan of 3,000 detections (the compiled DBSCAN's grid of cells, landmarks/_compiled.py
    neighbourhoods, instead of an m x m neighbourhood) runs in the fused engine, with the same
    associations, landmarks and poses as the steps form event by event (the labels against
    scikit-learn's: tests/test_backends.py)."""
    cfg = profile_config("apsipa")
    events = list(_scenario(cfg, 1).events[:40])
    rng = np.random.default_rng(0)
    scans = [i for i, e in enumerate(events) if hasattr(e, "polar")]
    for i in scans[3:5]:                    # a blob of clutter in two scans: clusters and landmarks of it
        n = 3000
        big = np.column_stack([rng.uniform(1, 30, n), rng.uniform(-np.pi / 3, np.pi / 3, n)])
        events[i] = replace(events[i], polar=np.concatenate([events[i].polar, big]))
    assert _assert_same_run(cfg, events) > 0
