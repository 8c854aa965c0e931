"""Whether numba's cache already holds the machine code a command needs (docs/speed.md "First run"):
the fused engine of each family, the kernels its steps form calls, the scan simulation and the
evaluation's matching. Nothing here compiles.

What the cache holds is read from radarslam's own markers (:mod:`.markers`), never out of numba's
private index: a process in which a watched dispatcher (:func:`watched`) has machine code marks it
when its compiled path ends (the warm-up, the background compile, the second compiling process)
and, for what the command itself compiled or loaded, when it exits (:func:`mark_compiled`,
registered with :mod:`atexit` on import)."""

from __future__ import annotations

import atexit
import itertools
import sys

from radarslam.compiling import markers
from radarslam.config import Config
from radarslam.config.variants import Variant, apply_variant

#: The compiled functions the policy (:mod:`.policy`) asks about, beside the fused engine's
#: families: ``(module, name)``.
WATCHED = (("radarslam.simulation._compiled", "simulate_scans"), ("radarslam.metrics._compiled", "match_scans"),
           *(STEPS_KERNELS := (("radarslam.slam._numba", "associate_scan"), ("radarslam.slam._numba", "batch_associate_scan"),
                               ("radarslam.landmarks._compiled", "compiled_mn_windows"),
                               ("radarslam.extent._compiled", "merge_rows"))),
           ("radarslam.models._doppler_compiled", "classify_scan"))


def steps_kernels() -> list:
    """The kernels of :data:`STEPS_KERNELS` (imported): those the engine's steps form compiles last on a
    first scan, whose machine code says its kernels are ready."""
    import importlib

    return [getattr(importlib.import_module(m), name) for m, name in STEPS_KERNELS]


def has_fresh_code(dispatcher) -> bool | None:
    """Whether ``dispatcher`` has machine code without compiling: compiled or loaded in this process
    (``dispatcher.signatures``), or marked as cached for its current source, closure, Python, numba
    and machine (:func:`.markers.is_marked`; a family's engine by its own closure's values, not
    another family's). None where that cannot be told (not a numba dispatcher)."""
    if getattr(dispatcher, "py_func", None) is None:
        return None
    if getattr(dispatcher, "signatures", None):
        return True
    return markers.is_marked(dispatcher)


def watched() -> list:
    """The dispatchers of :data:`WATCHED` and the fused engine of every family, of the modules this
    process has imported (none is imported here: a module not imported has no machine code)."""
    found = [getattr(sys.modules[m], name) for m, name in WATCHED if m in sys.modules]
    if "radarslam.slam.fused.engine" in sys.modules:
        fused = sys.modules["radarslam.slam.fused.engine"]
        found += [fused.engine(fused.Family(*flags)) for flags in itertools.product((False, True), repeat=3)]
    return found


def mark_compiled() -> int:
    """Mark every watched dispatcher that has machine code in this process (:func:`.markers.mark`);
    the number of markers written. Called where a compiled path ends, and at exit."""
    try:
        return markers.mark(*watched())
    except Exception:               # pragma: no cover - a marker is only a hint: never fail a run for it
        return 0


atexit.register(mark_compiled)


def fused_families(config: Config, variants: tuple[Variant, ...] = ()) -> tuple:
    """The families of the fused engine (:class:`radarslam.slam.fused.engine.Family`) that
    ``config`` under each of ``variants`` (none: ``config`` itself) runs with, as arguments for
    :func:`cache_is_cold`, :func:`fused_is_cold` and :func:`.first_run._filter_ready`: empty when
    that is the default family alone (or the fused engine covers none of them)."""
    from radarslam.slam._fused import DEFAULT, family
    from radarslam.slam.filter import EkfSlam

    found = set()
    for v in variants or (None,):
        found.add(family(EkfSlam(config if v is None else apply_variant(config, v))))
    return () if found <= {DEFAULT} else tuple(sorted(found))


def engines(families: tuple) -> list:
    """The compiled engines of ``families`` (none: the default family's)."""
    from radarslam.slam._fused import DEFAULT, engine

    return [engine(f) for f in families or (DEFAULT,)]


def cache_is_cold(*families) -> bool:
    """True when numba has no fresh cached machine code of the fused engine of each of ``families``
    (none given: the default family, :func:`fused_families`), the scan simulation or the
    evaluation's matching (no marker for their current source), so that the next compiled run compiles
    first. Where that cannot be told, False."""
    from radarslam.metrics._compiled import match_scans
    from radarslam.simulation._compiled import simulate_scans

    return any(has_fresh_code(d) is False for d in (*engines(families), simulate_scans, match_scans))


def fused_is_cold(*families) -> bool:
    """True when numba has no fresh cached machine code of the fused engine of one of ``families``
    (none given: the default family's)."""
    return any(has_fresh_code(d) is False for d in engines(families))


def _steps_are_cold() -> bool:
    """True when the kernels a short first run needs (the simulation, the evaluation's matching
    and the engine's steps form's, :func:`steps_kernels`) have no fresh cached code."""
    from radarslam.metrics._compiled import match_scans
    from radarslam.simulation._compiled import simulate_scans

    return any(has_fresh_code(d) is False for d in (simulate_scans, match_scans, *steps_kernels()))


def ready(dispatcher) -> bool:
    """True when numba need not compile ``dispatcher`` for its next call: it was compiled in this
    process, or its cache holds fresh machine code."""
    return has_fresh_code(dispatcher) is True
