"""Tasks run on local worker processes or a Dask cluster, each result handed back to the caller,
who stores it at once (``radarslam montecarlo``'s trials, ``radarslam evaluate``'s scenes;
docs/architecture.md "Packages").

A task is a picklable call ``fn(*args)`` returning ``bytes``. :func:`run_pool` runs the tasks on
local worker processes, :func:`run_dask` on a local Dask cluster of ``dask_local`` processes or on
the scheduler at ``scheduler``; both call ``finish(item, data)`` in this process as each task ends.
Within :func:`sigterm_as_interrupt` SIGTERM is Ctrl-C: what is finished stays stored, the workers
are ended, the command exits with 130.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Callable
from pathlib import Path

from radarslam.core.errors import InputError, RadarSlamError

#: A task: ``(fn, args)`` called as ``fn(*args)`` in a worker, returning bytes.
Call = tuple[Callable[..., bytes], tuple]


def limit_threads() -> None:
    """One BLAS thread per worker process (the matrices are tiny; oversubscription only hurts)."""
    try:
        from threadpoolctl import threadpool_limits

        threadpool_limits(1)
    except ImportError:  # pragma: no cover
        pass


def init_pool_worker() -> None:
    """A pool worker: one BLAS thread; SIGTERM back to its default (end the process) and Ctrl-C
    ignored, the parent deciding (:func:`run_pool` ends its workers when interrupted). A forked
    worker inherits the parent's handlers; when one raised KeyboardInterrupt, the parent's
    ``terminate`` made the worker block for ever sending that exception back on a queue nobody
    read, holding the parent's output pipes."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    limit_threads()


@contextlib.contextmanager
def sigterm_as_interrupt():
    """Within the block SIGTERM is handled like Ctrl-C (KeyboardInterrupt): finished results stay
    stored, workers are ended, the command exits with 130. Only in the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, old)


@contextlib.contextmanager
def interrupts_as_flag():
    """Within the block Ctrl-C and SIGTERM only set the yielded event; the pool loop raises
    KeyboardInterrupt itself, between two waits. An exception raised by the signal handler at an
    arbitrary point could land inside ``concurrent.futures.wait`` while it holds some futures'
    locks (they are taken one by one, outside any ``try``); the pool's manager thread then blocked
    for ever on them, and the command on that thread at exit, after it had printed that it was
    interrupted (seen once in CI). Outside the main thread: no handler, an event never set."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    old = {s: signal.signal(s, lambda signum, frame: stop.set()) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield stop
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _spooled(spool: str, number: int, fn: Callable[..., bytes], args: tuple) -> str:
    """A pool worker's task: call ``fn(*args)``, write its bytes to a file of ``spool`` and return
    only that file's name. A result's bytes (a trial's are about 90 kB) sent back over the pool's
    result pipe take several writes; a worker ended by an interrupt in the middle of them left the
    parent's manager thread waiting for the rest for ever (its own copy of the pipe's write end
    keeps it open), and the command hung at exit after saying it was interrupted (seen in CI). A
    name of a few dozen bytes goes in one write, which a pipe makes atomic (POSIX ``PIPE_BUF``)."""
    data = fn(*args)
    part = Path(spool) / f"task_{number}.part"
    part.write_bytes(data)
    done = part.with_suffix(".bin")
    part.replace(done)         # a worker ended while writing leaves only a .part, removed with the spool
    return done.name


def run_pool(calls: dict, finish: Callable[[object, bytes], None], jobs: int, *, unit: str = "trial",
             poll_s: float = 0.2) -> None:
    """Run ``calls`` (``{item: (fn, args)}``, submitted in that order) on ``jobs`` local worker
    processes; ``finish(item, data)`` here as each ends. ``unit`` names an item in the message of
    a worker that died."""
    import tempfile
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
    from concurrent.futures.process import BrokenProcessPool

    with interrupts_as_flag() as stop, tempfile.TemporaryDirectory(prefix="radarslam-pool-") as spool:
        ex = ProcessPoolExecutor(max_workers=jobs, initializer=init_pool_worker)
        try:
            pending = {ex.submit(_spooled, spool, i, fn, args): item
                       for i, (item, (fn, args)) in enumerate(calls.items())}
            while pending:
                done, _ = wait(pending, timeout=poll_s, return_when=FIRST_COMPLETED)
                for f in done:
                    item = pending.pop(f)
                    try:
                        name = f.result()
                    except BrokenProcessPool:
                        raise RadarSlamError(f"a worker process died; every finished {unit} is stored, "
                                             "rerun the same command to resume") from None
                    spooled = Path(spool) / name
                    data = spooled.read_bytes()
                    spooled.unlink()
                    finish(item, data)
                if stop.is_set():
                    raise KeyboardInterrupt
        except BaseException:
            # Interrupted (Ctrl-C, SIGTERM) or failed: cancel what has not started and end the
            # workers now, so that none is left running a task after this process is gone.
            procs = list(getattr(ex, "_processes", {}).values())
            for proc in procs:
                proc.terminate()
            for proc in procs:       # one forked before its initializer ran still has the parent's handler
                proc.join(2.0)
                if proc.is_alive():
                    proc.kill()
            manager = getattr(ex, "_executor_manager_thread", None)
            ex.shutdown(wait=False, cancel_futures=True)
            # Let the pool's manager thread see its dead workers and close its wake-up pipe now.
            # Left running, it could close that pipe while the interpreter's exit hook
            # (concurrent.futures.process._python_exit, unlocked on 3.11) writes to it: an
            # OSError 'Bad file descriptor' traceback after the interrupted message (seen in CI).
            if manager is not None:
                manager.join(10.0)
            raise
        ex.shutdown(wait=True)


def run_dask(calls: dict, finish: Callable[[object, bytes], None], scheduler: str | None, dask_local: int | None, *,
             timeout_s: float, worker_daemon: bool = True) -> None:
    """Run ``calls`` (``{item: (fn, args, key)}``, ``key`` the Dask task's name) on a local Dask
    cluster of ``dask_local`` single-threaded worker processes on loopback, or on the running
    scheduler at ``scheduler`` (``tcp://HOST:PORT``, reached within ``timeout_s``);
    ``finish(item, data)`` here as each ends. ``worker_daemon`` False lets the local cluster's
    workers start processes of their own (Dask's ``distributed.worker.daemon``)."""
    try:
        import dask
        from dask.distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise InputError("--scheduler/--dask-local: Dask is not installed; pip install 'radarslam[dask]'") from None
    cluster = None
    if dask_local is not None:
        if dask_local < 1:
            raise InputError(f"--dask-local: expected an integer >= 1, got {dask_local}")
        with dask.config.set({"distributed.worker.daemon": worker_daemon}):
            cluster = LocalCluster(n_workers=dask_local, threads_per_worker=1, processes=True, host="127.0.0.1",
                                   dashboard_address=None)
    try:
        try:
            client = Client(cluster if cluster is not None else scheduler, timeout=f"{timeout_s:g}s")
        except OSError as exc:
            raise InputError(f"--scheduler: cannot reach {scheduler} ({exc})") from None
        try:
            client.run(limit_threads)
            futures = [client.submit(fn, *args, key=key, pure=False) for fn, args, key in calls.values()]
            index = {f.key: item for f, item in zip(futures, calls)}
            for f in as_completed(futures):
                finish(index[f.key], f.result())
        finally:
            client.close()
    finally:
        if cluster is not None:
            cluster.close()
