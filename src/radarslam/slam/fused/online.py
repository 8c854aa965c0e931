"""The fused engine event by event: :class:`Online` keeps the filter's state between calls
(:class:`~radarslam.slam.fused.events.Carry`) and runs each event through the same engine a whole stream
runs through (slam/fused/engine.py, in any of its forms), so that a stream fed to it one event at a time
gives the one-call record bit for bit (tests/test_chunks.py).
"""

from __future__ import annotations

import numpy as np

from radarslam.core.errors import InputError
from radarslam.core.types import Scan
from radarslam.slam.event_input import finite_number
from radarslam.slam.fused.engine import OK
from radarslam.slam.fused.plan import _failure, _parameters, engine_of, first_carry, largest_scan, noises
from radarslam.slam.fused.stream import _stream_arrays
from radarslam.slam.report import ScanReport

__all__ = ["Online"]


class Online:
    """``slam``'s filter (an :class:`~radarslam.slam.filter.EkfSlam` that has processed nothing) run by the fused
    engine one event at a time, in form ``how`` (engine.FORMS; the steps form where ``slam`` has a component
    of the user's own, slam/fused/own.py). ``slam``'s own Doppler odometry and Doppler gate read the
    events as they come, and so change with them; ``slam.state`` does not (the filter's state is
    :attr:`carry`)."""

    def __init__(self, slam, how: str = "compiled"):
        self.slam = slam
        self.cfg = _parameters(slam, False, True)
        #: ``user_extents``: an extent estimator of the user's own's states (own.UserExtents), else None.
        self.engine, self.user_extents = engine_of(slam, self.cfg, how)
        self.largest = 1
        self.noise = noises(slam, self.cfg, self.largest)
        self.carry = first_carry(slam, self.cfg, self.largest)
        self.last_t = None                          # the time of the last scan run
        self.out = None                             # what the last event did beyond its record (events.ScanOut)
        #: The last scan's :class:`~radarslam.slam.report.ScanReport` (None before the first scan).
        self.report = None
        self.maps = None                            # the map after the last scan (storage.MapRows), None before one

    def process(self, event):
        """Run one event. Returns None for an odometry reading, else the scan's record: ``(record, maps,
        associations)`` as :func:`~radarslam.slam.fused.engine.run_stream` gives them for one scan (the map
        after it; the ``(0, detection, landmark id)`` rows, the detections the scan's own rows).

        Raises
        ------
        InputError
            As :class:`~radarslam.slam.filter.EkfSlam` would, for a bad event (nothing changed) or one that
            makes the state non-finite (the filter is then not to be used further).
        """
        if self.slam._odometry is not None or self.slam._gate is not None:
            _stream_arrays([event], fast=False)                      # its checks, before the components read it
        if isinstance(event, Scan):                                  # as EkfSlam.update: time goes forward
            t = finite_number(event.t, "scan.t")
            if self.last_t is not None and t < self.last_t:
                raise InputError(f"scan.t: expected scan times that do not go backwards, got {t!r} after "
                                 f"{self.last_t!r} (scan {event.index})")
        gated = []
        stream = _stream_arrays([event], slam=self.slam, live=True, gated=gated)
        if stream.kinds.shape[0] == 0:                               # c.10.5: a reading the Doppler odometry holds
            return None
        largest = largest_scan(stream)
        if largest > self.largest and self.cfg.assoc == 3:          # JCBB: gates for the deeper scan
            self.largest = largest
            self.noise = noises(self.slam, self.cfg, largest)
        status, n, (rec, maps), arows, self.carry, self.out = self.engine(stream, self.carry, self.noise, self.cfg)
        if n:
            self.last_t = float(event.t)
        if status[0] != OK:
            raise InputError(_failure([event], stream, status, n))
        if stream.kept.shape[0] and arows.shape[0]:                 # the gate's kept rows back to the scan's
            arows[:, 1] = stream.kept[arows[:, 1]]
        if not n:
            return None
        self.report = _report(event, stream, rec, arows, self.out, self.carry, gated[0] if gated else None)
        self.maps = maps
        return rec, maps, arows


def _report(scan, stream, rec, arows, out, carry, gated) -> ScanReport:
    """The :class:`~radarslam.slam.report.ScanReport` of ``scan``, run alone as ``stream``: its record
    ``rec``, associations ``arows`` (rows of the scan's detections), what else it did ``out``
    (events.ScanOut), the filter after it ``carry`` and the Doppler gate's ``(moving rows, EgoVelocity)``."""
    kept = stream.kept if stream.kept.shape[0] else None
    assoc: dict[int, list[int]] = {}
    for _, det, lid in arows.tolist():
        assoc.setdefault(lid, []).append(det)
    first = int(out.first_new)
    new_off = out.new_off.tolist()
    created = {}
    for a in range(len(new_off) - 1):
        rows = out.new_rows[new_off[a]:new_off[a + 1]].astype(int)
        created[first + a] = rows if kept is None else kept[rows].astype(int)
    moving, ego = (np.empty(0, dtype=int), None) if gated is None else gated
    return ScanReport(int(scan.index), int(rec.n_det[0]), int(out.n_cand), int(rec.n_ass[0]),
                      {lid: np.array(d, dtype=int) for lid, d in assoc.items()}, out.removed.tolist(), list(created),
                      [tuple(p) for p in out.merged.tolist()], int(out.n_clusters), int(carry.tent.count.shape[0]),
                      rec.nis.copy(), moving, ego, created)
