"""The fused engine's loop: an event stream through EKF-SLAM in one compiled call, from the filter's
state it is given (:class:`~radarslam.slam.fused.events.Carry`) to the state it gives back.

:func:`run_stream` calls :func:`~radarslam.slam.fused.events.predict_event` per odometry event and
:func:`~radarslam.slam.fused.events.scan_event` per scan, which read like
docs/method.md a.8: its steps in order, each a compiled function of :mod:`~radarslam.slam.fused.tracking` (steps 1-5),
:mod:`~radarslam.slam.fused.extent` (6) or :mod:`~radarslam.slam.fused.mapping` (steps 7-10), under
the partial view those of :mod:`~radarslam.slam.fused.view` (a.12); then the record after the scan
(:mod:`~radarslam.slam.fused.storage`).

It is compiled once per :class:`Family` of configurations (:func:`engine`): the partial view, JCBB
and the odometry-bias states are compile-time constants of the loop, so that a run compiles only
the branches its family takes (docs/architecture.md "Where the compile time goes").
"""

from __future__ import annotations

import functools
import time
from typing import NamedTuple

import numpy as np
from numba import njit, objmode

from radarslam.core.jit import uncompiled
from radarslam.slam.fused.events import no_scan_out, predict_event, scan_event
from radarslam.slam.fused.storage import _all_finite, cut_records, new_records, record_map, record_scan
from radarslam.slam.fused.tracking import BODY_VELOCITY, turn_noise
from radarslam.slam.layout import POSE_DIM

#: Status codes of :func:`run_stream`: what made the state non-finite, at which event.
OK, BAD_PREDICTION, BAD_SCAN = 0, 1, 2
#: Event kinds of ``Stream.kinds``: an odometer reading, a scan, a body-velocity input (c.10.5).
ODOMETRY, SCAN, VELOCITY = 0, 1, 2


@njit(cache=True)
def _clock():  # pragma: no cover - compiled
    """``time.perf_counter()`` from compiled code."""
    with objmode(t="float64"):
        t = time.perf_counter()
    return t


@njit(cache=True, inline="always")
def _prediction_input(stream, noise, cfg, ev, e_odo, e_vel):  # pragma: no cover - compiled
    """The input of event ``ev``, the odometer's ``e_odo``-th reading or the ``e_vel``-th body-velocity
    input (c.10.5): ``(u, dt, U, Q, model, e_odo, e_vel)``, the count of its kind moved on; a
    reading's control noise grown with the turn (c.11.8), both noises scaled to its interval (c.2.2)."""
    if stream.kinds[ev] == ODOMETRY:
        u, dt, U, Q = stream.odo[e_odo], stream.odo_dt[e_odo], noise.U, noise.Q
        if cfg.turn_index >= 0:                                            # c.11.8
            U = turn_noise(noise.U, u, cfg.turn_index, cfg.turn_gain2)
        if abs(dt - cfg.noise_ref) > 1e-9:                                 # c.2.2
            U, Q = U * (cfg.noise_ref / dt), Q * (dt / cfg.noise_ref)
        return u, dt, U, Q, cfg.motion, e_odo + 1, e_vel
    return (stream.vel[e_vel], stream.vel_dt[e_vel], stream.vel_U[e_vel], stream.vel_Q[e_vel], BODY_VELOCITY, e_odo,
            e_vel + 1)


class Family(NamedTuple):
    """Which of :func:`run_stream`'s optional branches a configuration takes: each is a compile-time
    constant of its own compiled engine (:func:`engine`), so that numba prunes the others before
    typing and never compiles what they call (docs/architecture.md "Where the compile time goes")."""

    view: bool   #: the partial view's sifting, association and shapes (docs/method.md a.12)
    jcbb: bool   #: the JCBB associator (c.4.1); else nearest neighbour, batch or batch-joint (``cfg.assoc``)
    bias: bool   #: the odometry-bias states' prediction (c.11, ``cfg.platform > 3``)


#: The family of every shipped profile but the partial view's, JCBB's and the bias states' (the car
#: parks' three variants, the automotive profile, both Victoria Park modes).
DEFAULT = Family(False, False, False)


def family_of(cfg) -> Family:
    """The :class:`Family` of the parameters ``cfg`` (:class:`~radarslam.slam.fused.plan.FusedParams`)."""
    return Family(bool(cfg.pv.on), cfg.assoc == 3, cfg.platform > POSE_DIM)


