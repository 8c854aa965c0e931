"""Reading a recording from a ROS 1 bag or a ROS 2 bag (sqlite3 or MCAP storage) with ``rosbags``.

Topics (docs/recordings.md "Bags"): the radar as ``sensor_msgs/PointCloud2`` (float fields ``x``,
``y`` in the radar frame, optional ``z``, Doppler, rcs / intensity, sensor id) or as ROS 2
``radar_msgs/msg/RadarScan`` (:mod:`.radar_scan`), the odometry as
``nav_msgs/Odometry`` (forward speed ``twist.twist.linear.x``, yaw rate ``twist.twist.angular.z``),
an optional truth as ``nav_msgs/Odometry`` or ``geometry_msgs/PoseStamped``, and the mounting from
``/tf_static`` when it holds the radar's frame.

Several radars (a rig): several radar topics, each one sensor (``sensor_id`` 0, 1, ... in the order
given), each message one scan, each topic's mounting from ``/tf_static`` for its clouds'
``frame_id`` (else from a sensors table passed in, e.g. ``run --sensors FILE``); the result holds
:attr:`Recording.sensors` (``name`` = the topic) and ``channels["sensor_id"]``, detections merged in
time order (:func:`_read_rig`).

Time: each topic uses its header stamps; a topic whose stamps are all 0 uses the bag's log time
(a warning in :attr:`Recording.notes`), and such a mix is refused when the header clock of another
topic is more than :data:`MAX_CLOCK_OFFSET_S` away from the log time. Times are returned in seconds
relative to the first radar message over every radar topic (``Recording.t0_ns`` is that origin).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from radarslam.core.errors import InputError
from radarslam.io.recording.mounting import Mounting, mounting_from_transform, quaternion_to_rpy
from radarslam.io.recording.pointcloud2 import cloud_fields, decode
from radarslam.io.recording.radar_scan import MAPPING as RADAR_SCAN_MAPPING
from radarslam.io.recording.radar_scan import RADAR_SCAN, scan_columns
from radarslam.io.recording.stream import Recording

#: Field names recognised as Doppler (radial velocity, m/s), in order of preference.
DOPPLER_NAMES = ("doppler", "velocity", "v_doppler_mps", "v_r", "VrelRad", "doppler_velocity", "radial_velocity",
                 "radar_relative_radial_velocity")
RCS_NAMES = ("rcs", "RCS", "intensity", "snr")
SENSOR_ID_NAMES = ("sensor_id",)
#: Cartesian velocity fields, refused unless a Doppler field is named (they are not a radial velocity).
CARTESIAN_VELOCITY = ("vx", "vy", "v_x", "v_y", "vx_comp", "vy_comp")
#: Header clocks this far (s) from the log time may not be mixed with log times.
MAX_CLOCK_OFFSET_S = 5.0

POINTCLOUD2 = "sensor_msgs/msg/PointCloud2"
ODOMETRY = "nav_msgs/msg/Odometry"
POSE_STAMPED = "geometry_msgs/msg/PoseStamped"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"


def choose_fields(names: list[str], doppler_field: str | None, where: str) -> dict[str, str]:
    """Map the cloud's field names to the recording's channels (``z_m``, ``doppler_mps``, ``rcs``, ``sensor_id``)."""
    out = {}
    for need in ("x", "y"):
        if need not in names:
            raise InputError(f"{where}: expected float fields x and y in the radar frame, got fields {names}")
    if "z" in names:
        out["z_m"] = "z"
    if doppler_field is not None:
        if doppler_field not in names:
            raise InputError(f"{where}: --doppler-field {doppler_field!r} is not a field of the cloud, got {names}")
        out["doppler_mps"] = doppler_field
    else:
        found = [n for n in DOPPLER_NAMES if n in names]
        if found:
            out["doppler_mps"] = found[0]
        else:
            cart = [n for n in CARTESIAN_VELOCITY if n in names]
            if cart:
                raise InputError(f"{where}: fields {cart} look like Cartesian velocities, not a radial (Doppler) "
                                 "velocity; name the Doppler field with --doppler-field NAME")
    for key, cands in (("rcs", RCS_NAMES), ("sensor_id", SENSOR_ID_NAMES)):
        found = [n for n in cands if n in names]
        if found:
            out[key] = found[0]
    return out


def _stamp_ns(header) -> int:
    return int(header.stamp.sec) * 10**9 + int(header.stamp.nanosec)


class _Bag:
    """An open bag: its connections by topic and a guarded message iterator."""

    def __init__(self, reader, path: Path):
        self.r, self.path = reader, path
        self.topics: dict[str, list] = {}
        for c in reader.connections:
            self.topics.setdefault(c.topic, []).append(c)

    def check(self, topic: str, types: tuple[str, ...], what: str) -> None:
        if topic not in self.topics:
            raise InputError(f"bag {self.path}: {what} topic {topic} not found; topics: {', '.join(sorted(self.topics))}")
        got = {c.msgtype for c in self.topics[topic]}
        if not got <= set(types):
            raise InputError(f"bag {self.path} topic {topic}: expected {' or '.join(types)} for the {what}, "
                             f"got {', '.join(sorted(got))}")

    def messages(self, topic: str):
        """``(log ns, message)`` of ``topic``; a damaged bag is one InputError."""
        try:
            for conn, log_ns, raw in self.r.messages(connections=self.topics[topic]):
                yield log_ns, self.r.deserialize(raw, conn.msgtype)
        except InputError:
            raise
        except Exception as exc:  # rosbags raises its own types, struct and decoding errors on damage
            raise InputError(f"bag {self.path} topic {topic}: cannot read a message ({type(exc).__name__}: "
                             f"{exc}); a truncated or damaged bag?") from None


def _times(stamps: list[int], logs: list[int], where: str, notes: list[str]) -> tuple[np.ndarray, bool]:
    """The times (ns) a topic uses, and whether they are log times."""
    st, lg = np.array(stamps, dtype=np.int64), np.array(logs, dtype=np.int64)
    zero = st == 0
    if zero.all():
        notes.append(f"{where}: every header stamp is 0; using the bag's log time")
        return lg, True
    if zero.any():
        raise InputError(f"{where}: header stamps are 0 in {int(zero.sum())} of {zero.size} messages; expected all "
                         "or none (mixed clocks)")
    return st, False


def _read_radar(bag: _Bag, topic: str, doppler_field: str | None):
    stamps, logs, frames, clouds = [], [], [], []
    mapping = None
    scan = {c.msgtype for c in bag.topics[topic]} == {RADAR_SCAN}
    if scan and doppler_field is not None and doppler_field != "doppler_velocity":
        raise InputError(f"bag {bag.path} topic {topic}: --doppler-field {doppler_field!r}: a radar_msgs/RadarScan "
                         "carries its Doppler in doppler_velocity; expected that name or none")
    for i, (log_ns, msg) in enumerate(bag.messages(topic)):
        where = f"bag {bag.path} topic {topic} message {i + 1}"
        if scan:
            mapping = RADAR_SCAN_MAPPING
            names = ["x", "y"] + list(mapping.values())
            cols = scan_columns(msg)
        else:
            fields = cloud_fields(msg)
            if mapping is None:
                mapping = choose_fields([f.name for f in fields], doppler_field, where)
            names = ["x", "y"] + list(mapping.values())
            cols = decode(fields, msg.data, width=int(msg.width), height=int(msg.height),
                          point_step=int(msg.point_step), row_step=int(msg.row_step),
                          is_bigendian=bool(msg.is_bigendian), names=names, where=where)
        for n in names:
            bad = ~np.isfinite(cols[n])
            if bad.any():
                raise InputError(f"{where} field {n}: expected finite values, got NaN or inf at point "
                                 f"{int(np.argmax(bad))} of {bad.size}")
        stamps.append(_stamp_ns(msg.header)), logs.append(log_ns), frames.append(str(msg.header.frame_id))
        clouds.append(cols)
    if not clouds:
        raise InputError(f"bag {bag.path} topic {topic}: expected PointCloud2 messages, got none")
    if sum(c["x"].size for c in clouds) == 0:
        raise InputError(f"bag {bag.path} topic {topic}: every cloud is empty (no detections)")
    return stamps, logs, frames, clouds, mapping


def _read_poses(bag: _Bag, topic: str, kind: str):
    """``(stamps, logs, rows)`` of an odometry topic (rows ``[v, yaw rate]``) or a truth topic (``[x, y, yaw]``)."""
    stamps, logs, rows = [], [], []
    for log_ns, msg in bag.messages(topic):
        stamps.append(_stamp_ns(msg.header)), logs.append(log_ns)
        if kind == "odom":
            tw = msg.twist.twist
            rows.append((tw.linear.x, tw.angular.z))
        else:
            pose = msg.pose.pose if hasattr(msg, "twist") else msg.pose
            q = pose.orientation
            rows.append((pose.position.x, pose.position.y, quaternion_to_rpy(q.x, q.y, q.z, q.w)[2]))
    if not rows:
        raise InputError(f"bag {bag.path} topic {topic}: expected messages, got none")
    arr = np.array(rows, dtype=float)
    if not np.all(np.isfinite(arr)):
        i = int(np.argmax(~np.all(np.isfinite(arr), axis=1)))
        raise InputError(f"bag {bag.path} topic {topic} message {i + 1}: expected finite values, got NaN or inf")
    return stamps, logs, arr


def _mounting(bag: _Bag, frame: str, notes: list[str]) -> Mounting | None:
    if "/tf_static" not in bag.topics or not frame:
        return None
    bag.check("/tf_static", (TF_MESSAGE,), "static transform")
    for _, msg in bag.messages("/tf_static"):
        for tr in msg.transforms:
            if str(tr.child_frame_id).lstrip("/") == frame.lstrip("/"):
                return mounting_from_transform(tr.transform.translation, tr.transform.rotation,
                                               f"bag {bag.path} /tf_static {tr.header.frame_id} -> {frame}")
    notes.append(f"bag {bag.path}: /tf_static has no transform to the radar frame {frame!r}; using the config's mounting")
    return None


def open_bag(path: Path):
    """An open ``rosbags`` AnyReader on ``path`` (the bag file, or a ROS 2 bag directory)."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise InputError(f"{path}: reading bags needs the 'ros' extra (pip install \"radarslam[ros]\")") from None
    try:
        from radarslam.io.recording.radar_scan import register_radar_msgs

        store = get_typestore(Stores.ROS2_HUMBLE)
        register_radar_msgs(store)                  # bags without stored definitions (radar_scan.py)
        reader = AnyReader([path], default_typestore=store)
        reader.open()
    except Exception as exc:  # rosbags' reader errors on a missing, truncated or foreign file
        raise InputError(f"bag {path}: cannot open ({type(exc).__name__}: {exc})") from None
    return reader


