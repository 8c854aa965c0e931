"""scripts/automotive_study.py's Doppler dead reckoning (the radar alone's reference):
it starts from the truth interpolated at its first sweep, not at the next truth sample.

Oracle: io/recording/synthetic.py's car on an exact arc (8 m/s, 0.1 rad/s), a rig of a front, a rear
and a side radar whose sweeps lie 7 ms after the 50 Hz truth's samples, each detection given its
exact static Doppler plus N(0, (1 mm/s)^2) (seed 1). The rig's fit is then the car's velocity to
about 1e-4 m/s, and the dead reckoning from the right start follows the truth to < 5 mm over 3 s;
from the next truth sample it is 13 ms x 8 m/s = 0.10 m off from the first sweep on.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import numpy as np

from radarslam.io.recording.mounting import Mounting
from radarslam.io.recording.synthetic import synthetic_recording

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "scripts"))

import automotive_study  # noqa: E402

SPEED, TURN, LAG = 8.0, 0.1, 0.007
RIG = {0: Mounting(3.4, 0.0, 0.0, "test", 0, "front"), 1: Mounting(-0.6, 0.6, math.pi, "test", 1, "rear"),
       2: Mounting(2.4, -0.8, -math.pi / 2, "test", 2, "right")}


def _recording():
    rec = synthetic_recording(duration_s=3.0, speed_mps=SPEED, turn_rate_rad_s=TURN, sensors=RIG, returns=2,
                              sensor_delays_s={k: LAG for k in RIG})
    sid = rec.channels["sensor_id"].astype(int)
    d = np.empty(rec.det_t.size)
    for s, m in RIG.items():
        k = sid == s
        wp = np.array([SPEED - TURN * m.y, TURN * m.x])
        c, sn = math.cos(m.yaw), math.sin(m.yaw)
        w = np.array([c * wp[0] + sn * wp[1], -sn * wp[0] + c * wp[1]])
        d[k] = -(np.cos(rec.det_polar[k, 1]) * w[0] + np.sin(rec.det_polar[k, 1]) * w[1])
    d += 1e-3 * np.random.default_rng(1).standard_normal(d.size)
    return dataclasses.replace(rec, channels={**rec.channels, "doppler_mps": d})


def test_the_doppler_dead_reckoning_starts_at_the_interpolated_truth():
    rec = _recording()
    assert rec.det_t.min() == LAG and np.min(np.abs(rec.truth_t - LAG)) > 0.005     # between truth samples
    err = automotive_study.doppler_dead_reckoning(rec, None)
    assert err["position_rmse_m"] < 5e-3, err
    assert err["heading_rmse_deg"] < 0.01, err
