"""radarslam's own record of what numba's on-disk cache holds (docs/speed.md "First run").

numba has no public way to ask, before a call, whether its cache holds the machine code of a
function. So once a dispatcher has machine code in a process (``dispatcher.signatures`` is not
empty: numba compiled it, and saved it to its cache, or loaded it from there), :func:`mark`
writes a small *marker* file for it, and :func:`is_marked` reads it in a later process.

A marker is written where numba caches the function, found in numba's order: under
``NUMBA_CACHE_DIR`` (``numba.config.CACHE_DIR``) in numba's folder for the source's directory,
else in the ``__pycache__`` beside the source, else (that not writable) in the user's cache
directory under ``numba``. Clearing numba's cache so clears the markers with it, and the package's
own clearing of stale code (:mod:`radarslam.core.numba_cache`) deletes them too.

Its name carries a digest of everything numba checks before it loads cached code, so that it goes
stale when numba's cache does: the source file's path and stamp (its content with numba 0.68 and
later, its modification time and size before, as numba stamps it), the function's name, line and
bytecode, the values its closure holds (a family of the fused engine,
:func:`radarslam.slam.fused.engine.engine`, is one closure per family), the Python and numba
versions and the machine (LLVM's target triple, CPU name and features, or the ``NUMBA_CPU_NAME`` /
``NUMBA_CPU_FEATURES`` that override them). The limit: a marker whose code was deleted by hand out
of numba's cache (its ``.nbi``/``.nbc`` files alone) still reads as present, and the run it decides
then compiles first: slow, but with the same results.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import pickle
import re
import sys
import tempfile
from pathlib import Path

from radarslam.core.numba_cache import MARKER_SUFFIX


def _numba_subfolder(source: str) -> str:
    """The folder numba names for the functions of ``source``'s directory in a cache of its own:
    that directory's name and the SHA-1 of its full path."""
    folder = os.path.dirname(os.path.abspath(source))
    return f"{os.path.basename(folder)}_{hashlib.sha1(folder.encode()).hexdigest()}"


