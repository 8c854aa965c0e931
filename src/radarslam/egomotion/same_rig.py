"""Whether a car's calibration (:class:`~radarslam.egomotion.car_calibration.CarCalibration`) was
computed on the rig of a recording (docs/method.md c.16.1): its yaw offsets correct the nominal
mountings it was computed against, so they hold only where those are the recording's."""

from __future__ import annotations

import math

from radarslam.core.errors import InputError

__all__ = ["SAME_POSITION_M", "SAME_YAW_SIGMAS", "check_same_rig"]


#: How far a radar's nominal position may differ between the calibration's rig and a recording's (m):
#: the calibration estimates no position, so the same rig gives the same surveyed numbers.
SAME_POSITION_M = 0.01
#: How many of the calibration's own standard deviations of a radar's yaw offset its nominal yaw may
#: differ by (a floor of 0.01 deg for a yaw offset held at its prior).
SAME_YAW_SIGMAS = 3.0


def check_same_rig(sensors, cal, key: str = "--calibration") -> None:
    """Refuses, in one line naming the sensor and the difference, a recording whose radars' nominal
    mountings (``sensors``: ``sensor_id`` -> :class:`~radarslam.core.mounting.Mounting`) are not the
    ones ``cal`` was computed on: a position more than :data:`SAME_POSITION_M` away, or a yaw more
    than :data:`SAME_YAW_SIGMAS` of the calibration's standard deviation of that radar's yaw offset
    (the radar furthest out named; the offsets are corrections to the nominal yaw, so they hold only
    on the same nominal rig). A calibration without ``mountings`` carries no rig and is not checked."""
    from radarslam.core.angles import wrap_pi

    if not cal.mountings or not sensors:
        return
    worst = None                                         # (sigmas, sensor_id, degrees off, the calibration's yaw, std)
    for j, sid in enumerate(cal.sensor_ids):
        if sid not in sensors:
            continue
        m, (x, y, yaw) = sensors[sid], cal.mountings[j]
        moved = math.hypot(m.x - x, m.y - y)
        if moved > SAME_POSITION_M:
            raise InputError(f"{key}: sensor {sid}: expected the calibration's rig, got a mounting {moved:.3f} m from "
                             f"its ({x:.3f}, {y:.3f}) m (a calibration holds only on the rig it was computed on)")
        turned = abs(float(wrap_pi(m.yaw - yaw)))
        sd = max(cal.yaw_offset_std[j] if j < len(cal.yaw_offset_std) else 0.0, math.radians(0.01))
        if turned > SAME_YAW_SIGMAS * sd and (worst is None or turned / sd > worst[0]):
            worst = (turned / sd, sid, turned, yaw, sd)
    if worst is not None:
        _, sid, turned, yaw, sd = worst
        raise InputError(f"{key}: sensor {sid}: expected the calibration's rig, got a nominal yaw "
                         f"{math.degrees(turned):.2f} deg from its {math.degrees(yaw):.2f} deg, beyond "
                         f"{SAME_YAW_SIGMAS:g} x its yaw offset's std {math.degrees(sd):.2f} deg (a calibration "
                         f"holds only on the rig it was computed on)")
