"""Your own recording: plain CSV / NPZ files and ROS bags in, one :class:`~.stream.Recording` out.

- :mod:`.plain`: the plain format (docs/recordings.md), read and written;
- :mod:`.bag`: ROS 1 and ROS 2 (sqlite3, MCAP) bags read through ``rosbags`` (the ``ros`` extra);
- :mod:`.bag_write`: bags written (the simulator's export, the tests);
- :mod:`.pointcloud2`: PointCloud2 decoding by field offset and datatype;
- :mod:`.mounting`: a bag's ``/tf_static`` as a mounting (the one type,
  :class:`radarslam.core.mounting.Mounting`, re-exported there with the detections' moves);
- :mod:`.stream`: the :class:`~.stream.Recording` arrays and their event stream.
"""

from __future__ import annotations

from pathlib import Path

from radarslam.core.errors import InputError


def is_plain(path: str | Path) -> bool:
    """Whether ``path`` is a plain recording (a directory with ``detections.csv``, or an ``.npz`` file)."""
    path = Path(path)
    return (path.is_dir() and (path / "detections.csv").exists()) or path.suffix == ".npz"


def read_recording(path: str | Path, *, radar_topic: str | list[str] | None = None, odom_topic: str | None = None,
                   truth_topic: str | None = None, doppler_field: str | None = None, sensors=None):
    """A :class:`~.stream.Recording` from a plain recording or a bag (the topics are required for a bag).

    ``radar_topic`` may be a list of topics, a rig (:func:`~.bag.read_bag`); ``sensors`` (a
    ``dict[int, Mounting]``) gives a rig's mountings that the bag's ``/tf_static`` lacks.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"--recording: {path}: no such file or directory")
    if is_plain(path):
        from radarslam.io.recording.plain import read_plain

        return read_plain(path)
    if not radar_topic or not odom_topic:
        raise InputError(f"--recording {path}: a bag needs --radar-topic and --odom-topic")
    from radarslam.io.recording.bag import read_bag

    return read_bag(path, radar_topic, odom_topic, truth_topic, doppler_field=doppler_field, sensors=sensors)
