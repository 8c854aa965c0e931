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

#: Times closer than this (s) are one time: a scan this close to an odometry stamp is at the stamp
#: (no sliver of an odometry piece; a bag's stamps are whole nanoseconds).
TIME_EPS_S = 1e-9
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


@dataclass
class StreamReport:
    """What :func:`stream_events` left out of the stream, for ``metrics.json`` and one warning line each.

    Attributes
    ----------
    scans, detections : int
        Scans and detections in the stream.
    dropped_scans : dict
        Scans outside the odometry's span (before its first row or after its last), which no
        prediction reaches: ``{"count", "detections", "t_first_s", "t_last_s"}`` (count 0: none).
    notes : list of str
        One line per fault met (nothing when the stream is whole).
    """

    scans: int = 0
    detections: int = 0
    dropped_scans: dict = field(default_factory=lambda: {"count": 0, "detections": 0})
    notes: list[str] = field(default_factory=list)


def to_events(rec: Recording, mounting: Mounting) -> list[Event]:
    """The time-ordered event stream of ``rec`` (:func:`stream_events` without its report)."""
    return stream_events(rec, mounting)[0]


def stream_events(rec: Recording, mounting: Mounting) -> tuple[list[Event], StreamReport]:
    """The time-ordered event stream of ``rec`` with detections moved to the platform frame, and
    what was left out (docs/recordings.md "From rows to events").

    Odometry row ``j`` is the reading over ``(t_{j-1}, t_j]`` (row 0 only marks the start). The
    prediction reaches each scan at its own time: an interval holding scans at ``s_1 < ... < s_m`` is
    split at them, ``Odometry(s_1, s_1 - a, u_j)``, the scan(s) at ``s_1``, ..., then the rest
    ``Odometry(t_j, t_j - s_m, u_j)`` (never a piece of zero length), with ``a = max(t_{j-1}, t_first_scan)``.
    The interval holding the last scan ends there (the rest of that reading, and later rows, are dropped).
    Scans before ``t_0`` or after the last row cannot be predicted to: they are dropped and reported.
    Odometry goes first on equal times (``t_odo <= t_scan``, within :data:`TIME_EPS_S`), as in the
    simulator. Scans are numbered from 1 in the stream.
    """
    scans = _scans(rec, mounting)
    if not scans:
        raise InputError(f"{rec.source}: expected at least one scan, got none")
    report = StreamReport()
    odo_t = rec.odo_t
    covered = [bool(odo_t.size) and odo_t[0] - TIME_EPS_S <= sc.t <= odo_t[-1] + TIME_EPS_S for sc in scans]
    inside = [sc for sc, c in zip(scans, covered) if c]
    out = [sc for sc, c in zip(scans, covered) if not c]
    if out:
        n_det = sum(sc.polar.shape[0] for sc in out)
        report.dropped_scans = {"count": len(out), "detections": n_det, "t_first_s": out[0].t, "t_last_s": out[-1].t}
        span = f"{odo_t[0]} .. {odo_t[-1]} s" if odo_t.size else "none"
        report.notes.append(f"{rec.source}: {len(out)} of {len(scans)} scans ({n_det} detections, {out[0].t} .. "
                            f"{out[-1].t} s) lie outside the odometry's span ({span}) and were dropped")
    if not inside:
        raise InputError(f"{rec.source}: expected scans within the odometry's time span "
                         f"({odo_t[0] if odo_t.size else '-'} .. {odo_t[-1] if odo_t.size else '-'} s), got none "
                         f"(scans {scans[0].t} .. {scans[-1].t} s)")
    scans = [Scan(sc.t, k, sc.polar, sc.channels) for k, sc in enumerate(inside, start=1)]
    report.scans, report.detections = len(scans), sum(sc.polar.shape[0] for sc in scans)
    t0, t1 = scans[0].t, scans[-1].t
    events: list[Event] = [scans[0]]
    i = 1                                     # the next scan to place
    prev = -np.inf                            # the previous row's time
    for tj, row in zip(odo_t.tolist(), rec.odo):
        if tj <= t0 + TIME_EPS_S or prev >= t1 - TIME_EPS_S:
            prev = tj
            continue
        u = np.array(row, dtype=float)
        a = max(prev, t0)                     # where this reading's interval starts in the stream
        while i < len(scans) and scans[i].t <= tj + TIME_EPS_S:
            s = scans[i].t
            if s > a + TIME_EPS_S:
                events.append(Odometry(s, s - a, u))
                a = s
            events.append(scans[i])
            i += 1
        b = min(tj, t1)
        if b > a + TIME_EPS_S:
            events.append(Odometry(b, b - a, u))
        prev = tj
    return events, report


def _scans(rec: Recording, mounting: Mounting) -> list[Scan]:
    """Every scan of ``rec`` in time order (numbered 0 here), detections in the platform frame."""
    st = rec.scan_times()
    order = np.argsort(rec.det_t, kind="stable")
    t, polar = rec.det_t[order], platform_polar(rec, mounting)[order]
    ch = {k: v[order] for k, v in rec.channels.items()}
    starts = np.searchsorted(t, st, side="left")
    ends = np.searchsorted(t, st, side="right")
    return [Scan(ts, 0, polar[a:b], {n: v[a:b] for n, v in ch.items()} or None)
            for ts, a, b in zip(st.tolist(), starts.tolist(), ends.tolist())]


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
