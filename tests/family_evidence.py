"""What a cold compile of the default family's fused engine touches, and what a second process then
reads from the cache (tests/test_engine_families.py). Either gathered by the session's own warm-up,
when it met a cold cache (tests/conftest.py; a fresh clone, CI), or by two processes of the test on
an empty cache of their own (a session whose cache was warm): the same measurements either way.

:func:`default_run_counts` is the COLD measurement: the default variants' runs (the warm-up's
tiny stream) and then how many signatures numba holds for the default engine, its associators and
every other family's code. It holds only for a compile from nothing: a function loaded from the
cache is not gone through, so what it calls gets no signature (measured: with the callees cached,
the nearest-neighbour associator showed none). The session's record is therefore taken only when
the cache held nothing of the package before (:func:`cache_empty`), and the warm-up then loads
nothing from the cache while it compiles (tests/conftest.py ``_compiling_without_loads``: its second
process writes the cache meanwhile). Loads within the
process (a second compiled object of a function this process compiled and cached) are harmless:
the first compile went through the callees, as in the empty-cache process of the test."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: The file that the session's warm-up leaves its evidence in (beside pytest's base temp dirs).
NAME = "default_family_cold.json"


def dispatchers() -> dict:
    """The compiled functions measured, by name."""
    from radarslam.extent import _compiled as extent_compiled
    from radarslam.slam import _fused, _jcbb_numba, _numba
    from radarslam.slam.fused import bias, view

    return {"engine": _fused.engine(_fused.DEFAULT), "nearest": _numba.associate_scan,
            "joint": _numba.joint_batch_associate_scan, "view_associate": view.view_associate,
            "view_terms": view.view_terms, "view_sift": view.view_sift, "view_rows": extent_compiled.view_rows,
            "jcbb": _jcbb_numba.jcbb_associate_scan, "bias": bias._platform_prediction}


def other_engines() -> list:
    from radarslam.slam import _fused

    return [_fused.engine(f) for f in (_fused.Family(True, False, False), _fused.Family(False, True, False),
                                       _fused.Family(False, False, True))]


def counts() -> dict:
    """Signatures numba holds now for each measured function, and for the other families' engines."""
    out = {k: len(d.signatures) for k, d in dispatchers().items()}
    out["others"] = [len(d.signatures) for d in other_engines()]
    return out


def untouched() -> bool:
    """True while nothing measured has a signature in this process (a measurement can start)."""
    c = counts()
    return not any(c.pop("others")) and not any(c.values())


def cache_empty() -> bool:
    """True when numba's cache holds no compiled code of this package (a fresh clone, or an empty
    ``NUMBA_CACHE_DIR``); False where that cannot be told."""
    from numba.core import config

    from radarslam.core.numba_cache import cached_files

    if not config.CACHE_DIR:
        return not cached_files()
    try:
        from numba.core.caching import UserProvidedCacheLocator
    except ImportError:
        return False
    import radarslam

    package = Path(radarslam.__file__).resolve().parent
    for d in {p.parent for p in package.rglob("*.py")}:
        sub = Path(config.CACHE_DIR) / UserProvidedCacheLocator.get_suitable_cache_subpath(str(d / "x.py"))
        if any(sub.glob("*.nbi")):
            return False
    return True


def default_run_counts() -> dict:
    """The COLD measurement in this process (module docstring)."""
    from radarslam.config import profile_config
    from radarslam.config.variants import DEFAULT_VARIANTS
    from radarslam.compiling.warmup import compile_fused

    compile_fused(profile_config(), DEFAULT_VARIANTS)          # what the session's warm-up runs
    return counts()


COLD = "import json, family_evidence; print(json.dumps(family_evidence.default_run_counts()))"

#: A second process on the same cache: what the first-run rule reads from disk.
WARM = """
import json
from radarslam.compiling import policy, readiness, warmup
from radarslam.slam.driver import run_filter
from radarslam.config import profile_config
from radarslam.slam import _fused
view = _fused.Family(True, False, False)
out = {"default_ready": policy._filter_ready(), "view_ready": policy._filter_ready(view),
       "both_ready": policy._filter_ready(_fused.DEFAULT, view), "fused_cold": readiness.fused_is_cold(),
       "view_cold": readiness.fused_is_cold(view)}
run_filter(profile_config(), warmup._tiny_stream())
out["hits"] = sum(_fused.engine(_fused.DEFAULT).stats.cache_hits.values())
out["misses"] = sum(_fused.engine(_fused.DEFAULT).stats.cache_misses.values())
print(json.dumps(out))
"""


def python(code: str, cache: Path | None = None) -> dict:
    """Run ``code`` in a new interpreter (this directory importable), on numba cache ``cache``
    (None: this process's); its last line of output, as JSON."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]))
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = str(cache)
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def record(where: Path, cold: dict) -> None:
    """Called by the session's warm-up right after it compiled the default family from a cold cache
    (``cold``: :func:`counts` then), under its lock: the WARM process on the session's cache, and
    both measurements written to ``where``."""
    where.write_text(json.dumps({"cold": cold, "warm": python(WARM)}))


def read(where: Path) -> tuple[dict, dict] | None:
    """The session's evidence, or None when its warm-up did not compile cold."""
    if not where.is_file():
        return None
    data = json.loads(where.read_text())
    return data["cold"], data["warm"]
