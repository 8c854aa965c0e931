"""A recording as plain arrays, and its event stream (docs/recordings.md "From rows to events").

Every reader (plain CSV / NPZ, ROS bags) returns a :class:`Recording`: detections in the SENSOR
frame, odometry rows, optional truth and the mounting if the file carried one. :func:`to_events`
turns it into the stream the filter consumes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.types import Event, Odometry, Scan
from radarslam.io.recording.mounting import Mounting, to_platform

#: Optional per-detection columns, carried to :attr:`Scan.channels` (not used by the filter yet).
CHANNELS = ("doppler_mps", "rcs", "sensor_id", "z_m")
#: Odometry columns of each kind: ``unicycle`` (speed, yaw rate) or ``ackermann`` (wheel speed, steering).
ODOMETRY_KINDS = {"unicycle": ("speed_mps", "yaw_rate_rad_s"), "ackermann": ("wheel_speed_mps", "steering_rad")}


@dataclass
class Recording:
    """One recording as arrays.

    Attributes
    ----------
    det_t : ndarray, shape (n,)
        Detection times (s), non-decreasing; detections of one time form one scan.
    det_polar : ndarray, shape (n, 2)
        ``[range (m), azimuth (rad)]`` in the sensor frame.
    channels : dict of str to ndarray of shape (n,)
        Optional columns among :data:`CHANNELS`.
    odo_t : ndarray, shape (p,)
        Odometry times (s), increasing.
    odo : ndarray, shape (p, 2)
        Odometry rows, in the columns of ``ODOMETRY_KINDS[odo_kind]``.
    odo_kind : str
        ``"unicycle"`` or ``"ackermann"``.
    truth_t, truth : ndarray, shapes (q,) and (q, 3), or None
        True poses ``[x (m), y (m), yaw (rad)]`` of the platform.
    mounting : Mounting or None
        The mounting the file carried (a bag's /tf_static), else None (the config's applies).
    source : str
        What was read (for messages and run.json).
    notes : list of str
        Warnings met while reading (one line each), e.g. a clock fallback.
    scan_t : ndarray, shape (K,), or None
        Every scan's time, including scans without detections (a bag's empty clouds); None: the
        distinct detection times.
    t0_ns : int
        The absolute time (ns) of ``t = 0`` when the source had one (a bag: its first radar message).
    sensors : dict of int to Mounting, or None
        A multi-radar rig (``sensors.csv``): each sensor's mounting by ``sensor_id``; each detection's
        ``channels["sensor_id"]`` names its own (one sensor without that column: all of them). None:
        the single ``mounting`` (or the config's) applies to every detection.
    labels : ndarray of int64, shape (n,), or None
        Per-detection annotation (RadarScenes: 11 the static world, else a road user), for evaluation
        only: never in a :class:`Scan`.
    det_scan : ndarray of int64, shape (n,), or None
        Which scan each detection belongs to (the optional ``scan`` column), else None.
    """

    det_t: np.ndarray
    det_polar: np.ndarray
    channels: dict[str, np.ndarray]
    odo_t: np.ndarray
    odo: np.ndarray
    odo_kind: str
    truth_t: np.ndarray | None = None
    truth: np.ndarray | None = None
    mounting: Mounting | None = None
    source: str = ""
    notes: list[str] = field(default_factory=list)
    scan_t: np.ndarray | None = None
    t0_ns: int = 0
    sensors: dict[int, Mounting] | None = None
    labels: np.ndarray | None = None
    det_scan: np.ndarray | None = None

    def scan_times(self) -> np.ndarray:
        """Every scan's time (s), increasing."""
        return np.unique(self.det_t) if self.scan_t is None else self.scan_t


def check_motion_model(rec: Recording, motion_model: str) -> None:
    """Refuse odometry whose kind is not what the filter's motion model takes."""
    if rec.odo_kind != motion_model:
        cols = ", ".join(ODOMETRY_KINDS.get(rec.odo_kind, ()))
        raise InputError(f"{rec.source}: odometry ({cols}) is for the {rec.odo_kind!r} motion model, but "
                         f"filter.motion_model is {motion_model!r}; choose a profile or --config that matches")


def to_events(rec: Recording, mounting: Mounting) -> list[Event]:
    """The time-ordered event stream of ``rec`` with detections moved to the platform frame.

    Scans are numbered from 1. Odometry row ``j`` with ``t_j`` after the first scan and at most the
    last scan becomes ``Odometry(t_j, t_j - max(t_{j-1}, t_first_scan), row_j)``: the reading at the
    end of its interval, applied over it (rows at or before the first scan only mark the start).
    Odometry goes first on equal times (``t_odo <= t_scan``), as in the simulator.
    """
    st = rec.scan_times()
    if st.size == 0:
        raise InputError(f"{rec.source}: expected at least one scan, got none")
    order = np.argsort(rec.det_t, kind="stable")
    t, polar = rec.det_t[order], platform_polar(rec, mounting)[order]
    ch = {k: v[order] for k, v in rec.channels.items()}
    starts = np.searchsorted(t, st, side="left")
    ends = np.searchsorted(t, st, side="right")
    scans = []
    for k, (ts, a, b) in enumerate(zip(st.tolist(), starts.tolist(), ends.tolist()), start=1):
        scans.append(Scan(ts, k, polar[a:b], {n: v[a:b] for n, v in ch.items()} or None))
    t0, t1 = st[0], st[-1]
    odo: list[tuple[float, Odometry]] = []
    prev = -np.inf
    for tj, row in zip(rec.odo_t.tolist(), rec.odo):
        if t0 < tj <= t1:
            odo.append((tj, Odometry(tj, tj - max(prev, t0), np.array(row, dtype=float))))
        prev = tj
    events: list[Event] = []
    i = 0
    for s in scans:
        while i < len(odo) and odo[i][0] <= s.t:
            events.append(odo[i][1])
            i += 1
        events.append(s)
    return events


def platform_polar(rec: Recording, mounting: Mounting) -> np.ndarray:
    """Every detection ``(n, 2)`` moved to the platform frame by its OWN sensor's mounting
    (``rec.sensors`` by ``channels["sensor_id"]``), else by ``mounting``."""
    if not rec.sensors:
        return to_platform(rec.det_polar, mounting)
    sid = rec.channels.get("sensor_id")
    if sid is None:                           # one sensor and no sensor_id column (checked by the reader)
        return to_platform(rec.det_polar, next(iter(rec.sensors.values())))
    unknown = np.flatnonzero(~np.isin(sid, np.array(sorted(rec.sensors), dtype=float)))
    if unknown.size:
        raise InputError(f"{rec.source}: detection {int(unknown[0]) + 1} has sensor_id {float(sid[unknown[0]])!r}, "
                         f"expected one of the sensors {', '.join(map(str, sorted(rec.sensors)))}")
    out = np.empty_like(rec.det_polar)
    for k, m in rec.sensors.items():
        rows = sid == k
        out[rows] = to_platform(rec.det_polar[rows], m)
    return out


def check_times(t: np.ndarray, where: str, strict: bool, row: str = "row", first: int = 1) -> None:
    """Refuse times that go backwards (or repeat, with ``strict``), naming the first offending
    ``row`` (numbered so that element 0 is ``first``)."""
    d = np.diff(t)
    bad = np.flatnonzero(d <= 0 if strict else d < 0)
    if bad.size:
        i = int(bad[0]) + 1
        what = "increasing" if strict else "non-decreasing"
        raise InputError(f"{where} {row} {i + first}: expected {what} times, got {float(t[i])!r} after "
                         f"{float(t[i - 1])!r} (times going backwards)")
