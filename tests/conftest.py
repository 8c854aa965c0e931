"""Shared fixtures and settings.

Hypothesis runs derandomized (a fixed example sequence) so CI is reproducible.
``RADARSLAM_SLOW_SCALE`` (default 1.0) scales the trial counts of ``@pytest.mark.slow`` tests;
CI sets it below 1 to keep its run short while still executing them.
"""

from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

# A Monte Carlo that meets a cold numba cache would start a detached compilation of the fused
# engine (compiling/background.py); the tests that need it say so themselves.
os.environ.setdefault("RADARSLAM_BACKGROUND_COMPILE", "0")

#: LLVM's optimisation level the tests compile with (numba's ``NUMBA_OPT``, 3 by default): level 1
#: compiles the default family's fused engine in 85 s of CPU instead of 114, with results equal to
#: the last bit (20 trials x 3 variants compared; the golden tests compare them every session).
TEST_NUMBA_OPT = "1"


def _test_numba_cache() -> Path:
    """numba's cache for the test session, of its own: numba's cache index does not key on
    ``NUMBA_OPT``, so code compiled at :data:`TEST_NUMBA_OPT` must never land where a user's later
    run loads it (beside the installed sources). Under ``build/`` (ignored by git), one folder per
    stamp of the compiled sources (``core/numba_cache.py``: numba keys a function by its own file
    only, so an edited callee must empty the cache, as the package's own refresh does beside the
    sources); the folders of other stamps are deleted."""
    import shutil

    from radarslam.core.numba_cache import ROOT, sources_stamp      # imports no numba

    base = Path(__file__).resolve().parents[1] / "build" / "numba-tests"
    here = base / sources_stamp(ROOT)[:16]
    if base.is_dir():
        for old in base.iterdir():
            if old != here:
                shutil.rmtree(old, ignore_errors=True)
    return here


# Set before numba is imported (conftest.py loads first; subprocesses inherit both). A user's own
# NUMBA_CACHE_DIR or NUMBA_OPT is left alone, and then the other too.
# A package that does not import is left to fail in the tests themselves.
if "NUMBA_CACHE_DIR" not in os.environ and "NUMBA_OPT" not in os.environ:
    try:
        os.environ["NUMBA_CACHE_DIR"] = str(_test_numba_cache())
    except ImportError:
        pass
    else:
        os.environ["NUMBA_OPT"] = TEST_NUMBA_OPT
    if "numba" in sys.modules:                  # a plugin imported it first: read the variables again
        sys.modules["numba"].core.config.reload_config()