def read_bag(path: str | Path, radar_topic: str | Sequence[str], odom_topic: str | None,
             truth_topic: str | None = None, *, doppler_field: str | None = None,
             sensors: dict[int, Mounting] | None = None) -> Recording:
    """Read a recording from a bag (see the module docstring for topics, fields and time).

    ``odom_topic=None`` reads the radar alone (empty odometry: to inspect or convert a bag without
    odometry; a run needs it). ``radar_topic`` may be a list: one topic reads as a single string
    does; several are a rig (:func:`_read_rig`), ``sensors`` then giving the mounting of a sensor
    whose frame ``/tf_static`` does not hold (unused with one topic).
    """
    path = Path(path)
    topics = [radar_topic] if isinstance(radar_topic, str) else list(radar_topic)
    if not topics:
        raise InputError(f"bag {path}: expected a radar topic, got none")
    if len(topics) > 1:
        return _read_rig(path, topics, odom_topic, truth_topic, doppler_field, sensors)
    radar_topic = topics[0]
    reader = open_bag(path)
    try:
        bag = _Bag(reader, path)
        bag.check(radar_topic, (POINTCLOUD2, RADAR_SCAN), "radar")
        if odom_topic:
            bag.check(odom_topic, (ODOMETRY,), "odometry")
        if truth_topic:
            bag.check(truth_topic, (ODOMETRY, POSE_STAMPED), "truth")
        notes: list[str] = []
        st, lg, frames, clouds, mapping = _read_radar(bag, radar_topic, doppler_field)
        radar_ns, radar_log = _times(st, lg, f"bag {path} topic {radar_topic}", notes)
        uses = [(radar_topic, st, lg, radar_log)]
        odo_ns, odo, truth_ns, truth = _read_odometry_and_truth(bag, path, odom_topic, truth_topic, notes, uses)
        _check_clocks(path, uses)
        mounting = _mounting(bag, frames[0], notes)
    finally:
        reader.close()
    return _assemble(path, radar_topic, odom_topic, truth_topic, radar_ns, clouds, mapping, odo_ns, odo,
                     truth_ns, truth, mounting, notes)


