"""ROS 2 ``radar_msgs/msg/RadarScan`` read directly (docs/recordings.md "Bags").

The message (ros-perception/radar_msgs, branch ros2): ``std_msgs/Header header`` and
``radar_msgs/RadarReturn[] returns``; each return holds float32 ``range`` (m), ``azimuth`` (rad,
counter-clockwise, REP 103), ``elevation`` (rad, negative below the sensor), ``doppler_velocity``
(m/s) and ``amplitude`` (dB), in the radar's frame. ``rosbags``' stock typestores do not carry
the package, so its two definitions are registered from their ``.msg`` text
(:func:`register_radar_msgs`); a bag that stores its own definitions (ROS 2 bags of format 9, MCAP)
is read with those.

Each return becomes a point ``x = r cos(el) cos(az)``, ``y = r cos(el) sin(az)``,
``z = r sin(el)`` of the same columns a PointCloud2 gives (``x``, ``y``, ``z``, Doppler, rcs), so
everything after the reader is shared. ``doppler_velocity`` is taken as the range rate (positive
receding), the convention of the other Doppler fields.
"""

from __future__ import annotations

import numpy as np

RADAR_SCAN = "radar_msgs/msg/RadarScan"
RADAR_RETURN = "radar_msgs/msg/RadarReturn"

#: The message definitions (field lists of RadarScan.msg and RadarReturn.msg).
DEFINITIONS = {
    RADAR_RETURN: "float32 range\nfloat32 azimuth\nfloat32 elevation\nfloat32 doppler_velocity\nfloat32 amplitude\n",
    RADAR_SCAN: "std_msgs/Header header\nradar_msgs/RadarReturn[] returns\n",
}
#: The channels of a RadarScan and the column each comes from.
MAPPING = {"z_m": "z", "doppler_mps": "doppler_velocity", "rcs": "amplitude"}


def register_radar_msgs(typestore) -> None:
    """Register ``radar_msgs/msg/RadarReturn`` and ``RadarScan`` in a ``rosbags`` typestore that lacks them."""
    from rosbags.typesys import get_types_from_msg

    for name in (RADAR_RETURN, RADAR_SCAN):
        if name not in typestore.types:
            typestore.register(get_types_from_msg(DEFINITIONS[name], name))


def scan_columns(msg) -> dict[str, np.ndarray]:
    """The columns ``x``, ``y``, ``z`` (m, radar frame), ``doppler_velocity`` (m/s) and ``amplitude``
    of one deserialised RadarScan, float64 arrays of its returns."""
    rows = np.array([(r.range, r.azimuth, r.elevation, r.doppler_velocity, r.amplitude) for r in msg.returns],
                    dtype=np.float64).reshape(-1, 5)
    rng, az, el = rows[:, 0], rows[:, 1], rows[:, 2]
    horiz = rng * np.cos(el)
    return {"x": horiz * np.cos(az), "y": horiz * np.sin(az), "z": rng * np.sin(el),
            "doppler_velocity": rows[:, 3], "amplitude": rows[:, 4]}
