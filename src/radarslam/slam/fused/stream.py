"""The fused engine's event stream as arrays (:class:`Stream`): every event checked as
:meth:`~radarslam.slam.filter.EkfSlam.predict` and :meth:`~radarslam.slam.filter.EkfSlam.update` check
it, the Doppler gate's classification and the Doppler odometry's fits made up front, each scan's radar
(its mounting, its view, its yaw and time offset states: docs/method.md c.13-c.13.2)."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from radarslam.core.mounting import ORIGIN
from radarslam.slam.fused.engine import ODOMETRY, SCAN, VELOCITY
from radarslam.slam.sensor_frame import scan_mounting

__all__ = ["Stream", "_stream_arrays"]


class Stream(NamedTuple):
    """The event stream as arrays (:func:`_stream_arrays`)."""

    kinds: np.ndarray      #: (E,) int64, engine.ODOMETRY, SCAN or VELOCITY
    odo: np.ndarray        #: (O, 2) odometry controls [v, psi]
    odo_dt: np.ndarray     #: (O,) odometry intervals
    vel: np.ndarray        #: (V, 3) body-velocity inputs [v_x, v_y, omega] (Doppler odometry, c.10.5)
    vel_dt: np.ndarray     #: (V,) their intervals
    vel_U: np.ndarray      #: (V, 3, 3) their covariances
    vel_Q: np.ndarray      #: (V, 3, 3) the process noise of each (Q once per odometer interval)
    scan_off: np.ndarray   #: (S + 1,) int64, scan s is polar[scan_off[s]:scan_off[s + 1]]
    polar: np.ndarray      #: (M, 2) every scan's detections [range, azimuth]
    scan_k: np.ndarray     #: (S,) int64 scan indices
    trace: np.ndarray      #: (S,) bool: record the landmarks' ids and centroids after these scans
    moving: np.ndarray     #: (S,) int64, detections the Doppler gate dropped (c.10.4; zeros without it)
    remember: np.ndarray   #: (S,) bool, the gate tested the scan's objects (its memory takes them)
    seen_off: np.ndarray   #: (S + 1,) int64, scan s's moving-object detections are seen[seen_off[s]:seen_off[s + 1]]
    seen: np.ndarray       #: (G, 2) those detections in the platform frame
    kept: np.ndarray       #: (M,) int64, under the gate each row of ``polar``'s row in its scan (else empty)
    mount: np.ndarray      #: (S, 3) each scan's radar's mounting, ``Mounting.as_array`` (docs/method.md c.13)
    has_mount: np.ndarray  #: (S,) bool: the scan is in its radar's frame (a non-zero mounting)
    sensor_view: np.ndarray  #: (S, 2) the M/N view test's range and half field of view (rad) of each scan
    yaw_i: np.ndarray      #: (S,) int64, the state index of each scan's radar's yaw offset (c.13.1), -1 for none
    tau_i: np.ndarray      #: (S,) int64, the state index of each scan's radar's time offset (c.13.2), -1 for none


def _stream_arrays(events, fast: bool = True, slam=None, live: bool = False, gated: list | None = None) -> Stream:
    """The event stream as arrays (a :class:`Stream`), each event checked as :meth:`EkfSlam.predict` and
    :meth:`EkfSlam.update` check it (the same one-line errors, the first bad event's).

    ``slam``, the :class:`~radarslam.slam.filter.EkfSlam` the stream is for (it has processed no
    scan), brings what depends on the scans and readings alone, formed here with (copies of) its own
    components: under Doppler odometry (its ``DopplerOdometry``, c.10.5) the odometry events only
    accumulate, each scan is preceded by its body-velocity input (a VELOCITY event) and followed by
    its Doppler fit, as ``DopplerOdometry.process`` does; under the Doppler gate (its
    ``DopplerGate.classify``, c.10.4) each scan keeps its static detections (``kept``: their rows in
    the scan), and its moving objects' detections go to the engine, which remembers them.

    ``fast``: a scan whose detections are already a float ``(m, 2)`` array is checked with all the
    others at once at the end (finite, ranges >= 0); if anything is wrong, the stream is checked
    again event by event, so that the error is the first one the events make.

    ``live``: the stream is a part of a longer one that ``slam``'s own components read in order (the
    fused engine event by event, :class:`~radarslam.slam.fused.online.Online`): they are used, not
    copied, so that the Doppler odometry's interval and the gate's generator go on from the part before
    (and every event is checked as it is read, ``fast`` or not).

    ``gated``: a list to which each scan's Doppler gate's ``(moving rows, EgoVelocity)`` is appended
    (under the gate; the per-event report's, :class:`~radarslam.slam.report.ScanReport`)."""
    from radarslam.core.errors import InputError

    # the gate reads checked scans only; live components are read once (no second pass after an error)
    if live or not fast or (slam is not None and slam._gate is not None):
        return _stream_arrays_checked(events, False, slam, live, gate_out=gated)
    try:
        out = _stream_arrays_checked(events, True, slam, live)
    except InputError:
        return _stream_arrays_checked(events, False, slam, live)
    polar = out.polar
    if not (np.isfinite(polar).all() and (polar[:, 0] >= 0).all()):
        return _stream_arrays_checked(events, False, slam, live)
    return out


def _stream_arrays_checked(events, defer_polar: bool, slam=None, live: bool = False, gate_out=None) -> Stream:
    """:func:`_stream_arrays`, the detections of a float ``(m, 2)`` array left unchecked with ``defer_polar``
    (``gate_out``: :func:`_stream_arrays`' ``gated``)."""
    import copy

    from radarslam.core.errors import InputError
    from radarslam.core.types import Odometry, Scan
    from radarslam.core.validation import as_array
    from radarslam.slam.event_input import finite_number as _number, scan_polar as _scan_polar

    src, gate = (slam._odometry, slam._gate) if slam is not None else (None, None)
    if slam is not None and not live:
        src, gate = copy.deepcopy(src), copy.deepcopy(gate)
    # c.10.4, c.10.5: the whole stream's classification or fits in one compiled call where the scans allow it
    gated, fits = None, None
    sensors = any(isinstance(e, Scan) and e.sensor is not None for e in events)      # c.13: per scan, below
    own = [scan_mounting(e.sensor) is not None for e in events if isinstance(e, Scan)]
    if (gate is not None or src is not None) and not sensors:
        from radarslam.slam.fused.doppler import gate_stream, odometry_stream

        gated = gate_stream(events, gate) if gate is not None else None
        fits = odometry_stream(events, src) if src is not None and gate is None else None
    elif gate is not None and own and all(own):
        # c.13: every scan in its own radar's frame, so the gate classifies each about a zero mounting,
        # as the per-scan call below would: one compiled call, the same generator in the same order
        from radarslam.slam.fused.doppler import gate_stream

        zero = copy.copy(gate)
        zero.mounting = ORIGIN
        gated = gate_stream(events, zero)
    kinds, odo, odo_dt, polars, scan_k, last_t = [], [], [], [], [], None
    vel, vel_dt, vel_U, vel_Q = [], [], [], []
    moving, remember, seen, kept = [], [], [], []
    f = slam.config.filter if slam is not None else None
    view0 = (float(f.max_range_m), math.radians(f.field_of_view_deg) / 2) if f is not None else (0.0, 0.0)
    mounts, views, frames = [], [], []
    bm = slam.bias_model if slam is not None else None
    for ev in events:
        if isinstance(ev, Odometry) and src is not None:
            src.accumulate(ev)
        elif isinstance(ev, Odometry):
            u = ev.control
            if not (type(u) is np.ndarray and u.dtype == np.float64 and u.shape == (2,)
                    and math.isfinite(u[0]) and math.isfinite(u[1])):
                u = as_array("odometry.control", u, (2,))
            dt = _number(ev.dt, "odometry.dt")
            if not dt > 0:
                raise InputError(f"odometry.dt: expected a finite value > 0, got {ev.dt!r}")
            kinds.append(ODOMETRY)
            odo.append(u)
            odo_dt.append(dt)
        elif isinstance(ev, Scan):
            if src is not None and src.n:                                   # c.10.5
                for lst, v in zip((vel, vel_U, vel_dt, vel_Q), src.prediction_input(slam.Q)):
                    lst.append(v)
                src.clear_interval()
                kinds.append(VELOCITY)
            polar = ev.polar
            if not ((defer_polar or gated is not None) and type(polar) is np.ndarray and polar.dtype == np.float64 and polar.ndim == 2
                    and polar.shape[1] == 2):
                polar = _scan_polar(ev)
            t = _number(ev.t, "scan.t")
            if last_t is not None and t < last_t:
                raise InputError(f"scan.t: expected scan times that do not go backwards, got {t!r} after "
                                 f"{last_t!r} (scan {ev.index})")
            last_t = t
            ego = None
            sen = ev.sensor
            yaw_i, tau_i = (None, None) if sen is None or bm is None else (bm.yaw_index(sen.sensor_id),
                                                                          bm.time_index(sen.sensor_id))
            frames.append((-1 if yaw_i is None else yaw_i, -1 if tau_i is None else tau_i))
            if gate is not None:                                            # c.10.4
                framed = scan_mounting(sen) is not None or yaw_i is not None or tau_i is not None
                own = ORIGIN if framed else None                            # c.13: in the radar's frame
                keep, bad, ego, objects = gate.classify(ev, polar, own) if gated is None else gated[len(polars)]
                polar = polar[keep]
                moving.append(bad.size)
                remember.append(objects is not None)
                seen.append(np.empty((0, 2)) if objects is None else objects)
                kept.append(keep)
                if gate_out is not None:
                    gate_out.append((bad, ego))
            kinds.append(SCAN)
            mounts.append((ORIGIN if scan_mounting(sen) is None else sen).as_array())
            views.append((view0[0] if sen is None or sen.max_range_m is None else float(sen.max_range_m),
                          view0[1] if sen is None or sen.fov_rad is None else float(sen.fov_rad) / 2))
            polars.append(polar)
            scan_k.append(int(ev.index))
            if src is not None:
                src.fit(ev, ego if fits is None else fits[len(polars) - 1])
        else:
            raise InputError(f"event: expected Odometry or Scan, got {type(ev).__name__}")
    return _as_stream(kinds, odo, odo_dt, (vel, vel_dt, vel_U, vel_Q), polars, scan_k, (moving, remember, seen, kept),
                      (mounts, views, frames))


def _as_stream(kinds, odo, odo_dt, velocity, polars, scan_k, gated, sensors) -> Stream:
    """The :class:`Stream` of the lists :func:`_stream_arrays_checked` gathered."""
    mount = np.array(sensors[0], dtype=float).reshape(-1, 3)
    vel, vel_dt, vel_U, vel_Q = velocity
    moving, remember, seen, kept = gated
    S = len(polars)
    off = np.zeros(S + 1, dtype=np.int64)
    off[1:] = np.cumsum([p.shape[0] for p in polars])
    seen_off = np.zeros(S + 1, dtype=np.int64)
    if seen:
        seen_off[1:] = np.cumsum([p.shape[0] for p in seen])
    return Stream(np.array(kinds, dtype=np.int64), np.array(odo, dtype=float).reshape(-1, 2),
                  np.array(odo_dt, dtype=float), np.array(vel, dtype=float).reshape(-1, 3),
                  np.array(vel_dt, dtype=float), np.array(vel_U, dtype=float).reshape(-1, 3, 3),
                  np.array(vel_Q, dtype=float).reshape(-1, 3, 3), off,
                  (np.concatenate(polars) if polars else np.empty((0, 2))).reshape(-1, 2),
                  np.array(scan_k, dtype=np.int64), np.zeros(S, dtype=np.bool_),
                  np.array(moving if moving else [0] * S, dtype=np.int64),
                  np.array(remember if remember else [False] * S, dtype=np.bool_), seen_off,
                  (np.concatenate(seen) if seen else np.empty((0, 2))).reshape(-1, 2),
                  (np.concatenate(kept) if kept else np.empty(0)).astype(np.int64), mount,
                  np.any(mount != 0.0, axis=1), np.array(sensors[1], dtype=float).reshape(-1, 2),
                  *np.array(sensors[2], dtype=np.int64).reshape(-1, 2).T.copy())