def _read_odometry_and_truth(bag: _Bag, path: Path, odom_topic, truth_topic, notes: list[str], uses: list):
    """The odometry ``(times ns, rows)`` (empty without ``odom_topic``) and the truth ``(times ns, poses)``
    (None without ``truth_topic``); each topic's clock use is appended to ``uses`` (:func:`_check_clocks`)."""
    odo_ns, odo = np.empty(0, dtype=np.int64), np.empty((0, 2))
    if odom_topic:
        ost, olg, odo = _read_poses(bag, odom_topic, "odom")
        odo_ns, odo_log = _times(ost, olg, f"bag {path} topic {odom_topic}", notes)
        uses.append((odom_topic, ost, olg, odo_log))
    truth_ns = truth = None
    if truth_topic:
        tst, tlg, truth = _read_poses(bag, truth_topic, "truth")
        truth_ns, tr_log = _times(tst, tlg, f"bag {path} topic {truth_topic}", notes)
        uses.append((truth_topic, tst, tlg, tr_log))
    return odo_ns, odo, truth_ns, truth


def _check_clocks(path: Path, uses) -> None:
    """Refuse log times mixed with header clocks more than :data:`MAX_CLOCK_OFFSET_S` away from them."""
    if not any(u[3] for u in uses):
        return
    for topic, st, lg, is_log in uses:
        if is_log:
            continue
        off = float(np.median(np.array(st, dtype=np.int64) - np.array(lg, dtype=np.int64))) * 1e-9
        if abs(off) > MAX_CLOCK_OFFSET_S:
            logs = [u[0] for u in uses if u[3]]
            raise InputError(f"bag {path} topic {topic}: its header clock is {off:.1f} s from the log time that "
                             f"{', '.join(logs)} must use (stamps 0); expected clocks within {MAX_CLOCK_OFFSET_S:g} s, "
                             "refusing to mix them")


