"""A line every few seconds while numba compiles in the foreground, so that a first run is never silent."""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

from radarslam.compiling.costs import HEARTBEAT_S


@contextmanager
def _beating(line, name: str):
    """An event to set when the work is over; until then ``line(seconds so far)`` on stderr every
    :data:`HEARTBEAT_S` seconds from a thread of its own. The one heartbeat of :func:`_heartbeat` and
    :func:`stage`."""
    done = threading.Event()
    t0 = time.perf_counter()

    def beat() -> None:
        while not done.wait(HEARTBEAT_S):
            print(line(time.perf_counter() - t0), file=sys.stderr, flush=True)

    th = threading.Thread(target=beat, name=name, daemon=True)
    th.start()
    try:
        yield done
    finally:
        done.set()
        th.join()


@contextmanager
def _heartbeat(expected_s: float, what: str = "run: still compiling the kernels of the engine's steps form"):
    """An event to set when the compile is over; until then, with ``expected_s`` > 0, a line on
    stderr every :data:`HEARTBEAT_S` seconds, ``what`` and the seconds so far, saying that numba still
    compiles (no silence longer than that while a first run compiles in the foreground)."""
    if expected_s <= 0:
        yield threading.Event()
        return
    lead = "\r" if sys.stderr.isatty() else ""
    with _beating(lambda el: f"{lead}{what} ({el:.0f} s of about {expected_s:.0f} s; once per machine)",
                  "radarslam-compile-heartbeat") as done:
        yield done


@contextmanager
def stage(what: str, enabled: bool = True):
    """A step before the filter that may take a while (the rig's ego-motion over a million
    detections, numba compiling its kernels the first time): a line on stderr every
    :data:`HEARTBEAT_S` seconds while it runs and one when it ends after half of that, so that the
    run's lines never stop for longer than a heartbeat (no silence over 10 s)."""
    if not enabled:
        yield
        return
    t0 = time.perf_counter()
    with _beating(lambda el: f"run: still {what} ({el:.0f} s)", "radarslam-stage-heartbeat"):
        yield
    el = time.perf_counter() - t0
    if el > HEARTBEAT_S / 2:
        print(f"run: {what}: done in {el:.0f} s", file=sys.stderr, flush=True)
