"""The progress line of a long command (trials, scans): a tqdm bar with a rate and an ETA."""

from __future__ import annotations

import math
import sys
import time

#: The progress line, as tqdm's ``bar_format``: the bar, the units done, the rate and the ETA (both
#: measured by :class:`Progress`'s clock, not tqdm's).
PROGRESS_FORMAT = "[{bar:30}] {n}/{total} {unit}  {rate_s} {unit}/s  ETA {eta_s}"


class Progress:
    """A one-line progress bar on stderr: units done, rate and ETA, drawn by tqdm.

    On a terminal tqdm redraws the line in place (at most every 0.2 s); on any other stream (a
    log file, a pipe) a whole line is written at the first unit done, at every new decile and at
    the end, never a carriage return. Nothing is written before the first unit is done, so no ETA
    is shown before there is a rate to base it on. The rate is measured from the construction or
    from :meth:`restart` (after a compilation that is not a unit's cost); with ``warm_up_unit``
    the clock starts when the first unit is done instead (numba compiling within the first scan),
    whose line then shows no ETA.
    """

    def __init__(self, total: int, done: int = 0, stream=None, enabled: bool = True, unit: str = "trials",
                 warm_up_unit: bool = False):
        self.total, self.done, self.start_done = total, done, done
        self.unit = unit
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self.t0: float | None = None if warm_up_unit else time.perf_counter()
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last = 0.0
        self._last_decile = -1
        self._bar = None
        if enabled and self.tty:
            from tqdm import tqdm

            # tqdm draws the line on the terminal; it never draws on its own (delay: forever), only
            # when update() refreshes it, so that its clock and cadence are this class's
            self._bar = tqdm(total=total, initial=done, file=self.stream, unit=unit, delay=math.inf, leave=False,
                             dynamic_ncols=True)

    def restart(self) -> None:
        """Measure the rate from now on (after a compilation that is not a trial's cost)."""
        self.t0, self.start_done = time.perf_counter(), self.done

    def update(self, n: int = 1) -> None:
        self.done += n
        if not self.enabled:
            return
        now = time.perf_counter()
        if self.t0 is None:                       # warm_up_unit: the clock starts after the first unit
            self.t0, self.start_done = now, self.done
        decile = int(10 * self.done / max(self.total, 1))
        if self._bar is not None and (now - self._last > 0.2 or self.done == self.total):
            self._bar.n = self.done
            self._bar.display(self.line(now))
            if self.done == self.total:
                self._bar.fp.write("\n")
            self._bar.fp.flush()
            self._last = now
        elif self._bar is None and (decile != self._last_decile or self.done == self.total):
            self.stream.write(self.line(now) + "\n")
            self.stream.flush()
            self._last_decile = decile

    def line(self, now: float | None = None) -> str:
        """The progress line at ``now`` (:data:`PROGRESS_FORMAT`, rendered by tqdm)."""
        from tqdm import tqdm

        now = now or time.perf_counter()
        el = now - self.t0 if self.t0 is not None else 0.0
        new = self.done - self.start_done
        rate = new / el if el > 0 else 0.0
        eta = (self.total - self.done) / rate if rate > 0 else math.inf
        eta_s = "--" if not math.isfinite(eta) else f"{int(eta // 60)}m{int(eta % 60):02d}s"
        return tqdm.format_meter(self.done, self.total, el, ascii=".#", unit=self.unit, bar_format=PROGRESS_FORMAT,
                                 rate_s=f"{rate:.2f}", eta_s=eta_s)


def scan_clock(bar, compiled=None):
    """``on_scan`` of an event-by-event run: the progress line; after the second scan (numba compiles
    the steps of a scan without associations at the first, the association and extent steps at the
    second) the rate is measured from there and ``compiled`` (a ``threading.Event``), if given, set."""
    n = [0]

    def tick() -> None:
        bar.update()
        n[0] += 1
        if n[0] == 2:
            bar.restart()
            if compiled is not None:
                compiled.set()
    return tick
