"""Each input detection's fate in a recording run: whether the Doppler gate called
it moving (docs/method.md c.10.4) and which landmark it updated, by either engine, in the order of
the recording's rows (``moving.csv``, docs/recordings.md "Outputs"), and its scores against the
recording's annotation (RadarScenes' ``label``).

A filter run event by event says both in each scan's :class:`~radarslam.slam.filter.ScanReport`
(``moving``, ``associations``); a whole stream's run returns its association rows ``(scan, detection, landmark id)``
and keeps the gate's ``kept`` rows in its :class:`~radarslam.slam.fused.plan.Stream` (a detection
not kept is one the gate called moving, its ``kept`` rows). Both are read as they run
(:class:`FlagsObserver` of :func:`radarslam.slam.driver.drive`), at no extra pass over the data.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from radarslam.config import Config
from radarslam.core.types import Scan
from radarslam.slam.driver import FilterRecord, Observer, drive

__all__ = [
    "STATIC_LABEL",
    "DetectionFlags",
    "ScanFlags",
    "detection_flags",
    "moving_scores",
    "run_with_flags",
    "stream_rows",
    "write_moving_csv",
]

#: RadarScenes' label of the static world; every other value is a road user (its SOURCE.md).
STATIC_LABEL = 11
#: The targets the run reports against: road users' detections updating a landmark, static ones called moving.
TARGETS = {"road_user_updated_share": 0.01, "static_moving_share": 0.12}


@dataclass(frozen=True)
class ScanFlags:
    """The gate's and the association's verdict on every detection of the stream's scans, scan after
    scan (stream order), each scan's rows in its own order.

    Attributes
    ----------
    scan_off : ndarray of int64, shape (S + 1,)
        Scan ``s`` holds rows ``scan_off[s]:scan_off[s + 1]``.
    moving : ndarray of bool, shape (M,)
        The Doppler gate dropped the detection as moving (c.10.4).
    landmark : ndarray of int64, shape (M,)
        The id of the landmark the detection updated, -1 for none.
    """

    scan_off: np.ndarray
    moving: np.ndarray
    landmark: np.ndarray


@dataclass(frozen=True)
class DetectionFlags:
    """:class:`ScanFlags` in the recording's row order (``detections.csv``), ``(n,)`` each.

    ``used`` is False for the rows dropped before the filter (zero range, scans outside the
    odometry's span): those are ``moving`` False and ``landmark`` -1.
    """

    moving: np.ndarray
    landmark: np.ndarray
    used: np.ndarray


class FlagsObserver(Observer):
    """Every scan detection's :class:`ScanFlags`, from the scan reports of a filter run event by event
    (``moving``, ``associations``) or a whole stream's association rows and its gate's kept rows."""

    def __init__(self):
        self._sizes: list[int] = []
        self._moving: list[np.ndarray] = []
        self._assoc: list[dict] = []
        self.flags: ScanFlags | None = None

    def after_scan(self, k, slam, scan, report):
        self._sizes.append(report.n_detections)        # the whole scan: kept + moving
        self._moving.append(np.asarray(report.moving, dtype=np.int64))
        self._assoc.append(report.associations)

    def after_fused(self, slam, scans, result, associations):
        full = np.zeros(len(scans) + 1, dtype=np.int64)
        full[1:] = np.cumsum([np.shape(e.polar)[0] for e in scans])
        gate = slam.config.filter.doppler_gate
        moving = np.full(full[-1], gate, dtype=bool)           # under the gate: moving unless kept
        if gate:
            k = result["kept_offsets"]
            scan_of_kept = np.repeat(np.arange(k.size - 1), np.diff(k))
            moving[full[scan_of_kept] + result["kept"]] = False
        landmark = np.full(full[-1], -1, dtype=np.int64)
        a = np.asarray(associations, dtype=np.int64).reshape(-1, 3)
        landmark[full[a[:, 0]] + a[:, 1]] = a[:, 2]
        self.flags = ScanFlags(full, moving, landmark)

    def result(self) -> ScanFlags:
        """The flags of the run the observer was told of."""
        if self.flags is not None:
            return self.flags
        off = np.zeros(len(self._sizes) + 1, dtype=np.int64)
        off[1:] = np.cumsum(self._sizes)
        moving = np.zeros(off[-1], dtype=bool)
        landmark = np.full(off[-1], -1, dtype=np.int64)
        for s, (bad, assoc) in enumerate(zip(self._moving, self._assoc)):
            moving[off[s] + bad] = True
            for lid, rows in assoc.items():
                landmark[off[s] + np.asarray(rows, dtype=np.int64)] = lid
        return ScanFlags(off, moving, landmark)


def run_with_flags(config: Config, events: list, *, on_scan=None, engine: str = "auto") -> tuple[FilterRecord,
                                                                                                 ScanFlags]:
    """:func:`~radarslam.slam.driver.drive` (the same record, the same engine choice as
    :func:`~radarslam.slam.driver.run_filter`) and every scan detection's :class:`ScanFlags`."""
    flags = FlagsObserver()
    record = drive(config, events, engine=engine, observers=[flags], on_scan=on_scan)
    return record, flags.result()


def stream_rows(rec, mounting) -> np.ndarray:
    """The row of ``rec`` (input order) of every detection of the stream's scans, scan after scan as
    :func:`~radarslam.io.recording.stream.stream_events` makes them ``(M,)``: the stream of a copy of
    ``rec`` whose only channels are the row number and ``sensor_id`` (what groups the scans)."""
    from radarslam.io.recording.stream import stream_events

    n = rec.det_t.size
    ch = {"row": np.arange(n, dtype=float)}
    if "sensor_id" in rec.channels:
        ch["sensor_id"] = rec.channels["sensor_id"]
    events, _ = stream_events(dataclasses.replace(rec, channels=ch, notes=[]), mounting)
    parts = [e.channels["row"] for e in events if isinstance(e, Scan) and e.channels]
    return np.concatenate(parts).astype(np.int64) if parts else np.empty(0, dtype=np.int64)


def detection_flags(n: int, rows: np.ndarray, flags: ScanFlags) -> DetectionFlags:
    """``flags`` in the recording's row order: ``rows`` (:func:`stream_rows`) of ``n`` input rows."""
    if rows.shape != flags.moving.shape:
        raise ValueError(f"rows: expected one per stream detection, {flags.moving.shape[0]}, got {rows.shape[0]}")
    moving, landmark, used = np.zeros(n, dtype=bool), np.full(n, -1, dtype=np.int64), np.zeros(n, dtype=bool)
    moving[rows], landmark[rows], used[rows] = flags.moving, flags.landmark, True
    return DetectionFlags(moving, landmark, used)


def write_moving_csv(path: str | Path, t: np.ndarray, sensor_id: np.ndarray, flags: DetectionFlags) -> None:
    """``moving.csv``: one line per input detection in input order, ``t_s, sensor_id, moving, landmark,
    used`` (docs/recordings.md "Outputs")."""
    from radarslam.io.results import atomic_write_text

    # each distinct time, sensor and (landmark, moving, used) is formatted once (a recording has a few
    # thousand of each for a million lines); a line is the concatenation of its three pieces
    t = np.ascontiguousarray(t, dtype=float)
    sid = np.asarray(sensor_id).astype(np.int64)
    lm = np.asarray(flags.landmark).astype(np.int64)
    tail = (lm - lm.min(initial=0)) * 4 + flags.moving.astype(np.int64) * 2 + flags.used.astype(np.int64)
    pieces = []
    for values, fmt in ((t.view(np.int64), None), (sid, "{},"), (tail, None)):   # times by their bits: -0.0
        keys, first, inv = np.unique(values, return_index=True, return_inverse=True)   # first: a line of each
        if fmt is not None:
            text = [fmt.format(v) for v in keys.tolist()]
        elif values is tail:
            text = [f"{int(c)},{d},{int(e)}\n" for c, d, e in zip(flags.moving[first].astype(np.int64).tolist(),
                                                                lm[first].tolist(),
                                                                flags.used[first].astype(np.int64).tolist())]
        else:
            text = [f"{a:.9f}," for a in t[first].tolist()]
        pieces.append(np.array(text, dtype=object)[inv.reshape(-1)])
    body = "".join((pieces[0] + pieces[1] + pieces[2]).tolist()) if t.size else ""
    atomic_write_text(path, "t_s,sensor_id,moving,landmark,used\n" + body)


def moving_scores(labels: np.ndarray, flags: DetectionFlags, static_label: int = STATIC_LABEL) -> dict:
    """Road users kept out of the map, against the annotation: the share of the road
    users' detections (``label != static_label``) that updated a landmark and the share of the static
    world's detections the gate called moving, over every input detection (those dropped before the
    filter count as neither), with the counts."""
    road = np.asarray(labels) != static_label
    static = ~road
    n_road, n_static = int(road.sum()), int(static.sum())
    upd = int(np.count_nonzero(road & (flags.landmark >= 0)))
    mov = int(np.count_nonzero(static & flags.moving))
    share = lambda a, b: a / b if b else None
    return {"road_user_detections": n_road, "road_user_updated": upd,
            "road_user_updated_share": share(upd, n_road),
            "road_user_called_moving": int(np.count_nonzero(road & flags.moving)),
            "static_detections": n_static, "static_moving": mov, "static_moving_share": share(mov, n_static),
            "static_updated": int(np.count_nonzero(static & (flags.landmark >= 0))),
            "unused_detections": int(np.count_nonzero(~flags.used)), "targets": dict(TARGETS),
            "definitions": {"road_user_updated_share": f"road users' detections (label != {static_label}) that updated "
                            "a landmark, over all of them", "static_moving_share": f"static detections (label "
                            f"{static_label}) the Doppler gate called moving, over all of them"}}