settings.register_profile("ci", derandomize=True, deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("ci")


def slow_scale() -> float:
    return float(os.environ.get("RADARSLAM_SLOW_SCALE", "1.0"))


def scaled(n: int, minimum: int = 1) -> int:
    """``n`` trials scaled by ``RADARSLAM_SLOW_SCALE``, at least ``minimum``."""
    return max(minimum, int(round(n * slow_scale())))


def require(module: str):
    """Import an optional dependency; skip without it locally, but fail under CI (CI=true),
    where every extra is installed and a skip would hide a missing install step."""
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        if os.environ.get("CI"):
            raise
        pytest.skip(f"{module} is not installed (an optional extra)")


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(12345)


@pytest.fixture(scope="session")
def default_config():
    from radarslam.config import profile_config

    return profile_config("apsipa")


VICTORIA_PARK = Path(__file__).resolve().parents[2] / "shared" / "data" / "victoria_park"


@pytest.fixture(scope="session")
def victoria_park_dir() -> Path:
    """The real Victoria Park files (``../shared/data/victoria_park``): skip locally without them,
    but FAIL under CI (CI=true), whose environment provides ``../shared``."""
    if not VICTORIA_PARK.is_dir():
        msg = f"Victoria Park data not found at {VICTORIA_PARK}"
        if os.environ.get("CI"):
            pytest.fail(msg + " (CI must provide ../shared)")
        pytest.skip(msg)
    return VICTORIA_PARK


@contextlib.contextmanager
def _one_process_at_a_time(path: Path):
    """Hold an exclusive lock on ``path``, waiting for it: under pytest-xdist every worker runs the
    session fixtures, and they share numba's cache; the first compiles, the others wait and then
    load its cached code instead of compiling the same engine again on the other core."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        yield
        return
    with open(path, "a+") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def family_evidence_path(tmp_path_factory) -> Path:
    """Where the session's warm-up leaves what its cold compile of the default family touched
    (tests/family_evidence.py): one file for every pytest-xdist worker of the session."""
    import family_evidence

    base = tmp_path_factory.getbasetemp()
    return (base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base) / family_evidence.NAME


#: The families of the fused engine (slam/fused/engine.py ``Family``) that the session's cold warm-up
#: also compiles, in its second process, on the core the default family's compile leaves idle (the
#: tests of the odometry-bias states compile it inside their call otherwise): the bias states'. One
#: only: measured, JCBB's too made the warm-up 117 s instead of 92, with both 143. Not the partial view's:
#: the record of tests/family_evidence.py must find it cold.
EXTRA_FAMILIES = ({"filter": {"odometry_bias": "states"}},)


def _side_and_families(cfg_dict: dict, overlay: dict) -> None:
    """Second process of the session's cold warm-up: the simulation and the evaluation (what the
    warm-up's own second process compiles, compiling/warmup.py), the kernels of
    :func:`_standalone_kernels`, then :data:`EXTRA_FAMILIES`."""
    from radarslam.compiling.warmup import _side, compile_fused
    from radarslam.config import from_dict
    from radarslam.config.variants import Variant

    _side(cfg_dict, overlay)
    cfg = from_dict(cfg_dict)
    _standalone_kernels(cfg)
    compile_fused(cfg, tuple(Variant(f"family{i}", f"family {i}", o)
                                             for i, o in enumerate(EXTRA_FAMILIES)))


def _small_stream(n: int = 25) -> list:
    """``n`` odometry readings and scans of three clusters of eight detections with a Doppler
    column: enough scans for landmarks to be confirmed, so that association runs."""
    from radarslam.core.types import Odometry, Scan

    rng = np.random.default_rng(0)
    events = []
    for k in range(n):
        t = 0.1 * (k + 1)
        polar = np.vstack([np.column_stack([r + 0.3 * rng.standard_normal(8), a + 0.02 * rng.standard_normal(8)])
                           for r, a in ((8.0, 0.3), (12.0, -0.4), (15.0, 0.1))])
        doppler = -np.cos(polar[:, 1]) + 0.05 * rng.standard_normal(polar.shape[0])
        events += [Odometry(t, 0.1, np.array([1.0, 0.0]), gyro_rad_s=0.0),
                   Scan(t, k + 1, polar, channels={"doppler_mps": doppler})]
    return events


def _standalone_kernels(cfg) -> None:
    """Compiled code that the tests need and that no family of the fused engine calls, so that the
    warm-up's second process compiles it while the default family compiles beside it (instead of a
    test inside its call, after the warm-up): the Doppler gate's classifier of a stream (what every
    fused run of the automotive profile calls first, and its per-scan classifier), then the
    kernels of the engine's steps form under JCBB and the MEM-EKF extent rows."""
    from radarslam.config import profile_config
    from radarslam.config.variants import Variant, apply_variant
    from radarslam.core.types import Scan
    from radarslam.slam.doppler_gate import DopplerGate
    from radarslam.slam.driver import run_filter
    from radarslam.slam.fused.doppler import gate_stream

    stream = _small_stream()
    gate_stream([e for e in stream if isinstance(e, Scan)], DopplerGate(profile_config("automotive").filter))
    for overlay in ({"landmarks": {"associator": "jcbb"}}, {"extent": {"estimator": "mem-ekf"}}):
        overlay = {**overlay, "filter": {"backend": "numba"}}
        run_filter(apply_variant(cfg, Variant("kernels", "kernels", overlay)), stream, engine="fused-steps")


@contextlib.contextmanager
def _compiling_without_loads():
    """numba compiles every function this process calls instead of loading it from its cache (and
    still saves it there): a compile from nothing, whatever another process writes to the cache
    meanwhile (a function loaded from the cache is not gone through, so what it calls would get
    no signature in tests/family_evidence.py's record)."""
    from numba.core import caching

    load = caching.Cache.load_overload
    caching.Cache.load_overload = lambda self, sig, target_context: None
    try:
        yield
    finally:
        caching.Cache.load_overload = load


def _cold_warm_up(family_evidence_path: Path, workers: int) -> None:
    """The session's warm-up on a cache empty of the package (a fresh clone), which is also the
    record of tests/family_evidence.py: the default family compiled here without loads from the
    cache; beside it, with more than one worker, the second process (:func:`_side_and_families`)."""
    from concurrent.futures import ProcessPoolExecutor

    import family_evidence
    from radarslam.compiling.warmup import _side, compile_fused
    from radarslam.config import profile_config, to_dict
    from radarslam.config.variants import DEFAULT_VARIANTS

    cfg = profile_config("apsipa")
    side = ProcessPoolExecutor(max_workers=1) if workers > 1 else None
    job = side.submit(_side_and_families, to_dict(cfg), dict(DEFAULT_VARIANTS[0].overlay)) if side else None
    try:
        with _compiling_without_loads():
            compile_fused(cfg, DEFAULT_VARIANTS)
        cold = family_evidence.counts()
        if side is None:            # one worker: the simulation and the evaluation next, here
            _side(to_dict(cfg), dict(DEFAULT_VARIANTS[0].overlay))
        else:
            job.result()
    finally:
        if side is not None:
            side.shutdown(wait=True)
    family_evidence.record(family_evidence_path, cold)