@functools.lru_cache(maxsize=None)
def engine(family: Family):
    """The compiled :func:`run_stream` of ``family``, built once per process: a closure over its flags
    (plain bools, by which numba's disk cache keys the code beside the signature), into which the steps
    that dispatch on a flag are inlined, so that a branch it never takes is pruned with its callees."""
    view, jcbb, bias = bool(family.view), bool(family.jcbb), bool(family.bias)

    def run_stream(stream, c, noise, cfg):  # pragma: no cover - compiled
        """Run the event stream through the filter from ``c`` (a :class:`~radarslam.slam.fused.events.Carry`,
        changed in place: :func:`~radarslam.slam.fused.events.initial_carry` for a new filter).

        ``stream`` is a :class:`~radarslam.slam.fused.stream.Stream` (its fields say what each event
        and scan holds), ``noise`` a :class:`~radarslam.slam.fused.plan.Noise`, ``cfg`` the parameters
        (:class:`~radarslam.slam.fused.plan.FusedParams`). Returns a tuple: status ``(code, event)``;
        the number of scans run; the per-scan :class:`~radarslam.slam.fused.storage.ScanRecord` (pose,
        covariance, detections, associated detections, landmarks, NIS sum and count and every NIS, map
        offsets, the landmarks after the scans ``stream.trace`` marks, and with ``cfg.timing`` the wall
        time of each scan with the predictions before it, else zeros); the maps after every scan
        (``cfg.all_maps``) or after the last (:class:`~radarslam.slam.fused.storage.MapRows`); and the
        per-scan associations as ``(scan, detection, landmark id)`` rows, all cut to the scans run; the
        filter after the last event run (the carry to run a further stream from); and what the last scan
        run did beyond its record (:class:`~radarslam.slam.fused.events.ScanOut`: the per-event report's).
        """
        S = stream.scan_off.shape[0] - 1
        zero = np.int64(0)    # counters: from a literal 0 numba compiles each callee twice (Literal[int](0), int64)
        rec, maps = new_records(S, 64, cfg.platform - 3)     # the odometry-bias states (c.11) after the pose
        a_rows, n_arows = np.empty((64, 3), dtype=np.int64), zero
        status = np.zeros(2, dtype=np.int64)
        t_last = _clock() if cfg.timing else 0.0
        e_odo, s, e_vel = zero, zero, zero
        last = no_scan_out()
        for ev in range(stream.kinds.shape[0]):
            if stream.kinds[ev] != SCAN:                                               # 1
                odometer = stream.kinds[ev] == ODOMETRY
                u, dt, U, Q, model, e_odo, e_vel = _prediction_input(stream, noise, cfg, ev, e_odo, e_vel)
                ok, c = predict_event(c, u, dt, U, Q, model, odometer, cfg, bias)   # c.2, c.11.2
                if not ok:
                    status[0], status[1] = BAD_PREDICTION, ev
                    break
                continue
            c, polar, n_assoc, nis, a_rows, n_arows, last = scan_event(c, stream, s, a_rows, n_arows, noise, cfg,
                                                                       view, jcbb, bias)  # a.8 steps 2-10
            if not _all_finite(c.x, c.P):
                status[0], status[1] = BAD_SCAN, ev
                break
            rec = record_scan(rec, s, c.x, c.P, c.lm, c.N, polar.shape[0] + stream.moving[s], n_assoc, nis,
                              stream.trace[s])
            if cfg.all_maps or s == S - 1:
                maps = record_map(rec, maps, s, c.x, c.P, c.lm, c.N, c.arcs, c.retired, c.n_retired, cfg)
            if cfg.timing:
                t1 = _clock()
                rec.seconds[s] = t1 - t_last
                t_last = t1
            s += 1
        return status, s, cut_records(rec, maps, s), a_rows[:n_arows], c, last

    return njit(cache=True)(_named(run_stream, family))


def _named(fn, family: Family):
    """``fn`` under a name of the family's own, so that numba's disk cache keeps each family in an index
    file of its own. In one index shared by the families (their keys differ only by the closure's
    values), two processes saving two families at once can both take the same data file number, and
    one family's key then loads the other family's machine code (docs/speed.md "First run")."""
    fn.__qualname__ = (f"engine.<locals>.run_stream_view{int(bool(family.view))}_jcbb{int(bool(family.jcbb))}"
                       f"_bias{int(bool(family.bias))}")
    return fn


#: How :func:`form` runs a family's engine: compiled; its loop and steps as Python over the compiled
#: kernels they call (``slam/``, ``extent/``, ``landmarks/``, ``models/``); or all of it as Python.
FORMS = ("compiled", "steps", "python")


def form(family: Family, how: str = "compiled", replace: tuple = ()):
    """The engine of ``family`` in form ``how`` (:data:`FORMS`): the one code of :func:`engine`, run
    compiled, or run by the interpreter (:func:`radarslam.core.jit.uncompiled`), whole (``"python"``,
    the reference the compiled engine is checked against: no numba code runs) or above its kernels
    (``"steps"``: the steps of this package, ``slam/fused/``, in Python, every kernel they call
    compiled). The three give the same results to rounding (docs/speed.md "The engine's three forms").
    ``replace``: ``(name, function)`` pairs, a component of the user's own called in the Python forms
    where the steps call ``name`` (``core.jit.uncompiled``; plan.py ``user_components``)."""
    if how not in FORMS:
        raise ValueError(f"how: expected one of {', '.join(FORMS)}, got {how!r}")
    if how == "compiled" and replace:
        raise ValueError("replace: a component of the user's own runs in a Python form, got how='compiled'")
    if how == "compiled":
        return engine(family)
    if not replace:
        return _python_form(family, how)
    return uncompiled(engine(family), _kernels_kept(how), dict(replace))


def _kernels_kept(how: str):
    """``uncompiled``'s ``keep`` of form ``how``: nothing (``"python"``), or every function outside
    ``slam/fused/`` (``"steps"``)."""
    steps = __name__.rpartition(".")[0]
    return None if how == "python" else (lambda d: not d.py_func.__module__.startswith(steps))


@functools.lru_cache(maxsize=None)
def _python_form(family: Family, how: str):
    """The engine of ``family`` in the Python form ``how``, cloned once per process."""
    return uncompiled(engine(family), _kernels_kept(how))


#: The default family's engine (:data:`DEFAULT`), under its former name.
run_stream = engine(DEFAULT)
