"""Moving cars kept out of the map by the Doppler gate (docs/method.md c.10.4, issue 26).

:func:`moving_landmark_trial` runs one simulated trial with moving cars and reports whether a
moving car became a confirmed landmark; :func:`gate_study` counts such trials with the gate on
and off (the negative control) on the same scenarios.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from radarslam.config import Config, validate
from radarslam.simulation.scenario import generate_scenario
from radarslam.slam.filter import EkfSlam

#: A landmark born within this distance (m) of a moving car's centre, nearer to it than to any
#: parked car present, is counted as the moving car's.
MOVING_MATCH_M = 3.0


def moving_landmark_trial(config: Config, seed: int, gate: bool) -> dict:
    """One trial (``world.moving_vehicles > 0``, ``radar.doppler`` on) with ``filter.doppler_gate = gate``.

    Returns ``{"moving_landmarks": count of confirmed landmarks born on a moving car,
    "landmarks": all confirmed, "moving_detections": moving-car detections, "gated_moving":
    of those the gate flagged, "gated_static": parked-car detections it flagged}``.
    """
    config = validate(dataclasses.replace(config, filter=dataclasses.replace(config.filter, doppler_gate=gate)))
    sc = generate_scenario(config, np.random.default_rng(np.random.SeedSequence(seed)))
    slam = EkfSlam(config)
    parked = np.array([v.center for v in sc.truth.vehicles]).reshape(-1, 2)
    out = {"moving_landmarks": 0, "landmarks": 0, "moving_detections": 0, "gated_moving": 0, "gated_static": 0}
    k = 0
    for ev in sc.events:
        rep = slam.process(ev)
        if rep is None:
            continue
        src = sc.truth.sources[k]
        moving_src = src <= -2
        out["moving_detections"] += int(moving_src.sum())
        out["gated_moving"] += int(moving_src[rep.moving].sum())
        out["gated_static"] += int((src[rep.moving] >= 0).sum())
        if rep.confirmed:
            pos = {int(i): p for i, p in zip(slam.state.ids(), slam.state.positions)}
            present = sc.truth.present[k]
            for lid in rep.confirmed:
                if lid not in pos:
                    continue
                p = pos[lid]
                out["landmarks"] += 1
                d_mov = np.linalg.norm(sc.truth.traffic.centres[k] - p, axis=1).min()
                d_park = np.linalg.norm(parked[present] - p, axis=1).min() if present.any() else np.inf
                out["moving_landmarks"] += int(d_mov <= MOVING_MATCH_M and d_mov < d_park)
        k += 1
    return out


def gate_study(config: Config, seeds, *, moving_vehicles: int = 3) -> dict:
    """Trials (``seeds``) where a moving car became a confirmed landmark, gate on and off."""
    config = dataclasses.replace(config, radar=dataclasses.replace(config.radar, doppler=True),
                                 world=dataclasses.replace(config.world, moving_vehicles=moving_vehicles))
    res = {}
    for gate in (True, False):
        rows = [moving_landmark_trial(config, s, gate) for s in seeds]
        res["on" if gate else "off"] = {
            "trials": len(rows), "trials_with_moving_landmark": sum(r["moving_landmarks"] > 0 for r in rows),
            "moving_landmarks": sum(r["moving_landmarks"] for r in rows),
            "landmarks": sum(r["landmarks"] for r in rows),
            "moving_detections_gated": sum(r["gated_moving"] for r in rows) / max(1, sum(r["moving_detections"]
                                                                                       for r in rows)),
            "static_detections_gated": sum(r["gated_static"] for r in rows)}
    return res