def _check_order(path, topic, ns, strict: bool) -> None:
    """Refuse a topic's times going backwards (or repeating, ``strict``), naming its message."""
    d = np.diff(ns)
    bad = np.flatnonzero(d <= 0 if strict else d < 0)
    if bad.size:
        i = int(bad[0]) + 1
        raise InputError(f"bag {path} topic {topic} message {i + 1}: expected increasing times, got "
                         f"{(ns[i] - ns[i - 1]) * 1e-9:+.6f} s after the previous (times going backwards)")


def _assemble(path, radar_topic, odom_topic, truth_topic, radar_ns, clouds, mapping, odo_ns, odo, truth_ns, truth,
              mounting, notes) -> Recording:
    for topic, ns in ((radar_topic, radar_ns), (odom_topic, odo_ns), (truth_topic, truth_ns)):
        if ns is not None:
            _check_order(path, topic, ns, topic != radar_topic)
    t0 = int(radar_ns[0])
    rel = lambda ns: (np.asarray(ns, dtype=np.int64) - t0) * 1e-9  # noqa: E731  integer first: no rounding at 1e9 s
    n = np.array([c["x"].size for c in clouds])
    x, y = np.concatenate([c["x"] for c in clouds]), np.concatenate([c["y"] for c in clouds])
    scan_t = rel(radar_ns)
    if np.any(np.diff(scan_t) == 0):
        raise InputError(f"bag {path} topic {radar_topic}: two clouds share a time; expected one cloud per scan time")
    channels = {key: np.concatenate([c[name] for c in clouds]) for key, name in mapping.items()}
    rec = Recording(np.repeat(scan_t, n), np.column_stack([np.hypot(x, y), np.arctan2(y, x)]), channels,
                    rel(odo_ns), odo, "unicycle", None if truth is None else rel(truth_ns), truth, mounting,
                    f"bag {path}", notes, scan_t, t0)
    return rec