def _user_cache_root() -> Path:
    """The user's cache directory for numba, as numba finds it."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA", Path.home() / "AppData" / "Local")) / "numba" / "Cache"
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches" / "numba"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "numba"


def _writable(folder: Path) -> bool:
    """Whether ``folder`` exists, or can be made, and takes a file (numba's own test of a cache folder)."""
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def cache_folder(source: str) -> Path | None:
    """Where numba caches the functions of the file ``source``, in numba's order (module docstring);
    None when the file does not exist or no folder can be written (numba then caches nothing)."""
    import numba

    if not os.path.isfile(source):
        return None
    candidates = [Path(os.path.dirname(os.path.abspath(source))) / "__pycache__",
                  _user_cache_root() / _numba_subfolder(source)]
    if numba.config.CACHE_DIR:
        candidates.insert(0, Path(numba.config.CACHE_DIR) / _numba_subfolder(source))
    return next((c for c in candidates if _writable(c)), None)


@functools.lru_cache(maxsize=None)
def _content_digest(path: str, mtime_ns: int, size: int) -> str:
    """SHA-256 of the file ``path`` (memoised by its modification time and size)."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@functools.lru_cache(maxsize=1)
def _stamps_content() -> bool:
    """Whether numba's source stamp is the file's content (numba 0.68 on) rather than its
    modification time and size (before)."""
    import numba

    found = re.match(r"(\d+)\.(\d+)", numba.__version__)
    return found is None or (int(found[1]), int(found[2])) >= (0, 68)


def _source_stamp(source: str) -> str:
    """The stamp numba compares before it loads cached code of ``source`` (:func:`_stamps_content`)."""
    st = os.stat(source)
    if _stamps_content():
        return _content_digest(source, st.st_mtime_ns, st.st_size)
    return f"{st.st_mtime!r}:{st.st_size}"


@functools.lru_cache(maxsize=1)
def _machine() -> dict:
    """The Python, the numba and the machine that numba keys its cached code by."""
    import llvmlite.binding as llvm
    import numba

    cpu = numba.config.CPU_NAME or llvm.get_host_cpu_name()
    features = numba.config.CPU_FEATURES
    if features is None:
        try:
            host = llvm.get_host_cpu_features()
            if not numba.config.ENABLE_AVX:
                for name in host:
                    if name.startswith("avx"):
                        host[name] = False
            features = host.flatten()
        except RuntimeError:
            features = ""
    return {"python": f"{sys.implementation.cache_tag}{getattr(sys, 'abiflags', '')}", "numba": numba.__version__,
            "triple": llvm.get_process_triple(), "cpu": cpu,
            "features": hashlib.sha256(features.encode()).hexdigest()}


def key(dispatcher) -> dict | None:
    """What a marker of ``dispatcher`` stands for (module docstring); None when that cannot be
    told: not a numba dispatcher, its source file missing, or a closure whose values do not pickle."""
    func = getattr(dispatcher, "py_func", None)
    code = getattr(func, "__code__", None)
    if code is None:
        return None
    source = os.path.abspath(code.co_filename)
    try:
        stamp = _source_stamp(source)
        cells = b"" if func.__closure__ is None else pickle.dumps(
            tuple(c.cell_contents for c in func.__closure__), protocol=4)
    except (OSError, ValueError, TypeError, AttributeError, pickle.PicklingError):
        return None
    return {"function": f"{func.__module__}.{func.__qualname__}", "line": code.co_firstlineno, "source": source,
            "source_stamp": stamp, "bytecode_sha256": hashlib.sha256(code.co_code).hexdigest(),
            "closure_sha256": hashlib.sha256(cells).hexdigest(), **_machine()}


def _path_of(k: dict) -> Path | None:
    """The marker file of the key ``k`` (present or not), or None where numba caches nothing."""
    folder = cache_folder(k["source"])
    if folder is None:
        return None
    name = "".join(ch if ch.isalnum() or ch in "._" else "_" for ch in k["function"].replace("<", "").replace(">", ""))
    digest = hashlib.sha256(json.dumps(k, sort_keys=True).encode()).hexdigest()[:24]
    return folder / f"{name}.{digest}{MARKER_SUFFIX}"


def marker_path(dispatcher) -> Path | None:
    """The marker file of ``dispatcher`` (present or not), or None when it has none (:func:`key`,
    :func:`cache_folder`)."""
    k = key(dispatcher)
    return None if k is None else _path_of(k)


def is_marked(dispatcher) -> bool | None:
    """True when the marker of ``dispatcher`` for its current source, closure, Python, numba and
    machine exists; False when it does not, or numba can cache nothing of it (its source file
    missing, no folder writable); None when that cannot be told (not a numba dispatcher, a closure
    whose values do not pickle)."""
    code = getattr(getattr(dispatcher, "py_func", None), "__code__", None)
    if code is not None and not os.path.isfile(code.co_filename):
        return False
    k = key(dispatcher)
    if k is None:
        return None
    path = _path_of(k)
    return path is not None and path.is_file()


def mark(*dispatchers) -> int:
    """Write the marker of each of ``dispatchers`` that has machine code in this process and has no
    marker yet; the number written. A folder that cannot be written is skipped (a later run then
    takes the code as not cached: slower, never wrong)."""
    written = 0
    for d in dispatchers:
        k = key(d) if getattr(d, "signatures", None) else None
        path = None if k is None else _path_of(k)
        if path is None or path.is_file():
            continue
        tmp = None
        try:
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".marker-", suffix=".tmp")
            with os.fdopen(fd, "w") as fh:
                json.dump(k, fh, indent=1, sort_keys=True)
            os.replace(tmp, path)                 # whole or not at all, whoever writes it first
            written += 1
        except OSError:
            if tmp is not None:
                Path(tmp).unlink(missing_ok=True)
    return written
