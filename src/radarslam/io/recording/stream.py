"""A recording as plain arrays, and its event stream (docs/recordings.md "From rows to events").

Every reader (plain CSV / NPZ, ROS bags) returns a :class:`Recording`: detections in the SENSOR
frame, odometry rows, optional truth and the mounting if the file carried one. :func:`to_events`
turns it into the stream the filter consumes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.mounting import Mounting, detections_to_platform
from radarslam.core.types import Event, Odometry, Scan

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
    zero_range : int
        Detections at range 0 dropped (many drivers' invalid returns; they would make landmarks at
        the sensor).
    single_detection_scans : int
        Scans of one detection (most of them: detections stamped one by one, each its own scan).
    notes : list of str
        One line per fault met (nothing when the stream is whole).
    """

    scans: int = 0
    detections: int = 0
    dropped_scans: dict = field(default_factory=lambda: {"count": 0, "detections": 0})
    zero_range: int = 0
    single_detection_scans: int = 0
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
    A unicycle row's yaw rate is also each piece's ``gyro_rad_s`` (what ``filter.odometry = "doppler"``
    takes from a gyro, docs/method.md c.10.5).
    Odometry goes first on equal times (``t_odo <= t_scan``, within :data:`TIME_EPS_S`), as in the
    simulator. Scans are numbered from 1 in the stream.
    """
    report = StreamReport()
    scans = _scans(rec, mounting, report)
    if not scans:
        raise InputError(f"{rec.source}: expected at least one scan, got none")
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
    scans = [Scan(sc.t, k, sc.polar, sc.channels, sensor=sc.sensor) for k, sc in enumerate(inside, start=1)]
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
        g = float(row[1]) if rec.odo_kind == "unicycle" else None    # the yaw rate as a gyro (c.10.5)
        a = max(prev, t0)                     # where this reading's interval starts in the stream
        while i < len(scans) and scans[i].t <= tj + TIME_EPS_S:
            s = scans[i].t
            if s > a + TIME_EPS_S:
                events.append(Odometry(s, s - a, u, g))
                a = s
            events.append(scans[i])
            i += 1
        b = min(tj, t1)
        if b > a + TIME_EPS_S:
            events.append(Odometry(b, b - a, u, g))
        prev = tj
    return events, report


#: Warn when more than this share of the scans (of at least ``SINGLE_MIN_SCANS``) hold one detection.
SINGLE_SHARE, SINGLE_MIN_SCANS = 0.5, 10


def _scans(rec: Recording, mounting: Mounting, report: StreamReport) -> list[Scan]:
    """Every scan of ``rec`` as the sensor made it, in time order (numbered 0 here), detections in
    their radar's frame with ``Scan.sensor`` its mounting and view (docs/method.md c.13; a radar at
    the platform origin along the heading: no ``sensor``, the numbers as before): the rows of one
    ``scan`` id when the recording has that column (its time the mean of theirs), else of one
    ``(t_s, sensor_id)``; the empty scans of ``rec.scan_t`` too. Zero-range detections are dropped;
    both faults are counted in ``report`` with one note line each."""
    polar = rec.det_polar
    sensors = scan_sensors(rec, mounting)
    ch = dict(rec.channels)
    t, scan = rec.det_t, rec.det_scan
    zero = rec.det_polar[:, 0] <= 0.0
    report.zero_range = int(zero.sum())
    if report.zero_range:
        report.notes.append(f"{rec.source}: {report.zero_range} of {t.size} detections at range 0 (a driver's invalid "
                            "returns) were dropped")
        keep = ~zero
        t, polar, ch = t[keep], polar[keep], {k: v[keep] for k, v in ch.items()}
        scan = None if scan is None else scan[keep]
    sid = ch.get("sensor_id", np.zeros(t.size))
    key = scan if scan is not None else sid
    o1 = np.argsort(key, kind="stable")                  # by (t, key), stable: one sensor keeps today's order
    order = o1[np.argsort(t[o1] if scan is None else _scan_times(t, scan)[o1], kind="stable")]
    ts, ks = (t if scan is None else _scan_times(t, scan))[order], key[order]
    polar, ch = polar[order], {k: v[order] for k, v in ch.items()}
    cut = np.flatnonzero((np.diff(ts) != 0) | (np.diff(ks) != 0)) + 1
    starts, ends = np.r_[0, cut], np.r_[cut, ts.size]
    groups = [(float(ts[a]), a, b) for a, b in zip(starts.tolist(), ends.tolist())] if ts.size else []
    if rec.scan_t is not None:                           # scans without detections (a bag's empty clouds)
        have = set(ts.tolist())
        groups += [(float(x), 0, 0) for x in rec.scan_t.tolist() if x not in have]
        groups.sort(key=lambda g: g[0])
    sid = ch.get("sensor_id")
    if scan is not None and sid is not None and sid.size:
        mixed = np.flatnonzero(np.diff(ks) == 0)
        bad = mixed[sid[mixed] != sid[mixed + 1]]
        if bad.size:
            raise InputError(f"{rec.source}: scan {int(ks[bad[0]])} holds detections of sensors {float(sid[bad[0]])!r} "
                             f"and {float(sid[bad[0] + 1])!r}; expected one sensor's detections per scan")
    scans = [Scan(x, 0, polar[a:b], {n: v[a:b] for n, v in ch.items()} or None,
                  sensor=sensors.get(int(sid[a]) if sid is not None and b > a else None, sensors.get(None)))
             for x, a, b in groups]
    ones = sum(1 for _, a, b in groups if b - a == 1)
    report.single_detection_scans = ones
    if len(groups) >= SINGLE_MIN_SCANS and ones > SINGLE_SHARE * len(groups):
        report.notes.append(f"{rec.source}: {ones} of {len(groups)} scans hold one detection: detections stamped one "
                            "by one? give them a scan column (docs/recordings.md \"Scans\")")
    return scans


def _scan_times(t: np.ndarray, scan: np.ndarray) -> np.ndarray:
    """Each detection's scan time ``(n,)``: the mean time of the detections of its ``scan`` id (their
    common time exactly when they share one)."""
    ids, inv = np.unique(scan, return_inverse=True)
    first = np.full(ids.size, np.inf)
    np.minimum.at(first, inv, t)
    mean = np.bincount(inv, weights=t - first[inv], minlength=ids.size) / np.bincount(inv, minlength=ids.size)
    return (first + mean)[inv]


def _sensor(m: Mounting) -> Mounting | None:
    """A scan's ``Scan.sensor``: the mounting itself, None for a radar at the origin along the heading
    with the configuration's view (the scan then runs exactly as the simulator's)."""
    if m.is_identity and m.max_range_m is None and m.fov_rad is None:
        return None
    return m


def scan_sensors(rec: Recording, mounting: Mounting) -> dict:
    """Each sensor's ``Scan.sensor`` (its :class:`Mounting`) by ``sensor_id`` (``rec.sensors``), or
    under ``None`` the one ``mounting`` of a recording without sensors.csv; refuses a detection of an
    unknown sensor."""
    if not rec.sensors:
        return {None: _sensor(mounting)}
    sid = rec.channels.get("sensor_id")
    if sid is None:                           # one sensor and no sensor_id column (checked by the reader)
        return {None: _sensor(next(iter(rec.sensors.values())))}
    unknown = np.flatnonzero(~np.isin(sid, np.array(sorted(rec.sensors), dtype=float)))
    if unknown.size:
        raise InputError(f"{rec.source}: detection {int(unknown[0]) + 1} has sensor_id {float(sid[unknown[0]])!r}, "
                         f"expected one of the sensors {', '.join(map(str, sorted(rec.sensors)))}")
    return {k: _sensor(m) for k, m in rec.sensors.items()}


def platform_polar(rec: Recording, mounting: Mounting) -> np.ndarray:
    """Every detection ``(n, 2)`` moved to the platform frame by its OWN sensor's mounting
    (``rec.sensors`` by ``channels["sensor_id"]``), else by ``mounting``."""
    if not rec.sensors:
        return detections_to_platform(rec.det_polar, mounting)
    sid = rec.channels.get("sensor_id")
    if sid is None:                           # one sensor and no sensor_id column (checked by the reader)
        return detections_to_platform(rec.det_polar, next(iter(rec.sensors.values())))
    unknown = np.flatnonzero(~np.isin(sid, np.array(sorted(rec.sensors), dtype=float)))
    if unknown.size:
        raise InputError(f"{rec.source}: detection {int(unknown[0]) + 1} has sensor_id {float(sid[unknown[0]])!r}, "
                         f"expected one of the sensors {', '.join(map(str, sorted(rec.sensors)))}")
    out = np.empty_like(rec.det_polar)
    for k, m in rec.sensors.items():
        rows = sid == k
        out[rows] = detections_to_platform(rec.det_polar[rows], m)
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