def _static_transforms(bag: _Bag) -> dict[str, list[tuple[str, Mounting]]]:
    """Every ``/tf_static`` transform by child frame (no leading ``/``): ``(parent, Mounting)``, in bag order."""
    out: dict[str, list[tuple[str, Mounting]]] = {}
    if "/tf_static" not in bag.topics:
        return out
    bag.check("/tf_static", (TF_MESSAGE,), "static transform")
    for _, msg in bag.messages("/tf_static"):
        for tr in msg.transforms:
            child = str(tr.child_frame_id).lstrip("/")
            where = f"bag {bag.path} /tf_static {tr.header.frame_id} -> {child}"
            out.setdefault(child, []).append((str(tr.header.frame_id),
                                              mounting_from_transform(tr.transform.translation,
                                                                      tr.transform.rotation, where)))
    return out


def _pose(m: Mounting) -> tuple[float, float, float]:
    return m.x, m.y, m.yaw


def _rig_mounting(path: Path, topic: str, sid: int, frame: str, tf, sensors) -> Mounting:
    """Sensor ``sid``'s mounting: ``/tf_static``'s transform to ``frame``, else ``sensors[sid]``."""
    found = tf.get(frame.lstrip("/"), []) if frame else []
    poses = {_pose(m) for _, m in found}
    if len(poses) > 1:
        raise InputError(f"bag {path} topic {topic}: /tf_static holds {len(poses)} different transforms to its frame "
                         f"{frame!r}; expected one")
    if found:
        m = found[0][1]
    elif sensors and sid in sensors:
        m = sensors[sid]
    else:
        raise InputError(f"bag {path} topic {topic}: no mounting for its frame {frame!r}: expected a /tf_static "
                         f"transform to it, or a sensors table (--sensors FILE) with a row for sensor_id {sid}")
    return dataclasses.replace(m, sensor_id=sid, name=topic)


