"""A line every few seconds while numba compiles in the foreground, so that a first run is never silent."""

from __future__ import annotations

import sys
import threading
import time
from contextlib import contextmanager

from radarslam.compiling.costs import HEARTBEAT_S


@contextmanager
def _heartbeat(expected_s: float, what: str = "run: still compiling the per-event engine's kernels"):
    """An event to set when the compile is over; until then, with ``expected_s`` > 0, a line on
    stderr every :data:`HEARTBEAT_S` seconds, ``what`` and the seconds so far, saying that numba still
    compiles (no silence longer than that while a first run compiles in the foreground)."""
    done = threading.Event()
    if expected_s <= 0:
        yield done
        return
    t0 = time.perf_counter()

    def beat() -> None:
        while not done.wait(HEARTBEAT_S):
            el = time.perf_counter() - t0
            lead = "\r" if sys.stderr.isatty() else ""
            print(f"{lead}{what} ({el:.0f} s of about {expected_s:.0f} s; once per machine)", file=sys.stderr,
                  flush=True)

    th = threading.Thread(target=beat, name="radarslam-compile-heartbeat", daemon=True)
    th.start()
    try:
        yield done
    finally:
        done.set()
        th.join()


@contextmanager
def stage(what: str, enabled: bool = True):
    """A step before the filter that may take a while (the rig's ego-motion over a million
    detections, numba compiling its kernels the first time): a line on stderr every
    :data:`HEARTBEAT_S` seconds while it runs and one when it ends after half of that, so that the
    run's lines never stop for longer than a heartbeat (issue 43: no silence over 10 s)."""
    if not enabled:
        yield
        return
    done = threading.Event()
    t0 = time.perf_counter()

    def beat() -> None:
        while not done.wait(HEARTBEAT_S):
            print(f"run: still {what} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)

    th = threading.Thread(target=beat, name="radarslam-stage-heartbeat", daemon=True)
    th.start()
    try:
        yield
    finally:
        done.set()
        th.join()
        el = time.perf_counter() - t0
        if el > HEARTBEAT_S / 2:
            print(f"run: {what}: done in {el:.0f} s", file=sys.stderr, flush=True)
