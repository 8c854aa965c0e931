"""A long stream through the fused engine in pieces: the engine takes the filter's state in and gives it
back (:class:`~radarslam.slam.fused.events.Carry`), so a stream runs as consecutive calls over parts of it,
with the same arithmetic as one call, and the caller hears of each part's scans as they are done (a
progress bar moves on a long recording; docs/speed.md "First run").

:func:`part` cuts the events ``[e0, e1)`` of a :class:`~radarslam.slam.fused.stream.Stream` out as a
stream of their own; :func:`joined` puts the parts' records back together as one run's; :class:`Pacer`
sizes each part by the wall time the parts before it took.
"""

from __future__ import annotations

import numpy as np

from radarslam.slam.fused.engine import ODOMETRY, SCAN, VELOCITY
from radarslam.slam.fused.storage import MapRows, ScanRecord
from radarslam.slam.fused.stream import Stream

__all__ = ["Pacer", "joined", "part"]


def part(stream: Stream, e0: int, e1: int) -> tuple[Stream, int]:
    """The events ``[e0, e1)`` of ``stream`` as a stream of their own, and the index of its first scan in
    ``stream`` (its scans' positions in ``stream`` are that plus theirs). Every array is a slice of
    ``stream``'s, in the same layout, so that the engine compiled for one takes the other."""
    kinds = stream.kinds
    before = kinds[:e0]
    o0, v0, s0 = (int(np.count_nonzero(before == kind)) for kind in (ODOMETRY, VELOCITY, SCAN))
    inside = kinds[e0:e1]
    o1, v1, s1 = (a + int(np.count_nonzero(inside == kind)) for a, kind in ((o0, ODOMETRY), (v0, VELOCITY), (s0, SCAN)))
    off, seen_off = stream.scan_off, stream.seen_off
    p0, p1 = int(off[s0]), int(off[s1])
    g0, g1 = int(seen_off[s0]), int(seen_off[s1])
    per_scan = {name: getattr(stream, name)[s0:s1] for name in ("scan_k", "trace", "moving", "remember", "mount",
                                                                  "has_mount", "sensor_view", "yaw_i", "tau_i")}
    sub = Stream(kinds=inside, odo=stream.odo[o0:o1], odo_dt=stream.odo_dt[o0:o1], vel=stream.vel[v0:v1],
                 vel_dt=stream.vel_dt[v0:v1], vel_U=stream.vel_U[v0:v1], vel_Q=stream.vel_Q[v0:v1],
                 scan_off=off[s0:s1 + 1] - p0, polar=stream.polar[p0:p1], seen_off=seen_off[s0:s1 + 1] - g0,
                 seen=stream.seen[g0:g1], kept=stream.kept[p0:p1] if stream.kept.shape[0] else stream.kept,
                 **per_scan)
    return sub, s0


def joined(parts: list, all_maps: bool) -> tuple[ScanRecord, MapRows, np.ndarray]:
    """One run's ``(record, maps, association rows)`` of the parts' ``(first scan, record, maps, rows)``,
    in order. Without ``all_maps`` each part holds the map after its last scan, and the last part's is
    the run's."""
    recs = [p[1] for p in parts]

    def cat(name):
        return np.concatenate([getattr(r, name) for r in recs])

    def offsets(name, kept=None):
        """A ``(S + 1,)`` offset field over the parts: each part's own offsets moved by the rows before it
        (a part whose rows are ``kept`` False contributes none)."""
        out, base = [np.zeros(1, dtype=np.int64)], 0
        for j, r in enumerate(recs):
            o = getattr(r, name)[1:]
            if kept is not None and not kept[j]:
                o = np.zeros_like(o)
            out.append(o + base)
            base += int(o[-1]) if o.shape[0] else 0
        return np.concatenate(out)

    keep_map = [all_maps or j == len(parts) - 1 for j in range(len(parts))]
    nis = cat("nis")
    rec = ScanRecord(cat("poses"), cat("pose_covs"), cat("n_det"), cat("n_ass"), cat("n_lm"), cat("nis_sum"),
                     cat("nis_cnt"), offsets("map_off", keep_map), cat("seconds"), nis, offsets("nis_off"),
                     offsets("trace_off"), cat("trace_ids"), cat("trace_pos"), cat("bias"), cat("bias_covs"))
    kept_maps = [p[2] for p, keep in zip(parts, keep_map) if keep]
    maps = MapRows(*(np.concatenate([getattr(m, f) for m in kept_maps]) for f in MapRows._fields))
    rows = []
    for s0, _, _, a in parts:
        a = a.copy()
        a[:, 0] += s0
        rows.append(a)
    return rec, maps, np.concatenate(rows).reshape(-1, 3)


class Pacer:
    """How many scans the next part of a stream takes: ``first`` at the start, then as many as the parts
    before it ran in ``target_s`` of wall time (at least ``least``). A part's size changes no result."""

    def __init__(self, first: int = 256, target_s: float = 0.5, least: int = 16):
        self.size, self.target_s, self.least = first, target_s, least

    def ran(self, scans: int, seconds: float) -> None:
        """A part of ``scans`` scans took ``seconds``: the next is sized by that rate."""
        if scans > 0 and seconds > 0.0:
            self.size = max(self.least, int(scans * self.target_s / seconds))

    def end(self, stream: Stream, e0: int) -> int:
        """The end of the part from event ``e0``: just after its ``self.size``-th scan (or the stream's end)."""
        scans = np.flatnonzero(stream.kinds[e0:] == SCAN)
        if scans.shape[0] <= self.size:
            return stream.kinds.shape[0]
        return e0 + int(scans[self.size - 1]) + 1