def _read_rig(path: Path, topics: list[str], odom_topic, truth_topic, doppler_field, sensors) -> Recording:
    """A rig from several radar topics: topic ``i`` is sensor ``i``, each message one scan, detections
    merged in time order (stable: equal times in topic order), times from the first radar message
    over all topics, channels those every topic carries (a note names any left out)."""
    seen = set()
    for t in topics:
        if t in seen:
            raise InputError(f"bag {path}: --radar-topic {t} given twice; expected each radar topic once")
        seen.add(t)
    reader = open_bag(path)
    try:
        bag = _Bag(reader, path)
        for t in topics:
            bag.check(t, (POINTCLOUD2, RADAR_SCAN), "radar")
        if odom_topic:
            bag.check(odom_topic, (ODOMETRY,), "odometry")
        if truth_topic:
            bag.check(truth_topic, (ODOMETRY, POSE_STAMPED), "truth")
        notes: list[str] = []
        uses, radar = [], []
        for sid, topic in enumerate(topics):
            st, lg, frames, clouds, mapping = _read_radar(bag, topic, doppler_field)
            if "sensor_id" in mapping:
                raise InputError(f"bag {path} topic {topic}: its clouds carry a sensor_id field "
                                 f"({mapping['sensor_id']!r}), but with several --radar-topic each topic is one "
                                 "sensor (0, 1, ... in the order given); expected one --radar-topic, or clouds "
                                 "without sensor_id")
            distinct = list(dict.fromkeys(frames))
            if len(distinct) > 1:
                raise InputError(f"bag {path} topic {topic}: its clouds name frames {distinct[0]!r} and "
                                 f"{distinct[1]!r}; expected one frame per radar topic")
            ns, is_log = _times(st, lg, f"bag {path} topic {topic}", notes)
            _check_order(path, topic, ns, False)
            if np.any(np.diff(ns) == 0):
                raise InputError(f"bag {path} topic {topic}: two clouds share a time; expected one cloud per "
                                 "scan time")
            uses.append((topic, st, lg, is_log))
            radar.append((topic, ns, frames[0], clouds, mapping))
        odo_ns, odo, truth_ns, truth = _read_odometry_and_truth(bag, path, odom_topic, truth_topic, notes, uses)
        _check_clocks(path, uses)
        tf = _static_transforms(bag)
        rig: dict[int, Mounting] = {}
        for sid, (topic, _, frame, _, _) in enumerate(radar):
            rig[sid] = _rig_mounting(path, topic, sid, frame, tf, sensors)
            for other, (otopic, _, oframe, _, _) in enumerate(radar[:sid]):
                if oframe.lstrip("/") == frame.lstrip("/") and _pose(rig[other]) != _pose(rig[sid]):
                    raise InputError(f"bag {path} topics {otopic} and {topic} share the frame {frame!r} but their "
                                     f"mountings differ ({_fmt(rig[other])} and {_fmt(rig[sid])}); expected one "
                                     "mounting per frame")
    finally:
        reader.close()
    for topic, ns in ((odom_topic, odo_ns), (truth_topic, truth_ns)):
        if ns is not None:
            _check_order(path, topic, ns, True)
    return _assemble_rig(path, radar, rig, odo_ns, odo, truth_ns, truth, notes)


def _fmt(m: Mounting) -> str:
    return f"x {m.x:g} m, y {m.y:g} m, yaw {m.yaw:g} rad"


def _assemble_rig(path, radar, rig, odo_ns, odo, truth_ns, truth, notes) -> Recording:
    t0 = min(int(ns[0]) for _, ns, _, _, _ in radar)
    rel = lambda ns: (np.asarray(ns, dtype=np.int64) - t0) * 1e-9  # noqa: E731  integer first, as _assemble
    keys = [k for k in radar[0][4] if all(k in r[4] for r in radar)]
    dropped = sorted({k for r in radar for k in r[4]} - set(keys))
    if dropped:
        lacking = [r[0] for r in radar if not set(dropped) <= set(r[4])]
        notes.append(f"bag {path}: channel(s) {', '.join(dropped)} left out: not carried by every radar topic "
                     f"(not by {', '.join(lacking)})")
    msg_ns = np.concatenate([ns for _, ns, _, _, _ in radar])
    msg_sid = np.concatenate([np.full(len(r[1]), sid, dtype=np.int64) for sid, r in enumerate(radar)])
    clouds = [(sid, c, r[4]) for sid, r in enumerate(radar) for c in r[3]]
    order = np.lexsort((msg_sid, msg_ns))            # time, then topic order: stable
    clouds = [clouds[i] for i in order.tolist()]
    n = np.array([c["x"].size for _, c, _ in clouds])
    x, y = np.concatenate([c["x"] for _, c, _ in clouds]), np.concatenate([c["y"] for _, c, _ in clouds])
    channels = {k: np.concatenate([c[mp[k]] for _, c, mp in clouds]) for k in keys}
    channels["sensor_id"] = np.repeat(msg_sid[order].astype(float), n)
    scan_t = np.unique(rel(msg_ns))
    return Recording(np.repeat(rel(msg_ns[order]), n), np.column_stack([np.hypot(x, y), np.arctan2(y, x)]), channels,
                     rel(odo_ns), odo, "unicycle", None if truth is None else rel(truth_ns), truth, None,
                     f"bag {path}", notes, scan_t, t0, sensors=rig)