def _compile_key(dispatcher) -> str | None:
    """What names one compiled function in numba's cache: its index file, and for a closure (the fused
    engine's families, slam/fused/engine.py ``engine``) the flags it closes over; None for a function
    numba does not cache."""
    cache = getattr(dispatcher, "_cache", None)
    index = getattr(getattr(cache, "_cache_file", None), "_index_path", None)
    if index is None:
        return None
    cells = []
    for cell in dispatcher.py_func.__closure__ or ():
        try:
            value = cell.cell_contents
        except ValueError:              # an empty cell
            value = None
        cells.append(repr(value) if isinstance(value, (bool, int, float, str, type(None))) else type(value).__name__)
    return f"{index}|{','.join(cells)}"


@contextlib.contextmanager
def _compiling_one_process_at_a_time(lock_dir: Path):
    """Under pytest-xdist, a function's compile on a cold cache holds a file lock named after it
    (:func:`_compile_key`): a worker that meets a function the other is compiling waits for it and
    then loads its code from numba's cache instead of compiling the same code on the other core
    (seen: both workers compiling the Doppler classifier, 13 s each, or JCBB's kernel, 11 s each,
    when their tests ran at the same time). Taken inside numba's compiler lock, so that one thread
    of a process compiles at a time, and in call order (a caller's lock, then its callees'), so
    that no two processes wait for each other; a process holds a lock once (a compile re-entered)."""
    import fcntl
    import hashlib

    from numba.core import dispatcher, sigutils
    from numba.core.compiler_lock import global_compiler_lock

    lock_dir.mkdir(parents=True, exist_ok=True)
    compile_ = dispatcher.Dispatcher.compile
    held: set[str] = set()

    def compile(self, sig):
        try:
            args, _ = sigutils.normalize_signature(sig)
        except Exception:               # numba's own compile says what is wrong with it
            return compile_(self, sig)
        key = None if self.overloads.get(tuple(args)) is not None else _compile_key(self)
        if key is None:
            return compile_(self, sig)
        with global_compiler_lock:
            if key in held:
                return compile_(self, sig)
            path = lock_dir / (hashlib.sha1(key.encode()).hexdigest()[:20] + ".lock")
            with open(path, "a+") as fh:
                fcntl.flock(fh, fcntl.LOCK_EX)
                held.add(key)
                try:
                    return compile_(self, sig)
                finally:
                    held.discard(key)
                    fcntl.flock(fh, fcntl.LOCK_UN)

    dispatcher.Dispatcher.compile = compile
    try:
        yield
    finally:
        dispatcher.Dispatcher.compile = compile_


@pytest.fixture(scope="session", autouse=True)
def _fused_engine_compiled(family_evidence_path):
    """Compile the fused engine once before the first test when numba's cache is cold, so that
    every Monte Carlo in the session runs its trials with the engine the results are compared
    against (a short run on a cold cache would take the engine's steps form, compiling/warmup.py). Without numba, nothing to do.

    Under pytest-xdist one worker compiles and the others wait for its lock, then find the cache
    warm. The warm-up's second process (the simulation and the evaluation) takes the idle core.
    On a cache empty of the package (a fresh clone) the compile is also the record of
    tests/family_evidence.py (:func:`_cold_warm_up`), and the second process compiles the
    :data:`EXTRA_FAMILIES` too."""
    try:
        import numba  # noqa: F401
    except ImportError:
        yield
        return
    from radarslam.config import profile_config
    from radarslam.compiling import background
    from radarslam.config.variants import DEFAULT_VARIANTS
    from radarslam.compiling.warmup import warm_up

    import family_evidence
    from radarslam.compiling.readiness import fused_is_cold

    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    # keyed like the background compilation's lock: the package's location and NUMBA_CACHE_DIR
    with _one_process_at_a_time(background.lock_path().with_suffix(".tests.lock")):
        if fused_is_cold() and family_evidence.cache_empty() and family_evidence.untouched():
            _cold_warm_up(family_evidence_path, workers)     # a compile from nothing: its evidence, once
        else:
            warm_up(profile_config("apsipa"), DEFAULT_VARIANTS, lambda s: None, parallel=workers > 1)
    if workers > 1 and os.name == "posix":
        with _compiling_one_process_at_a_time(family_evidence_path.parent / "numba-compile-locks"):
            yield
    else:
        yield
