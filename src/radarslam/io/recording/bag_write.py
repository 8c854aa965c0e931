"""Writing a :class:`Recording` as a ROS 1 bag or a ROS 2 bag (sqlite3 or MCAP storage) with ``rosbags``.

Messages (docs/recordings.md "Bags"): the radar as ``sensor_msgs/PointCloud2`` with FLOAT64 fields
``x``, ``y`` (+ ``z``, ``doppler``, ``rcs``, ``sensor_id`` when the recording has them) in the
radar frame, the odometry as ``nav_msgs/Odometry`` (forward speed ``twist.linear.x``, yaw rate
``twist.angular.z``), the truth as ``nav_msgs/Odometry`` poses, and the mounting on ``/tf_static``.
Times: ``stamp = origin + t`` in integer nanoseconds, header stamp and log time alike.

A rig (``rec.sensors``) is written as one radar topic per sensor (:func:`rig_topics`), its clouds in
the frame ``radar_<sensor_id>`` without a ``sensor_id`` field, and each frame's mounting on
``/tf_static`` (one message holding every transform), so that :func:`~.bag.read_bag` given the
topics in ``sensor_id`` order reads the same rig back.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError
from radarslam.io.recording.mounting import Mounting, yaw_quaternion
from radarslam.io.recording.pointcloud2 import encode
from radarslam.io.recording.stream import Recording

#: Bag formats :func:`write_bag` writes.
FORMATS = ("ros1", "sqlite3", "mcap")
#: Default topics and frames of written bags.
TOPICS = {"radar": "/radar/points", "odom": "/odom", "truth": "/truth", "tf_static": "/tf_static"}
FRAMES = {"base": "base_link", "radar": "radar", "world": "map", "odom": "odom"}
#: The time origin of written bags (ns): 2023-11-14T22:13:20Z, so no stamp is 0.
ORIGIN_NS = 1_700_000_000_000_000_000
#: Bag channel name of each optional detection column.
CHANNEL_FIELDS = {"z_m": "z", "doppler_mps": "doppler", "rcs": "rcs", "sensor_id": "sensor_id"}

TF_MESSAGE = "geometry_msgs/TransformStamped[] transforms\n"


def _typestore(fmt: str):
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore

    if fmt == "ros1":
        ts = get_typestore(Stores.ROS1_NOETIC)
        if "tf2_msgs/msg/TFMessage" not in ts.types:
            ts.register(get_types_from_msg(TF_MESSAGE, "tf2_msgs/msg/TFMessage"))
        return ts
    return get_typestore(Stores.ROS2_HUMBLE)


class _Msgs:
    """Message builders for one typestore (ROS 1 headers carry a ``seq``)."""

    def __init__(self, ts, ros1: bool):
        self.ts, self.ros1, self.T = ts, ros1, ts.types

    def header(self, ns: int, frame: str, seq: int = 0):
        stamp = self.T["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
        H = self.T["std_msgs/msg/Header"]
        return H(seq=seq, stamp=stamp, frame_id=frame) if self.ros1 else H(stamp=stamp, frame_id=frame)

    def vec(self, x=0.0, y=0.0, z=0.0):
        return self.T["geometry_msgs/msg/Vector3"](x=float(x), y=float(y), z=float(z))

    def quat(self, yaw: float):
        x, y, z, w = yaw_quaternion(float(yaw))
        return self.T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def cloud(self, ns: int, seq: int, cols: dict[str, np.ndarray], pad: int, frame: str = FRAMES["radar"]):
        fields, data, step = encode(cols, pad=pad)
        PF = self.T["sensor_msgs/msg/PointField"]
        n = len(cols["x"])
        return self.T["sensor_msgs/msg/PointCloud2"](
            header=self.header(ns, frame, seq), height=1, width=n,
            fields=[PF(name=f.name, offset=f.offset, datatype=f.datatype, count=1) for f in fields],
            is_bigendian=False, point_step=step, row_step=step * n, data=np.frombuffer(data, np.uint8),
            is_dense=True)

    def odometry(self, ns: int, seq: int, frame: str, pose=(0.0, 0.0, 0.0), twist=(0.0, 0.0)):
        T = self.T
        p = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=float(pose[0]), y=float(pose[1]), z=0.0),
                                        orientation=self.quat(pose[2]))
        tw = T["geometry_msgs/msg/Twist"](linear=self.vec(twist[0]), angular=self.vec(0.0, 0.0, twist[1]))
        return T["nav_msgs/msg/Odometry"](
            header=self.header(ns, frame, seq), child_frame_id=FRAMES["base"],
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=p, covariance=np.zeros(36)),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](twist=tw, covariance=np.zeros(36)))

    def tf_static(self, ns: int, m: Mounting, frames: dict[str, Mounting] | None = None):
        """``base_link`` -> ``radar`` at ``m``, or (``frames``) ``base_link`` -> each frame at its mounting."""
        T = self.T
        out = []
        for frame, mf in (frames or {FRAMES["radar"]: m}).items():
            tr = T["geometry_msgs/msg/Transform"](translation=self.vec(mf.x, mf.y), rotation=self.quat(mf.yaw))
            out.append(T["geometry_msgs/msg/TransformStamped"](header=self.header(ns, FRAMES["base"]),
                                                               child_frame_id=frame, transform=tr))
        return T["tf2_msgs/msg/TFMessage"](transforms=out)

    def serialize(self, msg, msgtype: str) -> bytes:
        return bytes(self.ts.serialize_ros1(msg, msgtype) if self.ros1 else self.ts.serialize_cdr(msg, msgtype))


def _open_writer(path: Path, fmt: str):
    if fmt == "ros1":
        from rosbags.rosbag1 import Writer

        return Writer(path)
    from rosbags.rosbag2 import StoragePlugin, Writer

    plugin = StoragePlugin.MCAP if fmt == "mcap" else StoragePlugin.SQLITE3
    return Writer(path, version=9, storage_plugin=plugin)


def rig_topics(sensors: dict[int, Mounting]) -> dict[int, str]:
    """Each sensor's radar topic in a written bag: its ``name`` when that is a topic (``/...``, as a
    rig read from a bag names its sensors), else ``/radar_<sensor_id>/points``."""
    out = {k: (m.name if m.name.startswith("/") else f"/radar_{k}/points") for k, m in sorted(sensors.items())}
    if len(set(out.values())) < len(out):
        raise InputError(f"bag: expected one radar topic per sensor, got {sorted(out.values())}")
    return out


def _rig_messages(rec: Recording, m: _Msgs, pad: int, ns_of):
    """The radar and ``/tf_static`` messages of a rig: sensor ``k``'s scans on its topic in frame
    ``radar_<k>``; a scan time without any detection is an empty cloud of the first sensor."""
    topics = rig_topics(rec.sensors)
    frames = {k: f"radar_{k}" for k in topics}
    st = rec.scan_times()
    out = [(TOPICS["tf_static"], "tf2_msgs/msg/TFMessage", ns_of(st[0]),
            m.tf_static(ns_of(st[0]), None, {frames[k]: rec.sensors[k] for k in topics}))]
    sid = rec.channels.get("sensor_id")
    if sid is None:
        if len(topics) > 1:
            raise InputError(f"{rec.source}: a rig of {len(topics)} sensors needs channels['sensor_id'], got none")
        sid = np.full(rec.det_t.size, float(next(iter(topics))))
    ch = {CHANNEL_FIELDS[c]: v for c, v in rec.channels.items() if c != "sensor_id"}
    seqs = dict.fromkeys(topics, 0)
    t = rec.det_t
    for k in topics:
        rows = np.flatnonzero(sid == k)
        rows = rows[np.argsort(t[rows], kind="stable")]
        times, starts = np.unique(t[rows], return_index=True)
        for ts, a, b in zip(times.tolist(), starts.tolist(), np.r_[starts[1:], rows.size].tolist()):
            r, az = rec.det_polar[rows[a:b], 0], rec.det_polar[rows[a:b], 1]
            cols = {"x": r * np.cos(az), "y": r * np.sin(az), **{n: v[rows[a:b]] for n, v in ch.items()}}
            out.append((topics[k], "sensor_msgs/msg/PointCloud2", ns_of(ts),
                        m.cloud(ns_of(ts), seqs[k], cols, pad, frames[k])))
            seqs[k] += 1
    first = next(iter(topics))
    empty = {"x": np.empty(0), "y": np.empty(0), **{n: np.empty(0) for n in ch}}
    for ts in np.setdiff1d(st, t).tolist():
        out.append((topics[first], "sensor_msgs/msg/PointCloud2", ns_of(ts),
                    m.cloud(ns_of(ts), seqs[first], empty, pad, frames[first])))
        seqs[first] += 1
    return out


def _messages(rec: Recording, mounting: Mounting | None, m: _Msgs, pad: int):
    """``(topic, msgtype, ns, message)`` of every message of ``rec``, in time order."""
    ns_of = lambda t: ORIGIN_NS + int(round(float(t) * 1e9))  # noqa: E731
    out = []
    if rec.sensors:
        out += _rig_messages(rec, m, pad, ns_of)
    elif mounting is not None:
        out.append((TOPICS["tf_static"], "tf2_msgs/msg/TFMessage", ns_of(rec.scan_times()[0]), m.tf_static(
            ns_of(rec.scan_times()[0]), mounting)))
    order = np.argsort(rec.det_t, kind="stable")
    t, polar = rec.det_t[order], rec.det_polar[order]
    ch = {CHANNEL_FIELDS[c]: v[order] for c, v in rec.channels.items()}
    st = rec.scan_times()
    a, b = np.searchsorted(t, st, "left"), np.searchsorted(t, st, "right")
    for seq, (ts, i, j) in enumerate(zip(st.tolist(), a.tolist(), b.tolist()) if not rec.sensors else ()):
        r, az = polar[i:j, 0], polar[i:j, 1]
        cols = {"x": r * np.cos(az), "y": r * np.sin(az)}
        cols.update({name: v[i:j] for name, v in ch.items()})
        out.append((TOPICS["radar"], "sensor_msgs/msg/PointCloud2", ns_of(ts), m.cloud(ns_of(ts), seq, cols, pad)))
    for seq, (ts, row) in enumerate(zip(rec.odo_t.tolist(), rec.odo)):
        out.append((TOPICS["odom"], "nav_msgs/msg/Odometry", ns_of(ts),
                    m.odometry(ns_of(ts), seq, FRAMES["odom"], twist=row)))
    if rec.truth is not None:
        for seq, (ts, pose) in enumerate(zip(rec.truth_t.tolist(), rec.truth)):
            out.append((TOPICS["truth"], "nav_msgs/msg/Odometry", ns_of(ts),
                        m.odometry(ns_of(ts), seq, FRAMES["world"], pose=pose)))
    out.sort(key=lambda x: x[2])
    return out


def write_bag(rec: Recording, path: str | Path, fmt: str = "mcap", *, mounting: Mounting | None = None,
              pad: int = 0) -> Path:
    """Write ``rec`` as a bag at ``path`` (a ``.bag`` file for ``ros1``, a new directory for ROS 2).

    Parameters
    ----------
    rec : Recording
        Detections in the sensor frame; odometry of kind ``unicycle`` (``nav_msgs/Odometry`` has no
        steering angle).
    path : path
        Must not exist.
    fmt : {"ros1", "sqlite3", "mcap"}
    mounting : Mounting, optional
        Written to ``/tf_static`` (``base_link`` -> ``radar``). Not with a rig (``rec.sensors``:
        one topic per sensor, :func:`rig_topics`, each frame's mounting on ``/tf_static``).
    pad : int
        Padding bytes after each point (to exercise readers).
    """
    if fmt not in FORMATS:
        raise InputError(f"bag format: expected one of {FORMATS}, got {fmt!r}")
    if rec.odo_kind != "unicycle":
        raise InputError(f"{rec.source}: a bag carries odometry as nav_msgs/Odometry (speed, yaw rate); "
                         f"got {rec.odo_kind!r} odometry")
    if rec.sensors and mounting is not None:
        raise InputError(f"{rec.source}: a rig's bag carries each sensor's own mounting (rec.sensors); expected "
                         "no mounting argument, got one")
    path = Path(path)
    if path.exists():
        raise InputError(f"bag {path}: expected a new path, got an existing one")
    m = _Msgs(_typestore(fmt), fmt == "ros1")
    msgs = _messages(rec, mounting, m, pad)
    with _open_writer(path, fmt) as w:
        conns = {}
        for topic, msgtype, ns, msg in msgs:
            if topic not in conns:
                conns[topic] = w.add_connection(topic, msgtype, typestore=m.ts)
            w.write(conns[topic], ns, m.serialize(msg, msgtype))
    return path