IMU = "sensor_msgs/msg/Imu"


def read_imu(path: str | Path, topic: str, *, log_time: bool) -> tuple[np.ndarray, np.ndarray]:
    """``(t_ns (n,), gyro (n, 3) rad/s)`` of a ``sensor_msgs/Imu`` topic (:func:`read_imu_samples`)."""
    t, gyro, _, _ = read_imu_samples(path, topic, log_time=log_time)
    return t, gyro


def read_imu_samples(path: str | Path, topic: str, *, log_time: bool):
    """``(t_ns (n,), gyro (n, 3) rad/s, accel (n, 3) m/s^2, note)`` of a ``sensor_msgs/Imu`` topic.

    ``log_time``: the radar's times are the bag's log times (its header stamps are 0). The IMU's
    own header clock is then moved onto the log clock by the median of ``log - stamp`` (one
    constant, said in ``note``): its stamps keep their regular spacing, which the log times of a
    fast topic lose (logged in bursts), and no two clocks are mixed. An IMU whose stamps are 0 uses
    its log times; otherwise (``log_time`` false) its header stamps.
    """
    path = Path(path)
    reader = open_bag(path)
    try:
        bag = _Bag(reader, path)
        bag.check(topic, (IMU,), "IMU")
        stamps, logs, rows = [], [], []
        for log_ns, msg in bag.messages(topic):
            stamps.append(_stamp_ns(msg.header)), logs.append(log_ns)
            w, a = msg.angular_velocity, msg.linear_acceleration
            rows.append((w.x, w.y, w.z, a.x, a.y, a.z))
    finally:
        reader.close()
    if not rows:
        raise InputError(f"bag {path} topic {topic}: expected IMU messages, got none")
    arr = np.array(rows, dtype=float)
    if not np.all(np.isfinite(arr)):
        i = int(np.argmax(~np.all(np.isfinite(arr), axis=1)))
        raise InputError(f"bag {path} topic {topic} message {i + 1}: expected finite angular velocity and "
                         "acceleration, got NaN or inf")
    notes: list[str] = []
    t, is_log = _times(stamps, logs, f"bag {path} topic {topic}", notes)
    note = notes[0] if notes else ""
    if log_time and not is_log:
        off = int(np.median(t - np.array(logs, dtype=np.int64)))
        t = t - off
        note = (f"bag {path} topic {topic}: header stamps moved onto the log clock by the median log - stamp "
                f"offset, {-off * 1e-9:.6f} s")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        raise InputError(f"bag {path} topic {topic} message {int(bad[0]) + 2}: expected increasing times, got one "
                         "that repeats or goes backwards")
    return t, arr[:, :3], arr[:, 3:], note


def list_topics(path: str | Path) -> dict[str, str]:
    """``{topic: message type}`` of a bag."""
    reader = open_bag(Path(path))
    try:
        return {c.topic: c.msgtype for c in reader.connections}
    finally:
        reader.close()

