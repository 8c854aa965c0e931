"""Whether numba's cache already holds the machine code a command needs (docs/speed.md "First run"):
the fused engine of each family, the orchestrator's kernels, the scan simulation and the
evaluation's matching. Nothing here compiles."""

from __future__ import annotations

import os

from radarslam.config import Config
from radarslam.config.variants import Variant, apply_variant


def has_fresh_code(dispatcher) -> bool | None:
    """Whether numba's cache holds machine code of ``dispatcher`` for its current source (an index
    that exists and whose source stamp matches), or None where that cannot be told. A closure (a
    family's engine, :func:`radarslam.slam.fused.engine.engine`) shares its index with the other
    families'; its own entries are those keyed by its closure's values."""
    try:
        cache = dispatcher._cache
        cache_file = cache._cache_file                      # numba's FunctionCache, in-tree or user-wide
        if not os.path.exists(cache_file._index_path):
            return False
        index = cache_file._load_index()                    # {} when stale (another source stamp)
        if dispatcher.py_func.__closure__ is None:
            return bool(index)
        own = cache._index_key(None, dispatcher.targetctx.codegen())[1:]
        return any(key[1:] == own for key in index)
    except (AttributeError, OSError, EOFError, ValueError, TypeError):  # pragma: no cover - another numba layout
        return None


def fused_families(config: Config, variants: tuple[Variant, ...] = ()) -> tuple:
    """The families of the fused engine (:class:`radarslam.slam.fused.engine.Family`) that
    ``config`` under each of ``variants`` (none: ``config`` itself) runs with, as arguments for
    :func:`cache_is_cold`, :func:`fused_is_cold` and :func:`.first_run._filter_ready`: empty when
    that is the default family alone (or the fused engine covers none of them)."""
    from radarslam.slam._fused import DEFAULT, family, why_not
    from radarslam.slam.filter import EkfSlam

    found = set()
    for v in variants or (None,):
        slam = EkfSlam(config if v is None else apply_variant(config, v))
        if why_not(slam) is None:
            found.add(family(slam))
    return () if found <= {DEFAULT} else tuple(sorted(found))


def engines(families: tuple) -> list:
    """The compiled engines of ``families`` (none: the default family's)."""
    from radarslam.slam._fused import DEFAULT, engine

    return [engine(f) for f in families or (DEFAULT,)]


def cache_is_cold(*families) -> bool:
    """True when numba has no fresh cached machine code of the fused engine of each of ``families``
    (none given: the default family, :func:`fused_families`), the scan simulation or the
    evaluation's matching (an index file absent or stale), so that the next compiled run compiles
    first. Where that cannot be told, False."""
    from radarslam.metrics._compiled import match_scans
    from radarslam.simulation._compiled import simulate_scans

    return any(has_fresh_code(d) is False for d in (*engines(families), simulate_scans, match_scans))


def fused_is_cold(*families) -> bool:
    """True when numba has no fresh cached machine code of the fused engine of one of ``families``
    (none given: the default family's)."""
    return any(has_fresh_code(d) is False for d in engines(families))


def _orchestrator_is_cold() -> bool:
    """True when the kernels a short first run needs (the simulation, the evaluation's matching
    and the orchestrator's nearest-neighbour associator) have no fresh cached code."""
    from radarslam.metrics._compiled import match_scans
    from radarslam.simulation._compiled import simulate_scans
    from radarslam.slam._numba import associate_scan

    return any(has_fresh_code(d) is False for d in (simulate_scans, match_scans, associate_scan))


def ready(dispatcher) -> bool:
    """True when numba need not compile ``dispatcher`` for its next call: it was compiled in this
    process, or its cache holds fresh machine code."""
    return bool(getattr(dispatcher, "signatures", ())) or has_fresh_code(dispatcher) is True
