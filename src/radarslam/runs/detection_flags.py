"""Each input detection's fate in a recording run (issue 36 item 4): whether the Doppler gate called
it moving (docs/method.md c.10.4) and which landmark it updated, by either engine, in the order of
the recording's rows (``moving.csv``, docs/recordings.md "Outputs"), and its scores against the
recording's annotation (RadarScenes' ``label``).

The orchestrator says both in each scan's :class:`~radarslam.slam.filter.ScanReport` (``moving``,
``associations``); the fused engine returns its association rows ``(scan, detection, landmark id)``
and keeps the gate's ``kept`` rows in its :class:`~radarslam.slam.fused.plan.Stream` (a detection
not kept is one the gate called moving). Both are read as they run, at no extra pass over the data.
"""

from __future__ import annotations

import dataclasses
import time
from contextlib import contextmanager
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

import numpy as np

from radarslam.config import Config
from radarslam.core.types import Scan
from radarslam.slam.driver import FilterRecord, run_filter
from radarslam.slam import _fused
from radarslam.slam.filter import EkfSlam, MapSnapshot

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
#: The targets of issue 36 item 6: road users' detections updating a landmark, static ones called moving.
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


class _ReportingSlam(EkfSlam):
    """:class:`EkfSlam` keeping each scan's gate verdict and associations (its :class:`ScanReport`)."""

    def __init__(self, config):
        super().__init__(config)
        self._sizes: list[int] = []
        self._moving: list[np.ndarray] = []
        self._assoc: list[dict] = []

    def process(self, event):
        rep = super().process(event)
        if rep is not None:
            self._sizes.append(rep.n_detections)        # the whole scan: kept + moving
            self._moving.append(np.asarray(rep.moving, dtype=np.int64))
            self._assoc.append(rep.associations)
        return rep

    def flags(self) -> ScanFlags:
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
    """:func:`~radarslam.slam.driver.run_filter` (the same record, the same engine choice) and
    every scan detection's :class:`ScanFlags`."""
    slam = _ReportingSlam(config)
    if engine == "auto" and _fused.why_not(slam, events) is None:
        return _fused_with_flags(slam, events, on_scan)
    return run_filter(config, events, slam=slam, on_scan=on_scan), slam.flags()


@contextmanager
def _stream_of_run():
    """The :class:`Stream` the fused engine's ``run`` builds (its gate's ``kept`` rows), caught as it
    passes (the module's documented patch point, slam/_fused.py): classifying the scans a second
    time would cost as much again (2.8 s of 25 on RadarScenes 105)."""
    from radarslam.slam.fused import plan

    inner, got = plan._stream_arrays, []

    def catch(*args, **kwargs):
        got.append(inner(*args, **kwargs))
        return got[-1]

    plan._stream_arrays = catch
    try:
        yield got
    finally:
        plan._stream_arrays = inner


def _fused_with_flags(slam: EkfSlam, events: list, on_scan) -> tuple[FilterRecord, ScanFlags]:
    """The fused engine's record (as ``single._fused_record``) and its flags from its association
    rows and its stream's kept rows."""
    t0 = time.perf_counter()
    with _stream_of_run() as got:
        r, arows = _fused.run(slam, events)
    off = r["map_offsets"].tolist()
    maps = [MapSnapshot(r["ids"][a:b], r["positions"][a:b], r["covs"][a:b], r["rma"][a:b], r["efa"][a:b],
                        r["created"][a:b]) for a, b in pairwise(off)]
    record = FilterRecord(r["poses"], r["pose_covs"], maps, r["n_detections"], r["n_associated"], r["n_landmarks"],
                          time.perf_counter() - t0, nis_sum=r["nis_sum"], nis_count=r["nis_count"].astype(float),
                          engine="fused")
    if on_scan is not None:
        for _ in maps:
            on_scan()
    stream = got[-1]
    sizes = [np.shape(e.polar)[0] for e in events if isinstance(e, Scan)]
    full = np.zeros(len(sizes) + 1, dtype=np.int64)
    full[1:] = np.cumsum(sizes)
    gate = slam.config.filter.doppler_gate
    moving = np.full(full[-1], gate, dtype=bool)           # under the gate: moving unless kept
    if gate:
        k = stream.scan_off
        scan_of_kept = np.repeat(np.arange(k.size - 1), np.diff(k))
        moving[full[scan_of_kept] + stream.kept] = False
    landmark = np.full(full[-1], -1, dtype=np.int64)
    a = np.asarray(arows, dtype=np.int64).reshape(-1, 3)
    landmark[full[a[:, 0]] + a[:, 1]] = a[:, 2]
    return record, ScanFlags(full, moving, landmark)


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
    """Road users kept out of the map, against the annotation (issue 36 item 6): the share of the road
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
