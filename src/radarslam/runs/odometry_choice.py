"""``filter.odometry = "auto"``: what drives the prediction, decided by what the recording carries
(docs/method.md c.10.5.2).

A recording whose detections carry a Doppler column and whose odometry is a unicycle's (a speed and
a yaw rate, the yaw rate read as the gyro) is driven by ``"both"``: the wheel speed fused with the
radar's Doppler velocity (the rig's joint fit on a rig, c.12), the gyro's yaw rate. Anything else is
driven by ``"odometer"`` (the readings, the paper's prediction). The choice is made once, before the
compile policy and the filter see the config, and the run says which and why (``metrics.json``
``odometry``, its notes); the written ``config.toml`` holds the value chosen. A filter built from a
config still saying ``"auto"`` (a simulation, whose scans carry no Doppler fit) takes the odometer
(``EkfSlam.__init__``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["resolved_odometry"]


def resolved_odometry(rec, config):
    """``(config, choice)``: ``config`` with ``filter.odometry`` "auto" replaced by what ``rec``
    supports (module docstring) and ``choice`` ``{"chosen", "from"}`` for the run's metrics; a config
    naming its own value is returned unchanged with ``choice`` None."""
    f = config.filter
    if f.odometry != "auto":
        return config, None
    d = rec.channels.get("doppler_mps")
    has_doppler = d is not None and d.size > 0 and bool(np.isfinite(d).any())
    unicycle = rec.odo_kind == "unicycle" and rec.odo_t.size >= 2
    needs_odometer = [k for k, on in (("filter.bias_thrust", f.bias_thrust),
                                      ("filter.radar_time_states", f.radar_time_states),
                                      (f"filter.jacobians {f.jacobians!r}", f.jacobians != "standard"),
                                      (f"filter.motion_model {f.motion_model!r}", f.motion_model != "unicycle"),
                                      (f"filter.yaw_rate {f.yaw_rate!r}", f.yaw_rate != "gyro")) if on]
    if has_doppler and unicycle and not needs_odometer:
        chosen, why = "both", ("the detections carry a Doppler column and the odometry a speed and a yaw rate: the "
                               "wheel speed fused with the radar's Doppler velocity, the gyro's yaw rate (c.10.5)")
    else:
        lacks = ("the recording has no Doppler column" if not has_doppler else
                 f"the recording's odometry is of kind {rec.odo_kind!r}, not a speed and a yaw rate" if not unicycle
                 else f"{', '.join(needs_odometer)} asks for the odometer")
        chosen, why = "odometer", f"{lacks}: the odometer's readings drive the prediction"
    config = dataclasses.replace(config, filter=dataclasses.replace(f, odometry=chosen))
    return config, {"chosen": chosen, "from": f"filter.odometry 'auto': {why}"}
