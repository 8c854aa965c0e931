"""The retirement's lever-arm margin (docs/method.md c.15).

A radar at lever arm ``l`` sees to ``d_r + |l|`` from the platform's origin, where the retirement
measures: nuScenes' front radar sits 3.412 m ahead of the rear axle, so with the automotive
profile's ``d_r`` = 250 m a landmark 252 m ahead (248.6 m from that radar, inside its reach) must
stay in the state. Both engines retire beyond ``d_r + max |l|`` = 253.412 m; a radar at the origin
(the car park) keeps ``d_r`` (the negative control: margin 0), and ``d_r`` 0 never retires.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from radarslam.config import RigSensorConfig, profile_config, validate

NUSCENES = [(0, 3.412, 0.0, 0.003491), (1, 2.422, 0.8, 1.542173), (2, 2.422, -0.8, -1.587901),
            (3, -0.562, 0.628, 3.044029), (4, -0.562, -0.618, -3.073699)]


def _config(rig=NUSCENES, retire=250.0):
    cfg = profile_config("automotive")
    return validate(dataclasses.replace(
        cfg, landmarks=dataclasses.replace(cfg.landmarks, retire_distance_m=retire),
        sensors=[RigSensorConfig(i, x, y, math.degrees(yaw)) for i, x, y, yaw in rig]))


def test_both_engines_retire_beyond_the_reach_plus_the_lever_arm():
    from radarslam.slam.filter import EkfSlam
    from radarslam.slam.fused.plan import _parameters

    cfg = _config()
    slam = EkfSlam(cfg)
    assert _parameters(slam).retire2 == pytest.approx(253.412 ** 2, rel=1e-12)       # the fused engine's
    from radarslam.slam.map_rows import retire_radius

    assert retire_radius(cfg.estimator) == pytest.approx(250.0 + 3.412, abs=1e-12)


def test_negative_control_a_radar_at_the_origin_keeps_d_r_and_zero_never_retires():
    from radarslam.slam.filter import EkfSlam
    from radarslam.slam.fused.plan import _parameters

    assert _parameters(EkfSlam(_config(rig=[]))).retire2 == pytest.approx(250.0 ** 2, rel=1e-12)
    assert _parameters(EkfSlam(_config(retire=0.0))).retire2 == 0.0
