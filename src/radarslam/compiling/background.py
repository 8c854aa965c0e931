"""Compile the fused engine in a detached, low-priority process, for the runs that come after.

The first Monte Carlo on a machine runs its trials with the engine's steps form when that ends
sooner than compiling the fused engine's whole loop first (:func:`radarslam.compiling.warmup.first_run_engine`).
The fused engine is then compiled here, in a process of its own that outlives the command: at the
lowest CPU priority (``nice 19``), so that it takes the cores only when the run leaves them idle,
in a process group of its own (Ctrl-C on the command does not reach it), with its output in a log
file. It stays in the command's session on purpose: Linux schedules each session (an "autogroup")
as one unit, so a process in a session of its own would take a fair share of the cores whatever its
nice value and slow the run down.
It writes numba's cache, which every later run loads (docs/architecture.md "Backends").

One compilation at a time per cache: the process holds an exclusive lock on a file named after
the package's location and ``NUMBA_CACHE_DIR``; a second one finds it held and exits.
``RADARSLAM_BACKGROUND_COMPILE=0`` turns the whole thing off (the fused engine then compiles in the
foreground of the first run long enough to pay for it).

Run as ``python -m radarslam.compiling.background JOB.json`` (what :func:`start` does): the job
file holds the configuration and the variants, and is deleted once read.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

#: Environment variable that turns background compilation off when set to 0.
ENV = "RADARSLAM_BACKGROUND_COMPILE"
_PACKAGE = Path(__file__).resolve().parents[1]


def enabled() -> bool:
    """False when ``RADARSLAM_BACKGROUND_COMPILE`` is ``0``, ``false`` or ``no``."""
    return os.environ.get(ENV, "1").strip().lower() not in ("0", "false", "no")


def lock_path() -> Path:
    """The lock of the numba cache this process would write (package location and NUMBA_CACHE_DIR)."""
    key = f"{_PACKAGE}|{os.environ.get('NUMBA_CACHE_DIR', '')}".encode()
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return Path(tempfile.gettempdir()) / f"radarslam-compile-{uid}-{hashlib.sha1(key).hexdigest()[:12]}.lock"


@contextlib.contextmanager
def held_lock(path: Path):
    """Yield True while this process holds the exclusive lock ``path``; False (nothing held) when
    another process has it. Where file locks do not exist, always True."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield True
        return
    with open(path, "a+") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            yield False
            return
        try:
            yield True
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


def busy() -> bool:
    """True while another process compiles in the background for this cache."""
    with held_lock(lock_path()) as mine:
        return not mine


def _lower_priority() -> None:  # pragma: no cover - runs in the child before exec
    with contextlib.suppress(OSError):
        os.nice(19)


def start(cfg_dict: dict, variants_json: list, log_file: Path | None = None) -> int | None:
    """Start the detached compilation of the fused engine for these variants; its pid, or None
    when it is turned off (:func:`enabled`) or already running (:func:`busy`)."""
    if not enabled() or busy():
        return None
    fd, job = tempfile.mkstemp(prefix="radarslam-compile-", suffix=".json")
    with os.fdopen(fd, "w") as fh:
        json.dump({"config": cfg_dict, "variants": variants_json}, fh)
    log_file = log_file or lock_path().with_suffix(".log")
    with open(log_file, "w") as out:
        proc = subprocess.Popen([sys.executable, "-m", "radarslam.compiling.background_job", job],
                                stdin=subprocess.DEVNULL, stdout=out, stderr=subprocess.STDOUT,
                                process_group=0, close_fds=True,
                                preexec_fn=_lower_priority if os.name == "posix" else None)
    return proc.pid

