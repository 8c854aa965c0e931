"""The fused engine one event at a time reports what each scan did (slam/fused/online.py ``Online.report``,
from the steps' own outputs, slam/fused/events.py ``ScanOut``) as EkfSlam.update reports it: the candidates,
associations, removed, confirmed and merged ids, the clusters, the tentatives, each new landmark's
detections, the NIS, and under the Doppler gate the moving detections and the ego-velocity, every scan.

Oracles: the whole stream's record in one run (an independent path: the engine's per-scan record and map,
not the steps' outputs): each scan's detections, associations (as ``(detection, landmark id)`` rows), NIS,
the ids confirmed (new in the map) and those removed or merged away (gone from it); and the same events
in the engine's Python form (every field, the ids and counts exactly, the NIS to 1e-9). Cases: the car-park
trial (seed 7) in each family of the fused engine (default, partial view, JCBB, bias states), and the first
five seconds of nuScenes scene-0061 under the automotive profile (five radars, the Doppler gate, Doppler
odometry, merges, moving detections). A negative control checks that the comparison sees a wrong id.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from conftest import require
from helpers import first_seconds, shared_data

require("numba")

from radarslam.config import profile_config  # noqa: E402
from radarslam.config.variants import Variant, apply_variant  # noqa: E402
from radarslam.simulation.scenario import generate_scenario  # noqa: E402
from radarslam.slam.filter import EkfSlam  # noqa: E402
from radarslam.slam.fused.online import Online  # noqa: E402

EXACT = ("index", "n_detections", "n_candidates", "n_associated", "removed", "confirmed", "merged", "n_clusters",
         "n_tentative")
FAMILIES = {"default": None, "view": {"extent": {"use_in_slam": True, "spread_model": "visible-faces"}},
            "jcbb": {"landmarks": {"associator": "jcbb"}}, "bias": {"filter": {"odometry_bias": "states"}}}


def _differences(a, b) -> list[str]:
    """What differs between two ScanReports (an empty list: nothing)."""
    out = [f for f in EXACT if getattr(a, f) != getattr(b, f)]
    for name in ("associations", "created"):
        x, y = getattr(a, name), getattr(b, name)
        if x.keys() != y.keys() or any(not np.array_equal(np.sort(x[k]), np.sort(y[k])) for k in x):
            out.append(name)
    if a.nis.shape != b.nis.shape or not np.allclose(a.nis, b.nis, rtol=0.0, atol=1e-9):
        out.append("nis")
    if not np.array_equal(np.sort(a.moving), np.sort(b.moving)):
        out.append("moving")
    if (a.ego is None) != (b.ego is None) or (a.ego is not None and not np.allclose(a.ego.v, b.ego.v, equal_nan=True)):
        out.append("ego")
    return out


def _reports(cfg, events, how: str):
    """Each scan's report from the Python form and from Online (``how``) on the same events, after checking
    the latter against the whole stream's record (:func:`_against_record`)."""
    slam, online = EkfSlam(cfg, engine="python"), Online(EkfSlam(cfg), how)
    pairs = []
    for ev in events:
        ra = slam.process(ev)
        rb = online.process(ev)
        assert (ra is None) == (rb is None)
        if ra is not None:
            pairs.append((ra, online.report))
    _against_record(cfg, events, [rb for _, rb in pairs])
    return pairs


def _against_record(cfg, events, reports) -> None:
    """``reports`` say what the whole stream's record says of each scan (module docstring)."""
    from radarslam.slam import _fused

    r, arows = _fused.run(EkfSlam(cfg), events)
    off, prev = r["map_offsets"], set()
    assert len(reports) == off.shape[0] - 1
    for s, rep in enumerate(reports):
        assert rep.n_detections == r["n_detections"][s] and rep.n_associated == r["n_associated"][s]
        mine = sorted((int(d), int(lid)) for lid, dets in rep.associations.items() for d in dets)
        assert mine == sorted(map(tuple, arows[arows[:, 0] == s][:, 1:].tolist())), s
        np.testing.assert_allclose(rep.nis, r["nis"][r["nis_offsets"][s]:r["nis_offsets"][s + 1]], rtol=0, atol=1e-12)
        now = set(r["ids"][off[s]:off[s + 1]].tolist())
        assert set(rep.confirmed) == now - prev, s
        assert set(rep.removed) | {gone for _, gone in rep.merged} == prev - now, s
        prev = now


@pytest.fixture(scope="module")
def carpark():
    return generate_scenario(profile_config(), np.random.default_rng(7)).events


@pytest.mark.parametrize("family", list(FAMILIES))
def test_the_car_park_reports_as_its_record_and_the_python_form(carpark, family):
    cfg = profile_config()
    if FAMILIES[family]:
        cfg = apply_variant(cfg, Variant(family, family, FAMILIES[family]))
    pairs = _reports(cfg, carpark, "compiled" if family == "default" else "steps")
    assert len(pairs) == 120
    assert [(ra.index, _differences(ra, rb)) for ra, rb in pairs if _differences(ra, rb)] == []
    assert sum(len(ra.confirmed) for ra, _ in pairs) > 5 and sum(ra.n_associated for ra, _ in pairs) > 100
    ra, rb = next((ra, rb) for ra, rb in pairs if ra.confirmed)          # negative control: a wrong id is seen
    wrong = dataclasses.replace(rb, confirmed=[i + 1 for i in rb.confirmed],
                                created={i + 1: m for i, m in rb.created.items()})
    assert _differences(ra, wrong) == ["confirmed", "created"]


def test_a_nuscenes_scene_reports_as_its_record_and_the_python_form(tmp_path):
    """Five radars, the Doppler gate and Doppler odometry: the gate's moving rows and ego-velocity, the
    associations and each new landmark's detections as rows of the scan before the gate."""
    from radarslam.io.recording import read_recording
    from radarslam.runs.recording import run_recording

    rec = read_recording(first_seconds(shared_data() / "nuscenes_radar" / "scene-0061", 5.0, tmp_path / "rec"))
    run = run_recording(rec, profile_config("automotive"))
    pairs = _reports(run.filter_config, run.events, "compiled")
    assert len(pairs) > 250
    assert [(ra.index, _differences(ra, rb)) for ra, rb in pairs if _differences(ra, rb)] == []
    assert sum(ra.moving.size for ra, _ in pairs) > 0 and all(ra.ego is not None for ra, _ in pairs)
    assert sum(len(ra.confirmed) for ra, _ in pairs) > 5
