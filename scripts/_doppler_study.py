"""Moving cars kept out of the map by the Doppler gate (docs/method.md c.10.4).

:func:`moving_landmark_trial` runs one simulated trial and reports which confirmed landmarks were
born on a moving car (by the true sources of the detections of the cluster each was confirmed
from) and the pose errors; :func:`gate_study` runs the gate's settings (:data:`GATE_SETTINGS`) on the
same trials with the moving cars and without them (the pose-error reference), and counts the trials
in which a moving car became a landmark, with the Clopper-Pearson interval.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from radarslam.config import Config, validate
from radarslam.simulation.trial import with_initial_estimate
from radarslam.metrics.pose import avg_rmse, pose_errors
from radarslam.metrics.statistics import bootstrap_avg_rmse, bootstrap_counts, clopper_pearson, percentile_interval
from radarslam.simulation.doppler import is_moving_source
from radarslam.simulation.scenario import generate_scenario
from radarslam.slam.filter import EkfSlam

#: The gate's settings compared (``[filter]`` overlays): off (the negative control), the
#: per-detection test alone (c.10.4.1), with the object test (c.10.4.2), with the memory (c.10.4.3),
#: and with the young landmarks' removal too (c.10.4.4; the defaults).
GATE_SETTINGS: dict[str, dict] = {
    "off": {"doppler_gate": False},
    "detection": {"doppler_gate": True, "doppler_object_radius_m": 0.0, "doppler_memory_scans": 0,
                  "doppler_probation_scans": 0},
    "object": {"doppler_gate": True, "doppler_memory_scans": 0, "doppler_probation_scans": 0},
    "memory": {"doppler_gate": True, "doppler_probation_scans": 0},
    "full": {"doppler_gate": True},
}


#: A moving car's landmark removed fewer scans than this after its creation (by the landmark test,
#: c.10.4.4, or M/N) is not counted as *lasting*; one still in the map at the end always is.
LASTING_SCANS = 5


def _with_filter(config: Config, overlay: dict) -> Config:
    return validate(dataclasses.replace(config, filter=dataclasses.replace(config.filter, **overlay)))


def moving_landmark_trial(config: Config, seed, gate: bool | dict = True) -> dict:
    """One trial (``radar.doppler`` on; ``seed`` an int or a SeedSequence) with the gate on
    (``True``: the configuration's gate settings), off, or a ``[filter]`` overlay (dict).

    Returns ``{"moving_landmarks": confirmed landmarks whose cluster's detections are mostly a
    moving car's, "mixed_landmarks": those with any moving car's detection, "landmarks": all
    confirmed, "moving_detections": moving-car detections, "gated_moving": of those dropped by the
    gate, "static_detections", "gated_static": parked-car detections dropped, "moving_associated":
    moving-car detections associated to a landmark, "position_errors",
    "heading_errors": (K,) m and rad, "moving_landmark_lifetimes": scans each moving car's landmark
    stayed in the map (inf: to the end)}``.
    """
    overlay = gate if isinstance(gate, dict) else {"doppler_gate": bool(gate)}
    config = _with_filter(config, overlay)
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    sc = generate_scenario(config, np.random.default_rng(ss))
    slam = EkfSlam(with_initial_estimate(config, sc, ss))
    out = {"moving_landmarks": 0, "mixed_landmarks": 0, "landmarks": 0, "moving_detections": 0, "gated_moving": 0,
           "static_detections": 0, "gated_static": 0, "moving_associated": 0}
    poses, born, lifetimes = [], {}, []    # the moving cars' landmarks: id -> creation scan; scans they lived
    k = 0
    for ev in sc.events:
        rep = slam.process(ev)
        if rep is None:
            continue
        src = sc.truth.sources[k]
        moving = is_moving_source(src)
        out["moving_detections"] += int(moving.sum())
        out["gated_moving"] += int(moving[rep.moving].sum())
        out["static_detections"] += int((src >= 0).sum())
        out["gated_static"] += int((src[rep.moving] >= 0).sum())
        assoc = np.concatenate([np.empty(0, dtype=int), *rep.associations.values()])
        out["moving_associated"] += int(is_moving_source(src[assoc]).sum())
        for lid in rep.removed:
            if lid in born:
                lifetimes.append(k - born.pop(lid))
        for lid, members in rep.created.items():
            n_mov = int(is_moving_source(src[members]).sum())
            out["landmarks"] += 1
            out["moving_landmarks"] += int(2 * n_mov > members.size)
            out["mixed_landmarks"] += int(n_mov > 0)
            if 2 * n_mov > members.size:
                born[lid] = k
        poses.append(slam.pose.copy())
        k += 1
    lifetimes += [math.inf] * len(born)         # still in the map at the end
    out["moving_landmark_lifetimes"] = lifetimes
    pos, head = pose_errors(np.array(poses), sc.truth.poses)
    out["position_errors"], out["heading_errors"] = pos, head
    return out


def summarise(rows: list[dict]) -> dict:
    """Counts over trials (with the 95% Clopper-Pearson interval of the share of trials with a
    moving car's landmark) and the pose's avg. RMSE (f.1) over them."""
    n = len(rows)
    bad = sum(r["moving_landmarks"] > 0 for r in rows)
    lasting = sum(any(t >= LASTING_SCANS for t in r["moving_landmark_lifetimes"]) for r in rows)
    moving = sum(r["moving_detections"] for r in rows)
    static = sum(r["static_detections"] for r in rows)
    return {"trials": n, "trials_with_moving_landmark": bad, "share_ci95": clopper_pearson(bad, n),
            "trials_without_moving_landmark_ci95": [1.0 - x for x in clopper_pearson(bad, n)[::-1]],
            "trials_with_lasting_moving_landmark": lasting, "lasting_share_ci95": clopper_pearson(lasting, n),
            "trials_with_mixed_landmark": sum(r["mixed_landmarks"] > 0 for r in rows),
            "moving_landmarks": sum(r["moving_landmarks"] for r in rows),
            "landmarks": sum(r["landmarks"] for r in rows),
            "moving_detections_gated": sum(r["gated_moving"] for r in rows) / max(1, moving),
            "moving_detections_associated": sum(r["moving_associated"] for r in rows) / max(1, moving),
            "static_detections_gated": sum(r["gated_static"] for r in rows) / max(1, static),
            "position_avg_rmse_m": avg_rmse(np.array([r["position_errors"] for r in rows])),
            "heading_avg_rmse_deg": math.degrees(avg_rmse(np.array([r["heading_errors"] for r in rows])))}


def gate_study(config: Config, seeds, *, moving_vehicles: int = 3, settings: dict | None = None,
               reference: bool = True) -> dict:
    """Each of ``settings`` (name -> ``[filter]`` overlay; :data:`GATE_SETTINGS` by default) on the
    trials ``seeds`` with ``moving_vehicles`` moving cars, and (``reference``) on the same trials
    without them: ``{name: summary, name + "/static": summary, name + "/change_pct": position and
    heading avg. RMSE with the cars against without, %}`` (:func:`summarise`)."""
    config = dataclasses.replace(config, radar=dataclasses.replace(config.radar, doppler=True))
    moving_cfg = dataclasses.replace(config, world=dataclasses.replace(config.world, moving_vehicles=moving_vehicles))
    static_cfg = dataclasses.replace(config, world=dataclasses.replace(config.world, moving_vehicles=0))
    seeds = list(seeds)
    res = {}
    for name, overlay in (settings or GATE_SETTINGS).items():
        rows = [moving_landmark_trial(moving_cfg, s, overlay) for s in seeds]
        res[name] = summarise(rows)
        if reference:
            ref = [moving_landmark_trial(static_cfg, s, overlay) for s in seeds]
            res[f"{name}/static"] = summarise(ref)
            res[f"{name}/change_pct"] = paired_change(rows, ref)
    return res


def paired_change(rows: list[dict], ref: list[dict], n_boot: int = 2000) -> dict:
    """Position and heading avg. RMSE of ``rows`` against ``ref`` (the same trials), in %, with the
    95% percentile interval of the paired trial bootstrap (f.2; resamples from a generator seeded 0)."""
    counts = bootstrap_counts(len(rows), n_boot, np.random.default_rng(0))
    out = {}
    for key, err in (("position_avg_rmse_m", "position_errors"), ("heading_avg_rmse_deg", "heading_errors")):
        a, b = np.array([r[err] for r in rows]), np.array([r[err] for r in ref])
        out[key] = 100.0 * (avg_rmse(a) / avg_rmse(b) - 1.0)
        out[key + "_ci95"] = [100.0 * (x - 1.0) for x in
                              percentile_interval(bootstrap_avg_rmse(a, counts) / bootstrap_avg_rmse(b, counts))]
    return out
